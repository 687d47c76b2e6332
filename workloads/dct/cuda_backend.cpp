// The cuda backend of the DCT pipeline. Per deformed frame:
//   upload (pinned or pageable) -> [Otsu histogram] -> threshold + label init -> union-find
//   over 8-neighbours -> compress -> roots to ids -> count to host -> per-component stats
//   (warp-aggregated atomics) -> per-dot filter + centroid (one block per component, eq. 7.1
//   with the shared kernels.hpp arithmetic) -> records to host -> the records' pass (tallied,
//   radix-ordered by root, kernels/component_records.hpp) -> matching on the host (a grid of
//   cells, tracking.hpp) -> match table up -> displacements -> MLS or FE, one thread per point, from the
//   look-up table in device memory -> fields to host.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <tuple>

#include <cuda_runtime.h>
#include <fmt/format.h>

#include "kernels/component_records.hpp"
#include "model/errors.hpp"
#include "workloads/dct/backend.hpp"
#include "workloads/dct/cuda_kernels.hpp"

namespace dtflop::dct {
namespace {

using namespace gpu;

template <class T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  ~DeviceBuffer() { if (p_) cudaFree(p_); }
  T* ensure(std::size_t n) {
    if (n > n_) {
      if (p_) DTFLOP_CUDA(cudaFree(p_));
      p_ = nullptr;
      DTFLOP_CUDA(cudaMalloc(&p_, std::max<std::size_t>(n, 1) * sizeof(T)));
      n_ = n;
    }
    return p_;
  }
  T* get() const { return p_; }

 private:
  T* p_ = nullptr;
  std::size_t n_ = 0;
};

class PinnedBuffer {
 public:
  PinnedBuffer() = default;
  PinnedBuffer(const PinnedBuffer&) = delete;
  PinnedBuffer& operator=(const PinnedBuffer&) = delete;
  ~PinnedBuffer() { if (p_) cudaFreeHost(p_); }
  void* ensure(std::size_t bytes) {
    if (bytes > n_) {
      if (p_) DTFLOP_CUDA(cudaFreeHost(p_));
      p_ = nullptr;
      DTFLOP_CUDA(cudaMallocHost(&p_, bytes));
      n_ = bytes;
    }
    return p_;
  }
  void* get() const { return p_; }

 private:
  void* p_ = nullptr;
  std::size_t n_ = 0;
};

// A host array the device copies to or from: pinned (cudaMallocHost) or pageable, chosen once, so
// that every copy of a frame uses the host memory its counts declare (the frames' kind).
template <class T>
class HostArray {
 public:
  explicit HostArray(bool pinned) : pinned_(pinned) {}
  HostArray(const HostArray&) = delete;
  HostArray& operator=(const HostArray&) = delete;
  ~HostArray() { release(); }
  void resize(std::size_t n) {
    if (n <= cap_) {
      n_ = n;
      return;
    }
    release();
    const std::size_t bytes = std::max<std::size_t>(n, 1) * sizeof(T);
    if (pinned_) {
      void* p = nullptr;
      DTFLOP_CUDA(cudaMallocHost(&p, bytes));
      p_ = static_cast<T*>(p);
    } else {
      p_ = static_cast<T*>(::operator new(bytes));
    }
    cap_ = n_ = n;
  }
  T* data() { return p_; }
  std::size_t size() const { return n_; }
  T& operator[](std::size_t i) { return p_[i]; }
  const T& operator[](std::size_t i) const { return p_[i]; }

 private:
  void release() {
    if (!p_) return;
    if (pinned_) cudaFreeHost(p_);
    else ::operator delete(p_);
    p_ = nullptr;
    cap_ = n_ = 0;
  }
  bool pinned_;
  T* p_ = nullptr;
  std::size_t n_ = 0, cap_ = 0;
};

// The component records the host reads back, in one array so that one copy brings them all:
// x, y (double), weight (float), status, area, root (int) and 3 pixel counts (int), each nc long,
// the 8-byte arrays first. kCudaRecordBytes a component, as cuda_counts declares the copy.
struct Records {
  double* x;
  double* y;
  float* weight;
  int* status;
  int* area;
  int* root;
  int* pixels;
  static Records over(void* base, std::size_t nc) {
    auto* d = static_cast<double*>(base);
    auto* w = reinterpret_cast<float*>(d + 2 * nc);
    auto* i = reinterpret_cast<int*>(w + nc);
    return {d, d + nc, w, i, i + nc, i + 2 * nc, i + 3 * nc};
  }
  static std::size_t doubles(std::size_t nc) { return (static_cast<std::size_t>(kCudaRecordBytes) * nc + 7) / 8; }
};
static_assert(kCudaRecordBytes == 2 * sizeof(double) + sizeof(float) + 6 * sizeof(int));

double host_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

class Events {
 public:
  Events() {
    for (auto& e : e_) DTFLOP_CUDA(cudaEventCreate(&e));
  }
  ~Events() {
    for (auto& e : e_) cudaEventDestroy(e);
  }
  Events(const Events&) = delete;
  Events& operator=(const Events&) = delete;
  void record(int k, cudaStream_t s) {
    if (on) DTFLOP_CUDA(cudaEventRecord(e_[k], s));
  }
  double between(int a, int b) const {
    float ms = 0;
    DTFLOP_CUDA(cudaEventElapsedTime(&ms, e_[a], e_[b]));
    return ms * 1e-3;
  }

  bool on = false;  // record only when the device stages are timed (Backend::time_device_stages)

 private:
  cudaEvent_t e_[10]{};
};

class CudaBackend final : public Backend {
 public:
  explicit CudaBackend(const PipelineOptions& o) : Backend(o) {
    if (o.analysis.method == ThresholdMethod::adaptive)
      throw InputError("the cuda backend thresholds with a fixed or an Otsu threshold; adaptive thresholding runs "
                       "on cpu-seq and cpu-par");
    const auto& l = o.layout;
    for (int b : {l.block_pixels, l.block_points, l.block_dots})
      if (b < 32 || b > 1024 || b % 32 != 0)
        throw InputError(fmt::format("CUDA block sizes must be multiples of 32 in 32..1024 (got {}, {}, {})",
                                     l.block_pixels, l.block_points, l.block_dots));
    // A block size the workload allows can still be more than a kernel's registers let a block run
    // on this device (the fields kernel: 768 threads on an H100): refused before any frame.
    const BlockLimits lim = block_limits();
    for (auto [name, asked, most] : {std::tuple{"block-pixels", l.block_pixels, lim.pixels},
                                     std::tuple{"block-points", l.block_points, lim.points},
                                     std::tuple{"block-dots", l.block_dots, lim.dots}})
      if (asked > most)
        throw InputError(fmt::format("{} {}: the kernels it sizes run at most {} threads a block on this GPU (their "
                                     "registers); use {} or fewer",
                                     name, asked, most, most / 32 * 32));
    DTFLOP_CUDA(cudaStreamCreate(&stream_));
  }
  ~CudaBackend() override { if (stream_) cudaStreamDestroy(stream_); }

  std::string name() const override { return "cuda"; }

  void time_device_stages(bool on) override { ev_.on = on; }

  cv::Mat frame_buffer(cv::Size size, int type) override {
    void* p = pinned_.ensure(size.area() * CV_ELEM_SIZE(type));
    return cv::Mat(size, type, p);
  }

  void set_reference(const cv::Mat& image) override {
    validate(options().analysis, image.size());
    if (image.empty() || image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U))
      throw InputError("the image must be one-channel 8- or 16-bit grey");
    Found f = find_dots(image, nullptr);
    state().accept_reference(image, f.dots, f.stats);
    const std::vector<Vec2>& ref_pos = state().reference_positions();
    const std::vector<Vec2>& points = state().points();
    const MlsTable& mls = state().mls_table();
    const FeTable& fe = state().fe_table();
    // Reference positions, the table and the points go to the device once.
    std::vector<double2> ref(ref_pos.size());
    for (std::size_t j = 0; j < ref.size(); ++j) ref[j] = make_double2(ref_pos[j].x, ref_pos[j].y);
    upload(d_ref_, ref);
    std::vector<double2> pts(points.size());
    for (std::size_t m = 0; m < pts.size(); ++m) pts[m] = make_double2(points[m].x, points[m].y);
    upload(d_pts_, pts);
    std::vector<unsigned char> geom(points.size());
    if (options().interp == Interp::mls) {
      std::vector<float> rho(mls.rho.begin(), mls.rho.end());
      for (std::size_t m = 0; m < geom.size(); ++m) geom[m] = static_cast<unsigned char>(mls.geometry[m]);
      upload(d_rho_, rho);
      upload(d_offsets_, mls.offsets);
      upload(d_lut_, mls.dots);
    } else {
      for (std::size_t m = 0; m < geom.size(); ++m) geom[m] = static_cast<unsigned char>(fe.geometry[m]);
      upload(d_tri_, fe.tri);
      upload(d_N_, std::vector<float>(fe.N.begin(), fe.N.end()));
      upload(d_offsets_, fe.offsets);
      upload(d_lut_, fe.support);
      upload(d_coef_, std::vector<float>(fe.coef.begin(), fe.coef.end()));
      upload(d_tri_dots_, fe.tri_dots);
      upload(d_tri_gx_, std::vector<float>(fe.tri_gx.begin(), fe.tri_gx.end()));
      upload(d_tri_gy_, std::vector<float>(fe.tri_gy.begin(), fe.tri_gy.end()));
    }
    upload(d_geom_, geom);
    DTFLOP_CUDA(cudaStreamSynchronize(stream_));
  }

  FrameOutput process(const cv::Mat& frame) override {
    state().check_frame(frame);
    FrameOutput out;
    const double t0 = host_now();
    Found f = find_dots(frame, &out);
    out.dots = f.dots;
    out.stats = f.stats;
    const double t1 = host_now();
    std::vector<Vec2> found;
    found.reserve(f.dots.size());
    for (const auto& d : f.dots) found.push_back({d.x, d.y});
    state().track(found, out);
    const double t2 = host_now();
    // Match table: reference dot -> component id on the device.
    const std::size_t nf = state().reference_positions().size(), nm = state().points().size();
    match_.resize(nf);
    for (std::size_t j = 0; j < nf; ++j) {
      const int k = out.matches.ref_to_def[j];
      match_[j] = k < 0 ? -1 : f.comp_of_dot[k];
    }
    const double t_host_match = host_now() - t2;
    ev_.record(6, stream_);
    const double u0 = host_now();
    DTFLOP_CUDA(cudaMemcpyAsync(d_match_.ensure(nf), match_.data(), nf * sizeof(int), cudaMemcpyHostToDevice, stream_));
    const double t_match_upload = host_now() - u0;
    ev_.record(7, stream_);
    launch_displacement(static_cast<int>(nf), d_ref_.get(), d_cx_now_, d_cy_now_, d_match_.get(), d_U_.ensure(nf),
                        d_valid_.ensure(nf), stream_);
    const int bp = options().layout.block_points;
    FieldValue<float>* d_out = d_fields_.ensure(nm);
    if (options().interp == Interp::mls) {
      launch_mls(static_cast<int>(nm), d_pts_.get(), d_rho_.get(), d_geom_.get(), d_offsets_.get(), d_lut_.get(),
                 d_ref_.get(), d_U_.get(), d_valid_.get(), static_cast<int>(options().mls.weight), options().mls.min_dots,
                 static_cast<float>(options().mls.min_pivot_ratio), d_out, bp, stream_);
    } else {
      launch_fe(static_cast<int>(nm), d_tri_.get(), d_N_.get(), d_offsets_.get(), d_lut_.get(), d_coef_.get(),
                d_tri_dots_.get(), d_tri_gx_.get(), d_tri_gy_.get(), d_geom_.get(), d_U_.get(), d_valid_.get(), d_out, bp,
                stream_);
    }
    host_fields_.resize(nm);
    ev_.record(8, stream_);
    DTFLOP_CUDA(cudaMemcpyAsync(host_fields_.data(), d_out, nm * sizeof(FieldValue<float>), cudaMemcpyDeviceToHost, stream_));
    ev_.record(9, stream_);
    DTFLOP_CUDA(cudaStreamSynchronize(stream_));
    const double t3 = host_now();
    out.fields.resize(nm);
    for (std::size_t m = 0; m < nm; ++m) {
      const auto& g = host_fields_[m];
      out.fields[m] = {g.ux, g.uy, g.exx, g.eyy, g.exy, g.status, g.support};
    }
    const double t4 = host_now();
    out.seconds["analysis"] = t1 - t0;
    out.seconds["tracking"] = t2 - t1;
    out.seconds["fields"] = t3 - t2;
    out.seconds["total"] = t4 - t0;
    // The host's own work (no device wait inside): ordering the components' records into dots,
    // matching, the match table and the fields' conversion. The counts price the records' pass
    // (record_steps) and the matching (match_steps); N_C = 0: comparisons and copies, not FLOPs.
    out.seconds["host"] = f.host_seconds + (t2 - t1) + t_host_match + (t4 - t3);
    out.seconds["host_records"] = f.host_seconds;
    out.seconds["host_match_table"] = t_host_match;
    out.seconds["host_fields"] = t4 - t3;
    // The host's time in the two upload calls. From pageable memory a call returns once the driver
    // has staged the bytes (the stream is idle before each: the frame's first copy, and the match
    // table after the records' wait), so this is the copy as the model prices it and the probe
    // times it, staging included; CUPTI's device-side records see only the staged chunks' DMA.
    // From pinned memory a call only queues the copy (its time is CUPTI's then).
    out.seconds["host_upload"] = f.upload_seconds + t_match_upload;
    // Device-side durations between events (copies and kernels apart).
    if (ev_.on) {
      out.seconds["device_upload"] = ev_.between(0, 1) + ev_.between(6, 7);
      out.seconds["device_download"] = ev_.between(2, 3) + ev_.between(4, 5) + ev_.between(8, 9);
      out.seconds["device_labelling"] = ev_.between(1, 2);
      out.seconds["device_centroids"] = ev_.between(3, 4);
      out.seconds["device_fields"] = ev_.between(7, 8);
      out.seconds["device_kernels"] = ev_.between(1, 2) + ev_.between(3, 4) + ev_.between(7, 8);
    }
    // The device classifies without scanning (no scanned pixels); the foreground is its components' areas.
    AnalysisStats stats = f.stats;
    stats.foreground_pixels = f.foreground;
    stats.scanned_pixels = 0;
    out.shape = state().frame_shape(frame, stats, {out.matches.tree_steps, out.matches.match_steps});
    out.counts = cuda_counts(out.shape, f.pinned ? HostMemory::pinned : HostMemory::pageable);
    return out;
  }

 private:
  struct Found {
    std::vector<DotObservation> dots;
    std::vector<int> comp_of_dot;  // device component id of each kept dot
    AnalysisStats stats;
    std::int64_t foreground = 0;
    bool pinned = false;
    double host_seconds = 0;    // the host's loop over the components' records
    double upload_seconds = 0;  // the host's time in the region's upload call
  };

  template <class T>
  void upload(DeviceBuffer<T>& d, const std::vector<T>& h) {
    DTFLOP_CUDA(cudaMemcpyAsync(d.ensure(h.size()), h.data(), h.size() * sizeof(T), cudaMemcpyHostToDevice, stream_));
    DTFLOP_CUDA(cudaStreamSynchronize(stream_));  // h may go out of scope
  }

  Found find_dots(const cv::Mat& image, FrameOutput* out) {
    if (image.depth() == CV_8U) return find_dots_t<std::uint8_t>(image, out);
    return find_dots_t<std::uint16_t>(image, out);
  }

  template <class Pix>
  Found find_dots_t(const cv::Mat& image, FrameOutput*) {
    const cv::Rect r = effective_roi(options().analysis, image.size());
    const Roi roi{r.x, r.y, r.width, r.height};
    const long long n = static_cast<long long>(r.width) * r.height;
    const int bpx = options().layout.block_pixels;
    Found f;
    // Upload the region of interest (pinned when the frame lives in our pinned buffer).
    Pix* d_img = d_img_.template ensure<Pix>(static_cast<std::size_t>(n));
    const std::uint8_t* lo = static_cast<const std::uint8_t*>(pinned_.get());
    f.pinned = lo && image.data >= lo && image.data < lo + static_cast<std::ptrdiff_t>(image.total() * image.elemSize());
    ev_.record(0, stream_);
    // Rows that follow each other in host memory (the region spans the frame's width) go as one
    // copy: from pageable memory the driver stages a 2D copy far slower than a 1D one of the same
    // bytes unless the row is a power of two (on a lent H100, 686 x 680 8-bit: 332 us against
    // 51 us; 2574 x 2258: 1578 against 492 us; docs/PERFORMANCE.md).
    const std::size_t row = static_cast<std::size_t>(r.width) * sizeof(Pix);
    const double u0 = host_now();
    if (row == image.step[0])
      DTFLOP_CUDA(cudaMemcpyAsync(d_img, image.ptr<Pix>(r.y), row * static_cast<std::size_t>(r.height),
                                  cudaMemcpyHostToDevice, stream_));
    else
      DTFLOP_CUDA(cudaMemcpy2DAsync(d_img, row, image.ptr<Pix>(r.y) + r.x, image.step[0], row, r.height,
                                    cudaMemcpyHostToDevice, stream_));
    f.upload_seconds = host_now() - u0;
    ev_.record(1, stream_);
    int* L = d_labels_.ensure(static_cast<std::size_t>(n));
    const int dark = options().analysis.polarity == Polarity::dark_dots;
    const bool wide = sizeof(Pix) == 2;
    // [0] the component count, [1] Otsu's threshold: one copy brings both back.
    int* d_count = d_count_.ensure(2);
    int* d_T = nullptr;
    int T_fixed = 0;
    if (options().analysis.method == ThresholdMethod::otsu) {
      d_T = d_count + 1;
      launch_otsu(d_img, wide, r.width, r.height, d_hist_.ensure(256), d_T, bpx, stream_);
    } else {
      T_fixed = static_cast<int>(wide ? std::floor(options().analysis.threshold * 257) : std::floor(options().analysis.threshold));
    }
    launch_labels(d_img, wide, r.width, r.height, d_T, T_fixed, dark != 0, L, d_count, bpx, stream_);
    ev_.record(2, stream_);
    h_scalars_.resize(2);
    h_scalars_[1] = T_fixed;
    DTFLOP_CUDA(cudaMemcpyAsync(h_scalars_.data(), d_count, (d_T ? 2 : 1) * sizeof(int), cudaMemcpyDeviceToHost, stream_));
    ev_.record(3, stream_);
    DTFLOP_CUDA(cudaStreamSynchronize(stream_));
    const int count = h_scalars_[0], T_used = h_scalars_[1];
    f.stats.roi_pixels = n;
    f.stats.components = count;
    f.stats.threshold = T_used;
    const std::size_t nc = static_cast<std::size_t>(count);
    if (nc == 0) {  // no records to read: the centroid and download phases are empty
      d_cx_now_ = d_cy_now_ = nullptr;
      ev_.record(4, stream_);
      ev_.record(5, stream_);
      return f;
    }
    if (count > 2147483647 / 2) throw std::runtime_error("too many components");
    const Records dr = Records::over(d_records_.ensure(Records::doubles(nc)), nc);
    d_cx_now_ = dr.x;
    d_cy_now_ = dr.y;
    CompStats cs{dr.area, d_minx_.ensure(nc), d_miny_.ensure(nc), d_maxx_.ensure(nc), d_maxy_.ensure(nc), dr.root};
    launch_stats(L, r.width, r.height, cs, count, bpx, stream_);
    const AnalysisOptions& a = options().analysis;
    const DotParams dp{a.min_area, a.max_area, static_cast<float>(a.max_aspect), static_cast<float>(a.min_fill),
                       a.margin, a.reject_border ? 1 : 0, dark};
    const DotOut dout{dr.x, dr.y, dr.weight, dr.status, dr.pixels};
    launch_centroids(d_img, wide, L, r.width, r.height, roi, cs, dp, dout, count, options().layout.block_dots, stream_);
    ev_.record(4, stream_);
    h_records_.resize(Records::doubles(nc));
    DTFLOP_CUDA(cudaMemcpyAsync(h_records_.data(), d_records_.get(), static_cast<std::size_t>(kCudaRecordBytes) * nc,
                                cudaMemcpyDeviceToHost, stream_));
    ev_.record(5, stream_);
    DTFLOP_CUDA(cudaStreamSynchronize(stream_));
    const double th = host_now();
    const Records hr = Records::over(h_records_.data(), nc);
    // Tallied, in the raster order of the roots (as OpenCV labels on the host), the kept ones as dots.
    const kernels::RecordColumns cols{hr.status, hr.area, hr.root, hr.pixels, nc};
    kernels::RecordTally tally;
    f.dots.reserve(nc);
    f.comp_of_dot.reserve(nc);
    kernels::order_records(cols, n, tally, order_, sort_scratch_, [&](int k) {
      DotObservation d;
      d.x = hr.x[k];
      d.y = hr.y[k];
      d.weight = hr.weight[k];
      d.area = hr.area[k];
      f.dots.push_back(d);
      f.comp_of_dot.push_back(k);
    });
    f.foreground = tally.area;
    f.stats.rejected_area = tally.by_status[1];
    f.stats.rejected_shape = tally.by_status[2];
    f.stats.rejected_border = tally.by_status[3];
    f.stats.rejected_contrast = tally.by_status[4];
    f.stats.window_pixels = tally.window_pixels;
    f.stats.ring_pixels = tally.ring_pixels;
    f.stats.weighted_pixels = tally.weighted_pixels;
    f.host_seconds = host_now() - th;
    return f;
  }

  cudaStream_t stream_ = nullptr;
  Events ev_;
  PinnedBuffer pinned_;
  DeviceBuffer<int> d_labels_, d_count_, d_minx_, d_miny_, d_maxx_, d_maxy_, d_match_, d_offsets_, d_lut_, d_tri_,
      d_tri_dots_;
  DeviceBuffer<unsigned int> d_hist_;
  DeviceBuffer<double> d_records_;  // Records::over it
  double* d_cx_now_ = nullptr;       // this frame's centroids, in d_records_
  double* d_cy_now_ = nullptr;
  DeviceBuffer<float> d_rho_, d_N_, d_coef_, d_tri_gx_, d_tri_gy_;
  DeviceBuffer<double2> d_ref_, d_pts_;
  DeviceBuffer<float2> d_U_;
  DeviceBuffer<unsigned char> d_valid_, d_geom_;
  DeviceBuffer<FieldValue<float>> d_fields_;
  // Raw image storage; sized in pixels of the widest type.
  struct ImgBuf {
    DeviceBuffer<std::uint16_t> wide;
    template <class Pix>
    Pix* ensure(std::size_t n) { return reinterpret_cast<Pix*>(wide.ensure((n * sizeof(Pix) + 1) / 2)); }
  } d_img_;
  // What the device copies to and from the host, in the frames' kind of host memory.
  const bool pinned_host_ = options().pinned_frames;
  HostArray<double> h_records_{pinned_host_};  // Records::over it
  HostArray<int> match_{pinned_host_}, h_scalars_{pinned_host_};
  HostArray<FieldValue<float>> host_fields_{pinned_host_};
  std::vector<int> order_, sort_scratch_;  // the records' pass: its buffers kept from frame to frame
};

}  // namespace

std::unique_ptr<Backend> make_cuda_backend(const PipelineOptions& o) { return std::make_unique<CudaBackend>(o); }


}  // namespace dtflop::dct
