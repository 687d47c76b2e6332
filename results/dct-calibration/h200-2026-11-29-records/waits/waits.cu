// What does a DCT-cuda-like host wait cost beyond the device's busy time?
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>
#include <cuda_runtime.h>
#define CK(x) do { cudaError_t e_ = (x); if (e_ != cudaSuccess) { std::printf("%s: %s\n", #x, cudaGetErrorString(e_)); std::exit(1);} } while (0)
__global__ void k_empty() {}
__global__ void k_spin(long long cycles) { long long t0 = clock64(); while (clock64() - t0 < cycles) {} }
static double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
static double med(std::vector<double> v) { std::sort(v.begin(), v.end()); return v[v.size() / 2]; }
static volatile double sink;
static void host_work(const std::vector<double>& buf, double seconds) {  // touch memory for about `seconds`
  const double t0 = now(); double s = 0; std::size_t i = 0;
  while (now() - t0 < seconds) { for (int k = 0; k < 512; ++k) s += buf[(i++ * 64) % buf.size()]; }
  sink = s;
}
int main(int argc, char** argv) {
  const char* mode = argc > 1 ? argv[1] : "auto";
  if (!std::strcmp(mode, "spin")) CK(cudaSetDeviceFlags(cudaDeviceScheduleSpin));
  if (!std::strcmp(mode, "yield")) CK(cudaSetDeviceFlags(cudaDeviceScheduleYield));
  if (!std::strcmp(mode, "blocking")) CK(cudaSetDeviceFlags(cudaDeviceScheduleBlockingSync));
  cudaStream_t s; CK(cudaStreamCreateWithFlags(&s, cudaStreamNonBlocking));
  cudaEvent_t a, b; CK(cudaEventCreate(&a)); CK(cudaEventCreate(&b));
  int clk = 0; CK(cudaDeviceGetAttribute(&clk, cudaDevAttrClockRate, 0));  // kHz
  const long long c10 = (long long)clk * 10 / 1000;  // ~10 us
  char *h_big, *h_small, *d_big, *d_small; std::vector<char> pageable(1 << 20);
  CK(cudaMallocHost(&h_big, 1 << 20)); CK(cudaMallocHost(&h_small, 1 << 16));
  CK(cudaMalloc(&d_big, 1 << 20)); CK(cudaMalloc(&d_small, 1 << 16));
  std::vector<double> buf(1 << 18, 1.0);  // 2 MiB
  const int R = 2000;
  auto host_med = [&](auto&& body) { std::vector<double> t; for (int r = 0; r < R; ++r) { double t0 = now(); body(); t.push_back(now() - t0); } return med(t) * 1e6; };
  auto dev_med = [&](auto&& body) {  // events around body, batch of 1 each, median
    std::vector<double> t; for (int r = 0; r < R / 4; ++r) { CK(cudaEventRecord(a, s)); body(); CK(cudaEventRecord(b, s)); CK(cudaEventSynchronize(b)); float ms; CK(cudaEventElapsedTime(&ms, a, b)); t.push_back(ms * 1e-3); } return med(t) * 1e6; };
  auto batch_med = [&](auto&& body) {  // back to back, per op
    std::vector<double> t; for (int r = 0; r < 20; ++r) { CK(cudaEventRecord(a, s)); for (int i = 0; i < 100; ++i) body(); CK(cudaEventRecord(b, s)); CK(cudaEventSynchronize(b)); float ms; CK(cudaEventElapsedTime(&ms, a, b)); t.push_back(ms * 1e-3 / 100); } return med(t) * 1e6; };
  auto sync = [&] { CK(cudaStreamSynchronize(s)); };
  for (int w = 0; w < 200; ++w) { k_empty<<<1, 32, 0, s>>>(); sync(); }
  std::printf("mode %s\n", mode);
  std::printf("launch+sync (the probe's L_wait): %.2f us\n", host_med([&] { k_empty<<<1, 32, 0, s>>>(); sync(); }));
  std::printf("back-to-back empty launch (L_launch): %.2f us\n", batch_med([&] { k_empty<<<1, 32, 0, s>>>(); }));
  std::printf("tiny H2D pinned, events around one: %.2f us; back to back %.2f us\n", dev_med([&] { CK(cudaMemcpyAsync(d_small, h_small, 8, cudaMemcpyHostToDevice, s)); }), batch_med([&] { CK(cudaMemcpyAsync(d_small, h_small, 8, cudaMemcpyHostToDevice, s)); }));
  std::printf("tiny D2H pinned, events around one: %.2f us; back to back %.2f us\n", dev_med([&] { CK(cudaMemcpyAsync(h_small, d_small, 8, cudaMemcpyDeviceToHost, s)); }), batch_med([&] { CK(cudaMemcpyAsync(h_small, d_small, 8, cudaMemcpyDeviceToHost, s)); }));
  std::printf("10us spin kernel back to back: %.2f us; events around one %.2f us\n", batch_med([&] { k_spin<<<1, 32, 0, s>>>(c10); }), dev_med([&] { k_spin<<<1, 32, 0, s>>>(c10); }));
  auto seq = [&](int kernels, bool spin, bool pageable_up) {
    CK(cudaMemcpyAsync(d_big, pageable_up ? pageable.data() : h_big, 300000, cudaMemcpyHostToDevice, s));
    for (int k = 0; k < kernels; ++k) { if (spin) k_spin<<<1, 32, 0, s>>>(c10); else k_empty<<<1, 32, 0, s>>>(); }
    CK(cudaMemcpyAsync(h_small, d_small, 8, cudaMemcpyDeviceToHost, s));
  };
  for (int pg = 0; pg < 2; ++pg)
    for (int spin = 0; spin < 2; ++spin)
      for (int k : {1, 4}) {
        const double host = host_med([&] { seq(k, spin, pg); sync(); });
        const double span = dev_med([&] { seq(k, spin, pg); });
        const double withwork = host_med([&] { host_work(buf, 30e-6); seq(k, spin, pg); sync(); }) - 30.0;
        std::printf("wait of [H2D 300 kB %s, %d %s kernel(s), D2H 8 B]: host %.2f us, event span %.2f, host-span %.2f; after 30 us of host work: host %.2f (-span %.2f)\n",
                    pg ? "pageable" : "pinned", k, spin ? "10-us" : "empty", host, span, host - span, withwork, withwork - span);
      }
  return 0;
}
