// Frame sources: where the DCT workload's live frames come from (library dtflop_sources).
//
// One interface, FrameSource, over
//   - OpenCV's VideoCapture: a V4L2 device index, a video file, a GStreamer pipeline, a gPhoto2
//     camera (DSLR) (opencv_source.cpp);
//   - an image sequence read with the DCT workload's own image reader (8- and 16-bit kept);
//   - GenICam industrial cameras through Aravis (aravis_source.cpp; built when libaravis-0.8 is
//     found): exposure, gain, frame rate, ROI, Mono8/10/12/14/16 and Bayer pixel formats.
// Every frame is one-channel grey, CV_8U or CV_16U (formats of more than 8 bits are kept in 16
// bits, shifted to its top so an 8-bit-scale threshold means the same), and carries its source's
// sequence number and timestamp. FrameSource::next() counts the frames lost between two it
// delivered (gaps in the sequence numbers, or in the timestamps of sources without them, and
// frames the source itself reports lost), refuses a frame whose size or depth differs from the
// stream's first, and reopens a source that disconnected, with back-off, as often as allowed.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

namespace dtflop::sources {

// Seconds on the host's steady clock: when a frame arrived, and the live loop's own timings.
inline double steady_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct Frame {
  cv::Mat image;              // CV_8UC1 or CV_16UC1
  std::uint64_t sequence = 0; // the source's frame number (camera frame id, file frame index)
  double timestamp_s = 0;     // the source's time of the frame (camera clock, stream position)
  double arrival_s = 0;       // host steady clock when the frame was (or, paced, became) available
  int bits = 8;               // significant bits of the source's pixels (8, 10, 12, 14 or 16)
};

// What a stream delivered and lost so far.
struct SourceStats {
  std::uint64_t delivered = 0;   // frames returned by next()
  std::uint64_t dropped = 0;     // frames lost: sequence or timestamp gaps, source-reported losses
  std::uint64_t incomplete = 0;  // of those, frames the source received damaged (Aravis buffer status)
  int reopened = 0;              // successful reopenings after a disconnect
  bool disconnected = false;     // the stream ended because the source went away for good
  std::string last_error;        // why the source last failed (empty if it never did)
};

// How a source is named and set: `kind:target[?key=value&...]` (parse_source_spec).
struct SourceSpec {
  enum class Kind { device, file, images, gstreamer, gphoto2, aravis };
  Kind kind = Kind::file;
  std::string target;  // device index, path, pattern, pipeline, camera id
  // Camera settings (Aravis; exposure, gain and fps also tried on V4L2 devices). Unset: the camera's own.
  std::optional<double> exposure_us, gain_db, fps;
  std::optional<cv::Rect> roi;         // sensor region (Aravis)
  std::string pixel_format;            // Aravis: Mono8, Mono16, BayerRG8, ... (empty: the camera's)
  // Files and image sequences are read as fast as asked, or paced like a camera at `fps`
  // (frame k becomes available k/fps after the first; frames the reader falls more than
  // `buffer` behind on are dropped as a camera with that many buffers would).
  bool paced = false;
  int buffer = 4;
  // Disconnects: reopen at most `reopen_attempts` times per disconnect, waiting backoff_ms,
  // then twice that, ... (capped at 5 s) between tries; 0 ends the stream at the first.
  int reopen_attempts = 3;
  int backoff_ms = 200;
  double timeout_s = 2;  // no frame for this long (Aravis): the source has disconnected
  std::string text;      // as given, for messages
};

std::string to_string(SourceSpec::Kind k);

// Parses "device:0", "file:clip.mp4", "images:def_%04d.png", "gst:videotestsrc ! appsink",
// "gphoto2:0", "aravis:Aravis-Fake-GV01?exposure=1000&gain=2&fps=30&roi=0,0,256,256&format=Mono16";
// a bare path is a file, a bare path with '%' an image sequence. Options after '?' (all kinds but
// gst, whose pipelines may hold '?'): exposure (us), gain (dB), fps, roi (x,y,w,h), format, paced
// (0/1), buffer, reopen (attempts), backoff (ms), timeout (s). Throws InputError naming what is
// wrong and what to write.
SourceSpec parse_source_spec(const std::string& text);

class FrameSource {
 public:
  virtual ~FrameSource() = default;

  // The next frame: true with `f` filled, false at the end of the stream (a file's end, or a
  // disconnect that could not be mended: stats().disconnected says which). Throws InputError
  // for a frame of another size or depth than the stream's first.
  bool next(Frame& f);

  const SourceStats& stats() const { return stats_; }
  // Frames per second the source runs at (its setting, the file's rate); 0 when unknown.
  double frame_rate() const { return nominal_fps(); }
  const SourceSpec& spec() const { return spec_; }
  // "Aravis-Fake-GV01 (Aravis, 512x512 Mono16)" and the like.
  virtual std::string describe() const = 0;

 protected:
  explicit FrameSource(SourceSpec spec) : spec_(std::move(spec)) {}

  enum class Grab { frame, end, lost };
  // One frame from the source, with its sequence number and timestamp; `lost` when the source
  // has gone (then `why` says how).
  virtual Grab grab(Frame& f, std::string& why) = 0;
  // Reopens after `lost`; throws (anything) when it cannot.
  virtual void reopen() = 0;
  // Frames the source itself lost since the last call (e.g. incomplete camera buffers).
  virtual std::uint64_t take_source_losses(std::uint64_t& incomplete) {
    incomplete = 0;
    return 0;
  }
  // Whether sequence numbers come from the source (else gaps are judged from timestamps at spec.fps).
  virtual bool numbers_frames() const { return true; }
  virtual double nominal_fps() const { return spec_.fps.value_or(0); }

  SourceSpec spec_;
  SourceStats stats_;

 private:
  std::optional<std::uint64_t> last_sequence_;
  std::optional<double> last_timestamp_;
  int first_type_ = -1;
  cv::Size first_size_;
};

// Opens the source `spec` names. Throws InputError, in one line ending with what to do, when it
// cannot be opened: a camera that is not there, a file that is missing, a pipeline that does
// not parse, an Aravis camera where dtflop was built without Aravis.
std::unique_ptr<FrameSource> open_source(const SourceSpec& spec);

// Whether dtflop was built with Aravis.
bool have_aravis();

}  // namespace dtflop::sources
