#include "sources/frame_source.hpp"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <thread>

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop::sources {

std::string to_string(SourceSpec::Kind k) {
  switch (k) {
    case SourceSpec::Kind::device: return "device";
    case SourceSpec::Kind::file: return "file";
    case SourceSpec::Kind::images: return "images";
    case SourceSpec::Kind::gstreamer: return "gst";
    case SourceSpec::Kind::gphoto2: return "gphoto2";
    case SourceSpec::Kind::aravis: return "aravis";
  }
  return "?";
}

namespace {

constexpr const char* kForms =
    "write device:0, file:clip.mp4, images:def_%04d.png, gst:'videotestsrc ! appsink', gphoto2:0 or "
    "aravis:CAMERA-ID[?exposure=US&gain=DB&fps=HZ&roi=X,Y,W,H&format=Mono16]";

double number(const std::string& key, const std::string& value, double lo, double hi, const std::string& text) {
  double v = 0;
  const auto r = std::from_chars(value.data(), value.data() + value.size(), v);
  if (r.ec != std::errc() || r.ptr != value.data() + value.size() || !std::isfinite(v) || v < lo || v > hi)
    throw InputError(fmt::format("source '{}': {}={} is not a number in [{}, {}]; {}", text, key, value, lo, hi,
                                 "give one in range"));
  return v;
}

cv::Rect roi_of(const std::string& value, const std::string& text) {
  int v[4] = {0, 0, 0, 0};
  const char* p = value.data();
  const char* end = p + value.size();
  bool ok = true;
  for (int i = 0; i < 4 && ok; ++i) {
    const auto r = std::from_chars(p, end, v[i]);
    ok = r.ec == std::errc() && (i == 3 ? r.ptr == end : (r.ptr != end && *r.ptr == ','));
    p = r.ptr + 1;
  }
  if (!ok || v[0] < 0 || v[1] < 0 || v[2] < 1 || v[3] < 1 || v[0] > 16384 - v[2] || v[1] > 16384 - v[3])
    throw InputError(fmt::format("source '{}': roi={} is not x,y,width,height within 16384 px (e.g. "
                                 "roi=0,0,640,480)",
                                 text, value));
  return {v[0], v[1], v[2], v[3]};
}

}  // namespace

SourceSpec parse_source_spec(const std::string& text) {
  if (text.empty() || text.size() > 4096)
    throw InputError(fmt::format("source '{}' is empty or longer than 4096 characters; {}", text.substr(0, 40), kForms));
  SourceSpec s;
  s.text = text;
  std::string rest = text;
  const auto colon = text.find(':');
  const std::string prefix = colon == std::string::npos ? "" : text.substr(0, colon);
  if (prefix == "device") s.kind = SourceSpec::Kind::device;
  else if (prefix == "file") s.kind = SourceSpec::Kind::file;
  else if (prefix == "images") s.kind = SourceSpec::Kind::images;
  else if (prefix == "gst") s.kind = SourceSpec::Kind::gstreamer;
  else if (prefix == "gphoto2") s.kind = SourceSpec::Kind::gphoto2;
  else if (prefix == "aravis") s.kind = SourceSpec::Kind::aravis;
  else {
    // No known prefix: a path (a sequence when it holds '%').
    s.kind = text.find('%') == std::string::npos ? SourceSpec::Kind::file : SourceSpec::Kind::images;
    s.target = text;
    return s;
  }
  rest = text.substr(colon + 1);
  if (s.kind != SourceSpec::Kind::gstreamer) {
    const auto q = rest.find('?');
    if (q != std::string::npos) {
      const std::string opts = rest.substr(q + 1);
      rest = rest.substr(0, q);
      std::size_t at = 0;
      while (at <= opts.size()) {
        const auto amp = std::min(opts.find('&', at), opts.size());
        const std::string kv = opts.substr(at, amp - at);
        at = amp + 1;
        const auto eq = kv.find('=');
        if (eq == std::string::npos)
          throw InputError(fmt::format("source '{}': option '{}' is not key=value; {}", text, kv, kForms));
        const std::string key = kv.substr(0, eq), value = kv.substr(eq + 1);
        if (key == "exposure") s.exposure_us = number(key, value, 1, 1e8, text);
        else if (key == "gain") s.gain_db = number(key, value, -100, 100, text);
        else if (key == "fps") s.fps = number(key, value, 0.01, 100000, text);
        else if (key == "roi") s.roi = roi_of(value, text);
        else if (key == "format") s.pixel_format = value;
        else if (key == "paced") s.paced = number(key, value, 0, 1, text) != 0;
        else if (key == "buffer") s.buffer = static_cast<int>(number(key, value, 1, 1000, text));
        else if (key == "reopen") s.reopen_attempts = static_cast<int>(number(key, value, 0, 100, text));
        else if (key == "backoff") s.backoff_ms = static_cast<int>(number(key, value, 1, 60000, text));
        else if (key == "timeout") s.timeout_s = number(key, value, 0.05, 600, text);
        else
          throw InputError(fmt::format("source '{}': unknown option '{}'; the options are exposure, gain, fps, roi, "
                                       "format, paced, buffer, reopen, backoff, timeout",
                                       text, key));
      }
    }
  }
  if (rest.empty() && s.kind != SourceSpec::Kind::aravis)
    throw InputError(fmt::format("source '{}' names nothing after '{}:'; {}", text, prefix, kForms));
  if (s.kind == SourceSpec::Kind::device || s.kind == SourceSpec::Kind::gphoto2) {
    int index = 0;
    const auto r = std::from_chars(rest.data(), rest.data() + rest.size(), index);
    if (r.ec != std::errc() || r.ptr != rest.data() + rest.size() || index < 0 || index > 255)
      throw InputError(fmt::format("source '{}': '{}' is not a device index 0..255 (e.g. {}:0)", text, rest, prefix));
  }
  s.target = rest;
  return s;
}

bool FrameSource::next(Frame& f) {
  for (;;) {
    std::string why;
    const Grab g = grab(f, why);
    if (g == Grab::end) return false;
    if (g == Grab::lost) {
      stats_.last_error = why;
      bool back = false;
      int wait_ms = spec_.backoff_ms;
      for (int attempt = 1; attempt <= spec_.reopen_attempts && !back; ++attempt) {
        std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms));
        wait_ms = std::min(2 * wait_ms, 5000);
        try {
          reopen();
          back = true;
        } catch (const std::exception& e) {
          stats_.last_error = fmt::format("{}; reopening (try {} of {}): {}", why, attempt, spec_.reopen_attempts,
                                          e.what());
        }
      }
      if (!back) {
        stats_.disconnected = true;
        return false;
      }
      ++stats_.reopened;
      // A reopened camera numbers its frames afresh: the gap across the reopening is not judged.
      last_sequence_.reset();
      last_timestamp_.reset();
      continue;
    }
    // Frames of one stream share size and depth (the reference is the first).
    if (first_type_ < 0) {
      first_type_ = f.image.type();
      first_size_ = f.image.size();
    } else if (f.image.type() != first_type_ || f.image.size() != first_size_) {
      throw InputError(fmt::format("source '{}': frame {} is {}x{} {}-bit and the stream began with {}x{} {}-bit "
                                   "frames; give a stream whose frames share one size and depth",
                                   spec_.text, f.sequence, f.image.cols, f.image.rows,
                                   f.image.depth() == CV_8U ? 8 : 16, first_size_.width, first_size_.height,
                                   CV_MAT_DEPTH(first_type_) == CV_8U ? 8 : 16));
    }
    std::uint64_t incomplete = 0;
    stats_.dropped += take_source_losses(incomplete);
    stats_.incomplete += incomplete;
    if (numbers_frames()) {
      if (last_sequence_ && f.sequence > *last_sequence_ + 1) stats_.dropped += f.sequence - *last_sequence_ - 1;
      last_sequence_ = f.sequence;
    } else if (nominal_fps() > 0) {
      if (last_timestamp_) {
        const double periods = (f.timestamp_s - *last_timestamp_) * nominal_fps();
        if (periods > 1.5) stats_.dropped += static_cast<std::uint64_t>(std::llround(periods)) - 1;
      }
      last_timestamp_ = f.timestamp_s;
    }
    ++stats_.delivered;
    return true;
  }
}

}  // namespace dtflop::sources
