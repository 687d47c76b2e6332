// Otsu's histogram on one rendered frame (the 2-vCPU VM): the DCT CPU backends' former single
// histogram against kernels::Histogram256's four interleaved ones, ns a pixel, medians of 41; both
// checked equal. Frames: `dtflop specimen "reference:size=1024x1024,pattern=random,radius=8,count=400[,noise=N]" -o DIR`.
// Build: g++ -O2 -std=c++20 -I. histogram-cost.cpp $(pkg-config --cflags --libs opencv4) (from the repository root).
#include <opencv2/imgcodecs.hpp>
#include <opencv2/core.hpp>
#include <chrono>
#include <cstdio>
#include <vector>
#include <algorithm>
#include "kernels/histogram.hpp"
int main(int argc, char** argv) {
  cv::Mat img = cv::imread(argv[1], cv::IMREAD_UNCHANGED);
  if (img.empty() || img.depth() != CV_8U) return 1;
  long same = 0;
  for (int i = 0; i < img.rows; ++i) { const auto* p = img.ptr<unsigned char>(i); for (int j = 1; j < img.cols; ++j) same += p[j] == p[j - 1]; }
  std::vector<double> one, four;
  for (int r = 0; r < 41; ++r) {
    auto t0 = std::chrono::steady_clock::now();
    std::vector<std::int64_t> h(256, 0);
    for (int i = 0; i < img.rows; ++i) { const auto* p = img.ptr<std::uint8_t>(i); for (int j = 0; j < img.cols; ++j) ++h[p[j]]; }
    auto t1 = std::chrono::steady_clock::now();
    dtflop::kernels::Histogram256 c;
    for (int i = 0; i < img.rows; ++i) c.add(img.ptr<std::uint8_t>(i), static_cast<std::size_t>(img.cols));
    const auto t = c.total();
    auto t2 = std::chrono::steady_clock::now();
    for (int v = 0; v < 256; ++v) if (t[v] != h[v]) return 2;
    one.push_back(std::chrono::duration<double>(t1 - t0).count()); four.push_back(std::chrono::duration<double>(t2 - t1).count());
  }
  std::sort(one.begin(), one.end()); std::sort(four.begin(), four.end());
  const double px = double(img.total());
  std::printf("%dx%d: equal neighbours %.3f; one histogram %.3f ns/px, four interleaved %.3f ns/px (medians of 41)\n", img.cols, img.rows, double(same) / px, one[20] / px * 1e9, four[20] / px * 1e9);
}
