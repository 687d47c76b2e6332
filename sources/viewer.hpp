// The live viewer (library dtflop_viewer, cpp-httplib): a page served on 127.0.0.1 showing the
// latest field image (with its colour bar), the frame rate and the deadline margin, refreshed
// by the page itself as frames are measured.
#pragma once

#include <memory>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace dtflop::live {

class Viewer {
 public:
  // Serves on 127.0.0.1:`port` (1024..65535). Throws InputError when the port cannot be bound.
  explicit Viewer(int port);
  ~Viewer();
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  // The latest field image (BGR, encoded as PNG here) and status (frame, fps, deadline margin,
  // ...: shown as the page's status line).
  void publish(const cv::Mat& image, const nlohmann::json& status);
  std::string url() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dtflop::live
