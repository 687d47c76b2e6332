// Host->device copies of frame-shaped 8-bit images from pageable memory, 1D against 2D, host clock and events; then device->host copies of the DCT cuda backend's sizes (results/portability/dct-cuda-centroid-probe-2026-11-27/README.md).
#include <cuda_runtime.h>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>
#include <algorithm>
#define CK(x) do { cudaError_t e = (x); if (e != cudaSuccess) { printf("%s: %s\n", #x, cudaGetErrorString(e)); exit(1);} } while (0)
static double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
static double med(std::vector<double> v) { std::sort(v.begin(), v.end()); return v[v.size() / 2]; }
int main() {
  cudaStream_t s; CK(cudaStreamCreate(&s));
  cudaEvent_t a, b; CK(cudaEventCreate(&a)); CK(cudaEventCreate(&b));
  const size_t maxb = 64u << 20;
  unsigned char* host = (unsigned char*)malloc(maxb); memset(host, 7, maxb);
  unsigned char* pin; CK(cudaMallocHost(&pin, maxb)); memset(pin, 7, maxb);
  unsigned char* dev; CK(cudaMalloc(&dev, maxb));
  struct Shape { int w, h; };
  Shape shapes[] = {{686, 680}, {712, 626}, {1024, 256}, {1044, 730}, {1258, 1054}, {2574, 2258}, {2048, 2048}, {3354, 1904}, {5250, 4284}, {8192, 4096}};
  printf("%-11s %10s | %9s %9s | %9s %9s | %9s %9s | %9s %9s\n", "shape", "bytes", "1D host", "1D event", "2D host", "2D event", "2Dpit host", "2Dpit ev", "pin host", "pin event");
  for (Shape sh : shapes) {
    const size_t bytes = size_t(sh.w) * sh.h;
    double r[8];
    for (int mode = 0; mode < 4; ++mode) {
      std::vector<double> th, te;
      for (int i = 0; i < 13; ++i) {
        CK(cudaStreamSynchronize(s));
        double t0 = now();
        CK(cudaEventRecord(a, s));
        if (mode == 0) CK(cudaMemcpyAsync(dev, host, bytes, cudaMemcpyHostToDevice, s));
        else if (mode == 1) CK(cudaMemcpy2DAsync(dev, sh.w, host, sh.w, sh.w, sh.h, cudaMemcpyHostToDevice, s));
        else if (mode == 2) CK(cudaMemcpy2DAsync(dev, sh.w, host, sh.w + 64, sh.w, sh.h, cudaMemcpyHostToDevice, s));
        else CK(cudaMemcpyAsync(dev, pin, bytes, cudaMemcpyHostToDevice, s));
        CK(cudaEventRecord(b, s));
        CK(cudaStreamSynchronize(s));
        double t1 = now();
        float ms; CK(cudaEventElapsedTime(&ms, a, b));
        if (i >= 3) { th.push_back((t1 - t0) * 1e6); te.push_back(ms * 1e3); }
      }
      r[2 * mode] = med(th); r[2 * mode + 1] = med(te);
    }
    char name[32]; snprintf(name, sizeof name, "%dx%d", sh.w, sh.h);
    printf("%-11s %10zu | %9.1f %9.1f | %9.1f %9.1f | %9.1f %9.1f | %9.1f %9.1f  (us)\n", name, bytes, r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7]);
  }
  // device->host, pageable and pinned, the DCT backend's sizes, behind an idle stream
  printf("\nD2H          bytes | pageable host  event | pinned host  event\n");
  for (size_t bytes : {8ul, 23100ul, 48356ul, 262144ul, 4194304ul}) {
    double r[4];
    for (int mode = 0; mode < 2; ++mode) {
      std::vector<double> th, te;
      for (int i = 0; i < 23; ++i) {
        CK(cudaStreamSynchronize(s));
        double t0 = now();
        CK(cudaEventRecord(a, s));
        CK(cudaMemcpyAsync(mode ? pin : host, dev, bytes, cudaMemcpyDeviceToHost, s));
        CK(cudaEventRecord(b, s));
        CK(cudaStreamSynchronize(s));
        double t1 = now();
        float ms; CK(cudaEventElapsedTime(&ms, a, b));
        if (i >= 3) { th.push_back((t1 - t0) * 1e6); te.push_back(ms * 1e3); }
      }
      r[2 * mode] = med(th); r[2 * mode + 1] = med(te);
    }
    printf("%18zu | %9.1f %9.1f | %9.1f %9.1f (us)\n", bytes, r[0], r[1], r[2], r[3]);
  }
  return 0;
}
