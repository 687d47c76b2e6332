// The CUPTI Activity API profiler (see profiler.hpp). Compiled only when dtflop is built with
// CUDA and the toolkit's CUPTI library was found.
#include <cuda_runtime.h>
#include <cupti.h>

#include <atomic>
#include <cstdlib>
#include <mutex>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "calibrate/profiler.hpp"

namespace dtflop::calib {

namespace {

constexpr std::size_t kBufferBytes = 8u << 20;  // per activity buffer

std::mutex g_mu;
std::vector<ActivityRecord> g_records;  // delivered records (guarded by g_mu)
std::uint64_t g_dropped = 0;            // guarded by g_mu
std::atomic<bool> g_in_use{false};
bool g_callbacks_registered = false;

std::string cupti_error(CUptiResult r) {
  const char* s = nullptr;
  if (cuptiGetResultString(r, &s) != CUPTI_SUCCESS || s == nullptr) return fmt::format("CUPTI error {}", int(r));
  return s;
}

void CUPTIAPI buffer_requested(uint8_t** buffer, size_t* size, size_t* max_records) {
  *buffer = static_cast<uint8_t*>(std::aligned_alloc(8, kBufferBytes));
  *size = *buffer ? kBufferBytes : 0;
  *max_records = 0;  // as many as fit
}

ActivityRecord::Direction direction(uint8_t copy_kind) {
  switch (copy_kind) {
    case CUPTI_ACTIVITY_MEMCPY_KIND_HTOD:
    case CUPTI_ACTIVITY_MEMCPY_KIND_HTOA: return ActivityRecord::Direction::to_device;
    case CUPTI_ACTIVITY_MEMCPY_KIND_DTOH:
    case CUPTI_ACTIVITY_MEMCPY_KIND_ATOH: return ActivityRecord::Direction::to_host;
    case CUPTI_ACTIVITY_MEMCPY_KIND_DTOD:
    case CUPTI_ACTIVITY_MEMCPY_KIND_DTOA:
    case CUPTI_ACTIVITY_MEMCPY_KIND_ATOD:
    case CUPTI_ACTIVITY_MEMCPY_KIND_ATOA: return ActivityRecord::Direction::on_device;
    default: return ActivityRecord::Direction::other;
  }
}

void CUPTIAPI buffer_completed(CUcontext ctx, uint32_t stream_id, uint8_t* buffer, size_t /*size*/,
                               size_t valid) {
  std::vector<ActivityRecord> local;
  CUpti_Activity* rec = nullptr;
  while (valid > 0 && cuptiActivityGetNextRecord(buffer, valid, &rec) == CUPTI_SUCCESS) {
    ActivityRecord r;
    switch (rec->kind) {
      case CUPTI_ACTIVITY_KIND_MEMCPY: {
        const auto* m = reinterpret_cast<const CUpti_ActivityMemcpy6*>(rec);
        r.kind = ActivityRecord::Kind::copy;
        r.start = m->start;
        r.end = m->end;
        r.bytes = m->bytes;
        r.direction = direction(m->copyKind);
        const uint8_t host_side = r.direction == ActivityRecord::Direction::to_host ? m->dstKind : m->srcKind;
        r.pageable = host_side == CUPTI_ACTIVITY_MEMORY_KIND_PAGEABLE;
        break;
      }
      case CUPTI_ACTIVITY_KIND_CONCURRENT_KERNEL:
      case CUPTI_ACTIVITY_KIND_KERNEL: {
        const auto* k = reinterpret_cast<const CUpti_ActivityKernel10*>(rec);
        r.kind = ActivityRecord::Kind::kernel;
        r.start = k->start;
        r.end = k->end;
        r.name = k->name ? k->name : "?";
        break;
      }
      case CUPTI_ACTIVITY_KIND_RUNTIME: {
        const auto* a = reinterpret_cast<const CUpti_ActivityAPI*>(rec);
        r.kind = ActivityRecord::Kind::api;
        r.start = a->start;
        r.end = a->end;
        const char* name = nullptr;
        if (cuptiGetCallbackName(CUPTI_CB_DOMAIN_RUNTIME_API, a->cbid, &name) == CUPTI_SUCCESS && name)
          r.name = name;
        break;
      }
      default: continue;
    }
    local.push_back(std::move(r));
  }
  size_t dropped = 0;
  cuptiActivityGetNumDroppedRecords(ctx, stream_id, &dropped);
  std::free(buffer);
  std::lock_guard<std::mutex> lock(g_mu);
  g_records.insert(g_records.end(), std::make_move_iterator(local.begin()),
                   std::make_move_iterator(local.end()));
  g_dropped += dropped;
}

void check_cuda(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw std::runtime_error(fmt::format("{} failed: {}", what, cudaGetErrorString(e)));
}
void check_cupti(CUptiResult r, const char* what) {
  if (r != CUPTI_SUCCESS) throw std::runtime_error(fmt::format("{} failed: {}", what, cupti_error(r)));
}

class CuptiProfiler final : public ActivityProfiler {
 public:
  CuptiProfiler() = default;
  ~CuptiProfiler() override {
    if (tracing_) stop();
    cuptiActivityFlushAll(CUPTI_ACTIVITY_FLAG_FLUSH_FORCED);
    {
      std::lock_guard<std::mutex> lock(g_mu);
      g_records.clear();
    }
    g_in_use = false;
  }

  void begin() override {
    check_cuda(cudaDeviceSynchronize(), "cudaDeviceSynchronize before a profiled range");
    start();
    // Drop whatever was delivered before this range.
    check_cupti(cuptiActivityFlushAll(CUPTI_ACTIVITY_FLAG_FLUSH_FORCED), "cuptiActivityFlushAll");
    {
      std::lock_guard<std::mutex> lock(g_mu);
      g_records.clear();
      g_dropped = 0;
    }
    check_cupti(cuptiGetTimestamp(&t0_), "cuptiGetTimestamp");
  }

  DeviceActivity end() override {
    check_cuda(cudaDeviceSynchronize(), "cudaDeviceSynchronize after a profiled range");
    std::uint64_t t1 = 0;
    check_cupti(cuptiGetTimestamp(&t1), "cuptiGetTimestamp");
    stop();
    check_cupti(cuptiActivityFlushAll(CUPTI_ACTIVITY_FLAG_FLUSH_FORCED), "cuptiActivityFlushAll");
    std::vector<ActivityRecord> records;
    std::uint64_t dropped = 0;
    {
      std::lock_guard<std::mutex> lock(g_mu);
      records.swap(g_records);
      dropped = g_dropped;
    }
    DeviceActivity a = aggregate(records, t0_, t1);
    a.dropped_records = dropped;
    a.begin_ns = t0_;
    a.end_ns = t1;
    a.records = std::move(records);
    return a;
  }

 private:
  void start() {
    check_cupti(cuptiActivityEnable(CUPTI_ACTIVITY_KIND_MEMCPY), "enabling CUPTI memcpy records");
    check_cupti(cuptiActivityEnable(CUPTI_ACTIVITY_KIND_CONCURRENT_KERNEL), "enabling CUPTI kernel records");
    // Runtime API records (the host side of launches and copies). Selecting single functions
    // with cuptiActivityEnableRuntimeApi delivered nothing on CUDA 13 (seen on an H200), so
    // the whole kind is enabled; only traced repetitions pay for it.
    runtime_ = cuptiActivityEnable(CUPTI_ACTIVITY_KIND_RUNTIME) == CUPTI_SUCCESS;
    tracing_ = true;
  }
  void stop() {
    cuptiActivityDisable(CUPTI_ACTIVITY_KIND_MEMCPY);
    cuptiActivityDisable(CUPTI_ACTIVITY_KIND_CONCURRENT_KERNEL);
    if (runtime_) cuptiActivityDisable(CUPTI_ACTIVITY_KIND_RUNTIME);
    tracing_ = false;
  }
  bool runtime_ = false;
  std::uint64_t t0_ = 0;
  bool tracing_ = false;
};

}  // namespace

ProfilerOpen open_cupti_profiler() {
  int devices = 0;
  const cudaError_t e = cudaGetDeviceCount(&devices);
  if (e != cudaSuccess || devices == 0) {
    (void)cudaGetLastError();
    return {nullptr, fmt::format("no usable CUDA device ({})",
                                 e != cudaSuccess ? cudaGetErrorString(e) : "none found")};
  }
  if (g_in_use.exchange(true))
    return {nullptr, "a CUPTI profiler is already open in this process (CUPTI allows one)"};
  auto fail = [](std::string why) {
    g_in_use = false;
    return ProfilerOpen{nullptr, std::move(why)};
  };
  // Create the context first: CUPTI then attaches to it.
  const cudaError_t f = cudaFree(nullptr);
  if (f != cudaSuccess) return fail(fmt::format("CUDA context creation failed: {}", cudaGetErrorString(f)));
  if (!g_callbacks_registered) {
    const CUptiResult r = cuptiActivityRegisterCallbacks(buffer_requested, buffer_completed);
    if (r != CUPTI_SUCCESS) {
      std::string hint;
      if (r == CUPTI_ERROR_MULTIPLE_SUBSCRIBERS_NOT_SUPPORTED)
        hint = " (another tool, e.g. Nsight Systems or Compute, is already subscribed)";
      else if (r == CUPTI_ERROR_INSUFFICIENT_PRIVILEGES)
        hint = " (this user may not profile the GPU; see NVIDIA's ERR_NVGPUCTRPERM notes)";
      return fail(fmt::format("CUPTI activity tracing could not start: {}{}", cupti_error(r), hint));
    }
    g_callbacks_registered = true;
  }
  // Probe that the kinds can be enabled, then leave tracing off until begin().
  for (auto kind : {CUPTI_ACTIVITY_KIND_MEMCPY, CUPTI_ACTIVITY_KIND_CONCURRENT_KERNEL}) {
    const CUptiResult r = cuptiActivityEnable(kind);
    if (r != CUPTI_SUCCESS) {
      std::string hint;
      if (r == CUPTI_ERROR_MULTIPLE_SUBSCRIBERS_NOT_SUPPORTED) hint = " (another tool is already subscribed)";
      else if (r == CUPTI_ERROR_INSUFFICIENT_PRIVILEGES) hint = " (insufficient permissions)";
      return fail(fmt::format("CUPTI refused activity kind {}: {}{}", int(kind), cupti_error(r), hint));
    }
    cuptiActivityDisable(kind);
  }
  return {std::make_unique<CuptiProfiler>(), {}};
}

}  // namespace dtflop::calib
