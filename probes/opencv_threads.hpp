// OpenCV's thread count for a scope, as the DCT workload's CPU backends set it: probes that run
// the workload's OpenCV-parallel code (cpu-pixel, cpu-mls) run it on the threads it gets there.
#pragma once

#include <opencv2/core.hpp>

namespace dtflop::probes {

class OpenCvThreads {
 public:
  explicit OpenCvThreads(int n) : old_(cv::getNumThreads()) { cv::setNumThreads(n); }
  ~OpenCvThreads() { cv::setNumThreads(old_); }
  OpenCvThreads(const OpenCvThreads&) = delete;
  OpenCvThreads& operator=(const OpenCvThreads&) = delete;

 private:
  int old_;
};

}  // namespace dtflop::probes
