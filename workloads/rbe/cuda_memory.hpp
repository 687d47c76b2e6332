// RAII owners of CUDA resources for the RBE backends (device and pinned host arrays, a stream,
// events, an instantiated graph). Every CUDA call is checked (cuda_check.hpp).
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>
#include <utility>
#include <vector>

#include "cuda/check.hpp"

namespace dtflop::rbe::detail {

template <class T>
class DeviceArray {
 public:
  DeviceArray() = default;
  explicit DeviceArray(std::size_t n) : n_(n) {
    if (n) DTFLOP_CUDA(cudaMalloc(reinterpret_cast<void**>(&p_), n * sizeof(T)));
  }
  ~DeviceArray() {
    if (p_) cudaFree(p_);
  }
  DeviceArray(DeviceArray&& o) noexcept : p_(std::exchange(o.p_, nullptr)), n_(std::exchange(o.n_, 0)) {}
  DeviceArray& operator=(DeviceArray&& o) noexcept {
    std::swap(p_, o.p_);
    std::swap(n_, o.n_);
    return *this;
  }
  T* get() const { return p_; }
  std::size_t size() const { return n_; }
  void upload(const T* host, std::size_t n) {
    DTFLOP_CUDA(cudaMemcpy(p_, host, n * sizeof(T), cudaMemcpyHostToDevice));
  }
  void upload(const std::vector<T>& host) { upload(host.data(), host.size()); }
  // Rows of a pitched grid: `rows` rows of `width` values, `pitch` values apart here and
  // `width` apart (packed) on the host; the padding between rows is left as it is.
  void upload_rows(const T* host, std::size_t width, std::size_t rows, std::size_t pitch) {
    DTFLOP_CUDA(cudaMemcpy2D(p_, pitch * sizeof(T), host, width * sizeof(T), width * sizeof(T), rows,
                             cudaMemcpyHostToDevice));
  }
  void download_rows(T* host, std::size_t width, std::size_t rows, std::size_t pitch) const {
    DTFLOP_CUDA(cudaMemcpy2D(host, width * sizeof(T), p_, pitch * sizeof(T), width * sizeof(T), rows,
                             cudaMemcpyDeviceToHost));
  }

 private:
  T* p_ = nullptr;
  std::size_t n_ = 0;
};

// Host memory, pinned (page-locked, cudaMallocHost) or pageable (ordinary heap).
template <class T>
class HostArray {
 public:
  HostArray() = default;
  HostArray(std::size_t n, bool pinned) : n_(n), pinned_(pinned) {
    if (!n) return;
    if (pinned) DTFLOP_CUDA(cudaMallocHost(reinterpret_cast<void**>(&p_), n * sizeof(T)));
    else p_ = new T[n]();
  }
  ~HostArray() { release(); }
  HostArray(HostArray&& o) noexcept
      : p_(std::exchange(o.p_, nullptr)), n_(std::exchange(o.n_, 0)), pinned_(o.pinned_) {}
  HostArray& operator=(HostArray&& o) noexcept {
    std::swap(p_, o.p_);
    std::swap(n_, o.n_);
    std::swap(pinned_, o.pinned_);
    return *this;
  }
  T* get() const { return p_; }
  T& operator[](std::size_t i) const { return p_[i]; }
  std::size_t size() const { return n_; }

 private:
  void release() {
    if (!p_) return;
    if (pinned_) cudaFreeHost(p_);
    else delete[] p_;
    p_ = nullptr;
  }
  T* p_ = nullptr;
  std::size_t n_ = 0;
  bool pinned_ = false;
};

class Stream {
 public:
  Stream() { DTFLOP_CUDA(cudaStreamCreateWithFlags(&s_, cudaStreamNonBlocking)); }
  // A stream whose blocks the scheduler starts before those of normal streams, as soon as a
  // multiprocessor has room (the device's greatest priority).
  struct Urgent {};
  explicit Stream(Urgent) {
    int least = 0, greatest = 0;
    DTFLOP_CUDA(cudaDeviceGetStreamPriorityRange(&least, &greatest));
    DTFLOP_CUDA(cudaStreamCreateWithPriority(&s_, cudaStreamNonBlocking, greatest));
  }
  ~Stream() {
    if (s_) cudaStreamDestroy(s_);
  }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  cudaStream_t get() const { return s_; }
  void sync() const { DTFLOP_CUDA(cudaStreamSynchronize(s_)); }

 private:
  cudaStream_t s_ = nullptr;
};

class Events {
 public:
  explicit Events(std::size_t n) : e_(n, nullptr) {
    for (auto& e : e_) DTFLOP_CUDA(cudaEventCreate(&e));
  }
  ~Events() {
    for (auto e : e_)
      if (e) cudaEventDestroy(e);
  }
  Events(const Events&) = delete;
  Events& operator=(const Events&) = delete;
  cudaEvent_t operator[](std::size_t i) const { return e_[i]; }
  std::size_t size() const { return e_.size(); }
  double seconds(std::size_t a, std::size_t b) const {
    float ms = 0;
    DTFLOP_CUDA(cudaEventElapsedTime(&ms, e_[a], e_[b]));
    return double(ms) * 1e-3;
  }

 private:
  std::vector<cudaEvent_t> e_;
};

class GraphExec {
 public:
  GraphExec() = default;
  explicit GraphExec(cudaGraph_t g) {
    DTFLOP_CUDA(cudaGraphInstantiate(&exec_, g, 0));
  }
  ~GraphExec() {
    if (exec_) cudaGraphExecDestroy(exec_);
  }
  GraphExec(GraphExec&& o) noexcept : exec_(std::exchange(o.exec_, nullptr)) {}
  GraphExec& operator=(GraphExec&& o) noexcept {
    std::swap(exec_, o.exec_);
    return *this;
  }
  cudaGraphExec_t get() const { return exec_; }

 private:
  cudaGraphExec_t exec_ = nullptr;
};

}  // namespace dtflop::rbe::detail
