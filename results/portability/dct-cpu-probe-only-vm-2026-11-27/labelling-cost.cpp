// Per-pixel passes of the DCT CPU analysis (a 256-bin histogram; OpenCV threshold + 8-connected labelling with statistics) on frames of 1 to 22.5 MP, one thread: ns a pixel (results/portability/dct-cpu-probe-only-vm-2026-11-27/README.md).
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <chrono>
#include <cstdio>
#include <random>
#include <array>
#include <algorithm>
int main() {
  for (int side : {1024, 2048, 3400, 4743}) {
    cv::Mat img(side, side, CV_8U);
    std::mt19937_64 rng(1); std::uniform_int_distribution<int> g(180, 220);
    for (int y = 0; y < side; ++y) for (int x = 0; x < side; ++x) img.at<uchar>(y, x) = g(rng);
    for (int cy = 25; cy < side - 25; cy += 51) for (int cx = 25; cx < side - 25; cx += 51) cv::circle(img, {cx, cy}, 8, 40, -1);
    cv::Mat mask, labels, stats, cents;
    std::vector<double> th, tl;
    for (int r = 0; r < 6; ++r) {
      auto t0 = std::chrono::steady_clock::now();
      std::array<long, 256> h{}; for (int y = 0; y < side; ++y) { const uchar* p = img.ptr(y); for (int x = 0; x < side; ++x) ++h[p[x]]; }
      auto t1 = std::chrono::steady_clock::now();
      cv::threshold(img, mask, 128, 255, cv::THRESH_BINARY_INV);
      int n = cv::connectedComponentsWithStats(mask, labels, stats, cents, 8, CV_32S, cv::CCL_DEFAULT);
      auto t2 = std::chrono::steady_clock::now();
      if (r) { th.push_back(std::chrono::duration<double>(t1 - t0).count()); tl.push_back(std::chrono::duration<double>(t2 - t1).count()); }
      if (n < 2 || h[40] == 0) return 1;
    }
    std::sort(th.begin(), th.end()); std::sort(tl.begin(), tl.end());
    double px = double(side) * side;
    printf("%5d: histogram %.2f ns/px, threshold+labelling %.2f ns/px\n", side, th[2] / px * 1e9, tl[2] / px * 1e9);
  }
}
