// Sources through OpenCV's VideoCapture (V4L2 device, video file, GStreamer pipeline, gPhoto2)
// and image sequences through the DCT workload's image reader; files and sequences paced like
// a camera when asked (a reader thread with `buffer` frames).
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <mutex>
#include <thread>

#include <fmt/format.h>
#include <fmt/printf.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "model/errors.hpp"
#include "sources/frame_source.hpp"
#include "sources/opencv_source.hpp"
#include "workloads/dct/io.hpp"

namespace dtflop::sources {
namespace {

// Colour to grey at the image's depth; 8- and 16-bit kept.
cv::Mat grey_of(const cv::Mat& m) {
  cv::Mat g;
  if (m.channels() == 3) cv::cvtColor(m, g, cv::COLOR_BGR2GRAY);
  else if (m.channels() == 4) cv::cvtColor(m, g, cv::COLOR_BGRA2GRAY);
  else g = m;
  if (g.depth() != CV_8U && g.depth() != CV_16U)
    throw InputError("the source gives frames of neither 8 nor 16 bits per channel; convert the stream to 8- or "
                     "16-bit grey");
  return g;
}

// Reads frames unpaced: one per call, false at the end.
class Reader {
 public:
  virtual ~Reader() = default;
  virtual bool read(Frame& f) = 0;
  virtual double fps() const = 0;
  virtual bool numbered() const = 0;
  virtual std::string describe() const = 0;
};

class CaptureReader final : public Reader {
 public:
  explicit CaptureReader(const SourceSpec& s) : spec_(s) { open(); }

  void open() {
    using K = SourceSpec::Kind;
    cap_.release();
    bool ok = false;
    switch (spec_.kind) {
      case K::file:
        if (!std::filesystem::is_regular_file(spec_.target))
          throw InputError(fmt::format("source '{}': no video file '{}'; give the path of a video file", spec_.text,
                                       spec_.target));
        ok = cap_.open(spec_.target, cv::CAP_FFMPEG);  // (CAP_ANY would also try gPhoto2, which leaks probing USB)
        if (!ok)
          throw InputError(fmt::format("source '{}': '{}' is not a video OpenCV can decode; give an mp4/avi/mkv file "
                                       "(or images:NAME_%04d.png for an image sequence)",
                                       spec_.text, spec_.target));
        break;
      case K::gstreamer:
        ok = cap_.open(spec_.target, cv::CAP_GSTREAMER);
        if (!ok)
          throw InputError(fmt::format("source '{}': the GStreamer pipeline does not parse or does not start; check "
                                       "it with gst-launch-1.0 and end it in appsink",
                                       spec_.text));
        break;
      case K::device:
      case K::gphoto2: {
        const int index = std::stoi(spec_.target);
        ok = cap_.open(index, spec_.kind == K::device ? cv::CAP_V4L2 : cv::CAP_GPHOTO2);
        if (!ok)
          throw InputError(fmt::format("source '{}': no {} camera {} here; plug one in or give another index", spec_.text,
                                       spec_.kind == K::device ? "V4L2" : "gPhoto2", index));
        if (spec_.fps) cap_.set(cv::CAP_PROP_FPS, *spec_.fps);
        if (spec_.exposure_us) cap_.set(cv::CAP_PROP_EXPOSURE, *spec_.exposure_us / 100.0);  // V4L2: 100 us units
        if (spec_.gain_db) cap_.set(cv::CAP_PROP_GAIN, *spec_.gain_db);
        break;
      }
      default: throw InputError("internal: not a VideoCapture source");
    }
    fps_ = spec_.fps.value_or(cap_.get(cv::CAP_PROP_FPS));
    if (!(fps_ > 0 && fps_ < 1e5)) fps_ = 0;
    index_ = 0;
  }

  bool read(Frame& f) override {
    cv::Mat m;
    if (!cap_.read(m) || m.empty()) return false;
    const cv::Mat g = grey_of(m);
    if (static_cast<std::int64_t>(g.cols) * g.rows > dct::kMaxImagePixels || g.cols > dct::kMaxImageSide ||
        g.rows > dct::kMaxImageSide)
      throw InputError(fmt::format("source '{}': {}x{} frames are larger than dtflop reads ({} px); set a smaller "
                                   "frame size",
                                   spec_.text, g.cols, g.rows, dct::kMaxImagePixels));
    f.image = g.data == m.data ? g.clone() : g;
    f.bits = g.depth() == CV_8U ? 8 : 16;
    f.sequence = index_++;
    const double ms = cap_.get(cv::CAP_PROP_POS_MSEC);
    f.timestamp_s = std::isfinite(ms) && ms >= 0 ? ms / 1000.0 : 0.0;
    if (spec_.kind == SourceSpec::Kind::file && fps_ > 0 && f.timestamp_s == 0 && f.sequence > 0)
      f.timestamp_s = static_cast<double>(f.sequence) / fps_;
    f.arrival_s = steady_seconds();
    return true;
  }
  double fps() const override { return fps_; }
  // Files: the frame index is the file's; devices and pipelines: OpenCV's count, so gaps are
  // judged from the timestamps.
  bool numbered() const override { return spec_.kind == SourceSpec::Kind::file; }
  std::string describe() const override {
    return fmt::format("{} '{}' (OpenCV {}{})", to_string(spec_.kind), spec_.target, cap_.getBackendName(),
                       fps_ > 0 ? fmt::format(", {:.3g} fps", fps_) : "");
  }

 private:
  SourceSpec spec_;
  cv::VideoCapture cap_;
  double fps_ = 0;
  std::uint64_t index_ = 0;
};

// "def_%04d.png": the files for k = 0, 1, ... (starting at 0 or 1, up to the first gap).
class ImageSequenceReader final : public Reader {
 public:
  explicit ImageSequenceReader(const SourceSpec& s) : spec_(s) {
    if (s.target.find('%') == std::string::npos)
      throw InputError(fmt::format("source '{}': an image sequence is a printf pattern such as def_%04d.png", s.text));
    if (!exists(0) && !exists(1))
      throw InputError(fmt::format("source '{}': no file {} (nor index 1); give a pattern that names the images",
                                   s.text, name(0)));
    k_ = exists(0) ? 0 : 1;
  }
  bool read(Frame& f) override {
    if (!exists(k_)) return false;
    f.image = dct::read_grey(name(k_));
    f.bits = f.image.depth() == CV_8U ? 8 : 16;
    f.sequence = static_cast<std::uint64_t>(k_);
    f.timestamp_s = spec_.fps ? static_cast<double>(k_) / *spec_.fps : static_cast<double>(k_);
    f.arrival_s = steady_seconds();
    ++k_;
    return true;
  }
  double fps() const override { return spec_.fps.value_or(0); }
  bool numbered() const override { return true; }
  std::string describe() const override { return fmt::format("image sequence '{}'", spec_.target); }

 private:
  std::string name(int k) const {
    try {
      return fmt::sprintf(spec_.target, k);
    } catch (const std::exception& e) {
      throw InputError(fmt::format("source '{}' is not a printf pattern with one integer (e.g. def_%04d.png): {}",
                                   spec_.text, e.what()));
    }
  }
  bool exists(int k) const { return k < 10000000 && std::filesystem::is_regular_file(name(k)); }
  SourceSpec spec_;
  int k_ = 0;
};

std::unique_ptr<Reader> make_reader(const SourceSpec& s) {
  if (s.kind == SourceSpec::Kind::images) return std::make_unique<ImageSequenceReader>(s);
  return std::make_unique<CaptureReader>(s);
}

class OpenCvSource final : public FrameSource {
 public:
  explicit OpenCvSource(const SourceSpec& s) : FrameSource(s), reader_(make_reader(s)) {
    if (spec_.paced) {
      if (reader_->fps() <= 0)
        throw InputError(fmt::format("source '{}': paced reading needs a frame rate; add fps=30 to the source",
                                     spec_.text));
      thread_ = std::thread([this] { produce(); });
    }
  }
  ~OpenCvSource() override {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

  std::string describe() const override {
    return reader_->describe() +
           (spec_.paced ? fmt::format(", paced at {:.3g} fps with {} buffers", reader_->fps(), spec_.buffer) : "");
  }

 protected:
  Grab grab(Frame& f, std::string& why) override {
    if (!spec_.paced) {
      try {
        if (reader_->read(f)) return Grab::frame;
      } catch (const InputError&) {
        throw;
      } catch (const std::exception& e) {
        why = e.what();
        return Grab::lost;
      }
      // A file or pipeline ends; a camera does not: one that stops sending has gone.
      if (spec_.kind == SourceSpec::Kind::device || spec_.kind == SourceSpec::Kind::gphoto2) {
        why = fmt::format("{} camera {} stopped sending frames (unplugged?)", to_string(spec_.kind), spec_.target);
        return Grab::lost;
      }
      return Grab::end;
    }
    std::unique_lock lock(mutex_);
    cv_.wait(lock, [this] { return !queue_.empty() || done_; });
    if (!error_.empty()) {
      const std::string e = error_;
      error_.clear();
      throw InputError(e);
    }
    if (queue_.empty()) return Grab::end;
    f = std::move(queue_.front());
    queue_.pop_front();
    (void)why;
    return Grab::frame;
  }
  // Cameras (V4L2, gPhoto2) are opened again; a file or pipeline that failed is not.
  void reopen() override {
    if ((spec_.kind != SourceSpec::Kind::device && spec_.kind != SourceSpec::Kind::gphoto2) || spec_.paced)
      throw InputError("a file or pipeline that failed is not reopened");
    reader_ = make_reader(spec_);
  }
  bool numbers_frames() const override { return reader_->numbered() || spec_.paced; }
  double nominal_fps() const override { return reader_->fps(); }

 private:
  // Frame k becomes available k/fps after the first; a full buffer loses its oldest frame.
  void produce() {
    const double period = 1.0 / reader_->fps();
    const double t0 = steady_seconds();
    std::uint64_t k = 0;
    for (;;) {
      Frame f;
      bool got = false;
      std::string err;
      try {
        got = reader_->read(f);
      } catch (const std::exception& e) {
        err = e.what();
      }
      const double due = t0 + static_cast<double>(k) * period;
      const double t = steady_seconds();
      if (got && t < due) std::this_thread::sleep_for(std::chrono::duration<double>(due - t));
      std::lock_guard lock(mutex_);
      if (stop_) return;
      if (!got) {
        error_ = err;
        done_ = true;
        cv_.notify_all();
        return;
      }
      f.sequence = k++;
      f.arrival_s = std::max(due, t);
      if (static_cast<int>(queue_.size()) >= spec_.buffer) queue_.pop_front();
      queue_.push_back(std::move(f));
      cv_.notify_all();
    }
  }

  std::unique_ptr<Reader> reader_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Frame> queue_;
  bool stop_ = false, done_ = false;
  std::string error_;
};

}  // namespace

std::unique_ptr<FrameSource> open_opencv_source(const SourceSpec& spec) { return std::make_unique<OpenCvSource>(spec); }

}  // namespace dtflop::sources
