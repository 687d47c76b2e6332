#include "sources/live.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "model/errors.hpp"
#include "model/units.hpp"
#include "workloads/dct/io.hpp"

namespace dtflop::live {
namespace {

// Field access with the file and key in every message.
class Reader {
 public:
  Reader(const YAML::Node& root, std::string name) : root_(root), name_(std::move(name)) {}

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw InputError(fmt::format("{}: '{}' {}", name_, key, what));
  }
  std::optional<std::string> text(const std::string& key) const {
    const YAML::Node n = root_[key];
    if (!n) return std::nullopt;
    if (!n.IsScalar()) fail(key, "must be a single value (text), not a list or map");
    const std::string s = n.as<std::string>();
    if (s.empty() || s.size() > 4096) fail(key, "is empty or longer than 4096 characters");
    return s;
  }
  std::optional<std::int64_t> integer(const std::string& key, std::int64_t lo, std::int64_t hi) const {
    const YAML::Node n = root_[key];
    if (!n) return std::nullopt;
    return whole(n, key, lo, hi);
  }
  std::int64_t whole(const YAML::Node& n, const std::string& key, std::int64_t lo, std::int64_t hi) const {
    if (!n.IsScalar()) fail(key, fmt::format("must be a whole number in [{}, {}]", lo, hi));
    const std::string s = n.as<std::string>();
    std::int64_t v = 0;
    std::size_t used = 0;
    try {
      v = std::stoll(s, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != s.size() || s.empty() || v < lo || v > hi)
      fail(key, fmt::format("is '{}': write a whole number in [{}, {}]", s.substr(0, 40), lo, hi));
    return v;
  }
  std::optional<double> real(const std::string& key, double lo, double hi) const {
    const YAML::Node n = root_[key];
    if (!n) return std::nullopt;
    if (!n.IsScalar()) fail(key, fmt::format("must be a number in [{}, {}]", lo, hi));
    const std::string s = n.as<std::string>();
    double v = 0;
    std::size_t used = 0;
    try {
      v = std::stod(s, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != s.size() || !std::isfinite(v) || v < lo || v > hi)
      fail(key, fmt::format("is '{}': write a finite number in [{}, {}]", s.substr(0, 40), lo, hi));
    return v;
  }
  std::optional<std::vector<std::int64_t>> list(const std::string& key, std::size_t size, std::int64_t lo,
                                                std::int64_t hi) const {
    const YAML::Node n = root_[key];
    if (!n) return std::nullopt;
    if (!n.IsSequence() || n.size() != size)
      fail(key, fmt::format("must be a list of {} whole numbers (e.g. [{}])", size, size == 4 ? "0, 0, 640, 480" : "12, 20000"));
    std::vector<std::int64_t> out;
    for (const auto& x : n) out.push_back(whole(x, key, lo, hi));
    return out;
  }

 private:
  YAML::Node root_;
  std::string name_;
};

}  // namespace

LiveConfig parse_live_config(const std::string& yaml, const std::string& name) {
  if (yaml.size() > (1u << 20))
    throw InputError(fmt::format("{}: a run configuration of over 1 MiB is not one; give the YAML file", name));
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}: not YAML (line {}: {}); fix the file", name, e.mark.line + 1, e.msg));
  }
  if (!root.IsMap()) throw InputError(fmt::format("{}: a run configuration is a YAML map of keys (source: ..., ...)", name));
  static const std::set<std::string> known = {"source", "reference", "roi", "threshold", "polarity", "area",
                                              "backend", "interpolation", "weight", "support", "points", "threads",
                                              "search_radius", "output", "max_frames", "overlay_every", "source2",
                                              "calibration", "pair", "pair_tolerance_ms", "epipolar_tolerance", "tuned"};
  for (const auto& kv : root) {
    const std::string key = kv.first.IsScalar() ? kv.first.as<std::string>() : "?";
    if (!known.count(key)) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw InputError(fmt::format("{}: unknown key '{}'; the keys are {}", name, key.substr(0, 60), list));
    }
  }
  const Reader r(root, name);
  LiveConfig c;
  for (const auto& kv : root) c.given.insert(kv.first.as<std::string>());
  using namespace dtflop::dct;
  PipelineOptions& p = c.pipeline;
  if (auto s = r.text("source")) c.source = *s;
  if (auto s = r.text("reference")) c.reference = *s;
  if (auto roi = r.list("roi", 4, 0, 16384)) {
    const auto& v = *roi;
    if (v[2] < 1 || v[3] < 1 || v[0] + v[2] > 16384 || v[1] + v[3] > 16384)
      r.fail("roi", "must be [x, y, width, height] with width, height >= 1 inside 16384 px");
    p.analysis.roi = cv::Rect(static_cast<int>(v[0]), static_cast<int>(v[1]), static_cast<int>(v[2]),
                              static_cast<int>(v[3]));
  }
  if (auto s = r.text("threshold")) {
    if (s->rfind("fixed:", 0) == 0) {
      p.analysis.method = ThresholdMethod::fixed;
      char* end = nullptr;
      const double t = std::strtod(s->c_str() + 6, &end);
      if (end == s->c_str() + 6 || *end != '\0' || !std::isfinite(t) || t < 0 || t > 255)
        r.fail("threshold", fmt::format("is '{}': write fixed:128 (0..255, 8-bit scale), otsu or adaptive", *s));
      p.analysis.threshold = t;
    } else {
      try {
        p.analysis.method = threshold_method_from_string(*s);
      } catch (const InputError& e) {
        r.fail("threshold", fmt::format("is '{}': {}", *s, e.what()));
      }
    }
  }
  if (auto s = r.text("polarity")) {
    if (*s == "dark") p.analysis.polarity = Polarity::dark_dots;
    else if (*s == "light") p.analysis.polarity = Polarity::light_dots;
    else r.fail("polarity", fmt::format("is '{}': write dark or light", *s));
  }
  if (auto a = r.list("area", 2, 1, 100'000'000)) {
    if ((*a)[0] > (*a)[1]) r.fail("area", "must be [min, max] with min <= max (px)");
    p.analysis.min_area = static_cast<int>((*a)[0]);
    p.analysis.max_area = static_cast<int>(std::min<std::int64_t>((*a)[1], std::numeric_limits<int>::max()));
  }
  if (auto s = r.text("backend")) {
    try {
      (void)backend_kind(*s);
    } catch (const InputError& e) {
      r.fail("backend", fmt::format("is '{}': {}", *s, e.what()));
    }
    c.backend = *s;
  }
  auto parse = [&](const std::string& key, auto f) {
    if (auto s = r.text(key)) {
      try {
        f(*s);
      } catch (const InputError& e) {
        r.fail(key, fmt::format("is '{}': {}", *s, e.what()));
      }
    }
  };
  parse("interpolation", [&](const std::string& s) { p.interp = interp_from_string(s); });
  parse("weight", [&](const std::string& s) { p.mls.weight = weight_from_string(s); });
  parse("support", [&](const std::string& s) {
    p.mls.support = parse_support(s);
    c.support_text = s;
    c.support_given = true;
  });
  p.mls.support_at_most_found = !c.support_given;
  parse("points", [&](const std::string& s) {
    const Size2 g = parse_size2(s, "points", 4096);
    if (g.x < 2 || g.y < 2) throw InputError("write at least 2x2");
    p.points_x = static_cast<int>(g.x);
    p.points_y = static_cast<int>(g.y);
  });
  if (auto t = r.integer("threads", 0, 1024)) p.threads = static_cast<int>(*t);
  if (auto v = r.real("search_radius", 0, 16384)) p.match.search_radius = *v;
  if (auto s = r.text("output")) c.output = *s;
  if (auto m = r.integer("max_frames", 0, 100'000'000)) c.max_frames = *m;
  if (auto m = r.integer("overlay_every", 0, 100'000'000)) c.overlay_every = *m;
  if (auto s = r.text("source2")) c.source2 = *s;
  if (auto s = r.text("calibration")) c.calibration = *s;
  if (auto s = r.text("pair")) {
    if (*s == "sequence") c.pair_by_timestamp = false;
    else if (*s == "timestamp") c.pair_by_timestamp = true;
    else r.fail("pair", fmt::format("is '{}': write sequence or timestamp", *s));
  }
  if (auto v = r.real("pair_tolerance_ms", 0, 10000)) c.pair_tolerance_s = *v / 1000;
  if (auto v = r.real("epipolar_tolerance", 0.01, 100)) c.epipolar_tolerance = *v;
  if (auto s = r.text("tuned")) c.tuned = *s;
  if (!c.source2.empty() != !c.calibration.empty() && c.given.count("source2"))
    r.fail("calibration", "is needed with source2: give the pair's calibration (dtflop live stereo-calibrate)");
  return c;
}

LiveConfig load_live_config(const std::filesystem::path& path) {
  std::error_code ec;
  const auto st = std::filesystem::status(path, ec);
  if (!std::filesystem::is_regular_file(st))
    throw InputError(fmt::format("--config '{}' is not a file; give the run's YAML configuration", path.string()));
  if (std::filesystem::file_size(path, ec) > (1u << 20))
    throw InputError(fmt::format("--config '{}' is over 1 MiB; give the run's YAML configuration", path.string()));
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return parse_live_config(s.str(), path.string());
}

void apply_tuned(LiveConfig& c, const std::string& backend, const dct::PipelineOptions& tuned) {
  const dct::PipelineOptions mine = c.pipeline;
  dct::PipelineOptions p = tuned;
  // What describes the images, not the computation, stays the configuration's.
  p.analysis.roi = mine.analysis.roi;
  p.analysis.polarity = mine.analysis.polarity;
  p.analysis.min_area = mine.analysis.min_area;
  p.analysis.max_area = mine.analysis.max_area;
  p.points = mine.points;
  // Keys the file named win over the tuned values.
  auto given = [&](const char* k) { return c.given.count(k) > 0; };
  if (given("threshold")) {
    p.analysis.method = mine.analysis.method;
    p.analysis.threshold = mine.analysis.threshold;
  }
  if (given("interpolation")) p.interp = mine.interp;
  if (given("weight")) p.mls.weight = mine.mls.weight;
  if (given("support")) {
    p.mls.support = mine.mls.support;
    p.mls.support_at_most_found = mine.mls.support_at_most_found;
  } else {
    c.support_text = p.mls.support.str();
  }
  if (given("points")) {
    p.points_x = mine.points_x;
    p.points_y = mine.points_y;
  }
  if (given("threads")) p.threads = mine.threads;
  if (given("search_radius")) p.match.search_radius = mine.match.search_radius;
  if (given("backend") && c.backend != backend)
    throw InputError(fmt::format("the tuned configuration '{}' chose backend {} and the run configuration says {}: drop "
                                 "one of them",
                                 c.tuned, backend, c.backend));
  c.pipeline = p;
  c.backend = backend;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double at = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(at));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (at - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

LiveReport run_live(const LiveConfig& config, sources::FrameSource& source, dct::Backend& backend,
                    const std::function<void(const FrameRecord&, const dct::FrameOutput&, const cv::Mat&)>& on_frame) {
  namespace fs = std::filesystem;
  LiveReport rep;
  const fs::path dir(config.output);
  sources::Frame frame;
  // The reference: a file, or the stream's first frame.
  if (config.reference != "first") {
    backend.set_reference(dct::read_grey(config.reference));
  } else {
    if (!source.next(frame)) {
      rep.source = source.stats();
      throw InputError(fmt::format("source '{}' gave no frame to take the reference from{}; check the source",
                                   source.spec().text,
                                   rep.source.last_error.empty() ? "" : " (" + rep.source.last_error + ")"));
    }
    backend.set_reference(frame.image);
    rep.reference_sequence = frame.sequence;
  }
  rep.reference_dots = static_cast<int>(backend.reference_dots().size());
  // A live run reports every frame's stages, the device's too: their events cost a GPU frame about
  // 16 us of host time (docs/PERFORMANCE.md), against tens of milliseconds between camera frames.
  backend.time_device_stages(true);
  // frames.csv: one row per measured frame, flushed as it is written (kept if the run stops).
  std::ofstream log;
  if (!dir.empty()) {
    fs::create_directories(dir);
    log.open(dir / "frames.csv");
    if (!log) throw InputError(fmt::format("cannot write {}; give an output folder you can write", (dir / "frames.csv").string()));
    log << "frame,sequence,timestamp_s,latency_ms,process_ms,write_ms,dots,matched,valid_points,"
           "mean_e_xx_microstrain,mean_e_yy_microstrain\n";
  }
  double first_arrival = -1, last_end = 0;
  for (std::int64_t k = 0; config.max_frames == 0 || k < config.max_frames; ++k) {
    const double w0 = sources::steady_seconds();
    bool got = false;
    try {
      got = source.next(frame);
    } catch (const std::exception& e) {
      rep.stopped_because = e.what();
      break;
    }
    if (!got) {
      if (source.stats().disconnected)
        rep.stopped_because = fmt::format("the source went away: {}", source.stats().last_error);
      break;
    }
    rep.wait_seconds.push_back(sources::steady_seconds() - w0);
    if (first_arrival < 0) first_arrival = frame.arrival_s;
    FrameRecord r;
    r.sequence = frame.sequence;
    r.timestamp_s = frame.timestamp_s;
    dct::FrameOutput out;
    const double p0 = sources::steady_seconds();
    try {
      out = backend.process(frame.image);
    } catch (const std::exception& e) {
      rep.stopped_because = fmt::format("frame {}: {}", frame.sequence, e.what());
      break;
    }
    r.process_s = sources::steady_seconds() - p0;
    for (const auto& f : out.fields)
      if (f.status == dct::PointStatus::ok) {
        ++r.valid_points;
        r.mean_exx += f.exx;
        r.mean_eyy += f.eyy;
      }
    if (r.valid_points) {
      r.mean_exx /= r.valid_points;
      r.mean_eyy /= r.valid_points;
    }
    r.dots = static_cast<int>(out.dots.size());
    r.matched = out.matches.matched;
    const double c0 = sources::steady_seconds();
    const std::size_t index = rep.frames.size() + 1;
    if (!dir.empty()) {
      dct::write_fields_csv(dir / fmt::format("frame_{:06d}.csv", index), backend.points(), out.fields);
      if (config.overlay_every > 0 && (index - 1) % static_cast<std::size_t>(config.overlay_every) == 0)
        for (dct::Field f : {dct::Field::ux, dct::Field::uy, dct::Field::exx, dct::Field::eyy, dct::Field::exy}) {
          std::vector<double> v;
          for (const auto& x : out.fields)
            v.push_back(x.status == dct::PointStatus::ok ? dct::field_value(x, f) : std::nan(""));
          dct::write_image(dir / fmt::format("frame_{:06d}_{}.png", index, dct::field_name(f)),
                           dct::overlay(frame.image, backend.points(), config.pipeline.points_x,
                                        config.pipeline.points_y, v, dct::field_name(f), dct::field_unit(f)));
        }
    }
    const double end = sources::steady_seconds();
    r.write_s = end - c0;
    r.latency_s = end - frame.arrival_s;
    last_end = end;
    for (const auto& [stage, s] : out.seconds) rep.stage_seconds[stage].push_back(s);
    rep.frames.push_back(r);
    if (log.is_open())
      log << fmt::format("{},{},{:.6f},{:.3f},{:.3f},{:.3f},{},{},{},{:.2f},{:.2f}\n", rep.frames.size(), r.sequence,
                         r.timestamp_s, 1e3 * r.latency_s, 1e3 * r.process_s, 1e3 * r.write_s, r.dots, r.matched,
                         r.valid_points, 1e6 * r.mean_exx, 1e6 * r.mean_eyy)
          << std::flush;
    if (on_frame) on_frame(r, out, frame.image);
    if (r.valid_points == 0) {
      rep.stopped_because = fmt::format("frame {}: no point has a valid value ({} dots found, {} matched); check the "
                                        "threshold, polarity and area limits against the images",
                                        frame.sequence, r.dots, r.matched);
      break;
    }
  }
  rep.source = source.stats();
  rep.wall_s = first_arrival < 0 ? 0 : last_end - first_arrival;
  return rep;
}

namespace {

// Pairs frames of two sources: each frame's key (its sequence number or timestamp, counted from
// the source's first frame) must match the partner's within the tolerance; the frame that is
// behind is dropped (and counted) until they do.
class Pairer {
 public:
  Pairer(sources::FrameSource& a, sources::FrameSource& b, bool by_time, double tol)
      : a_(a), b_(b), by_time_(by_time), tol_(tol) {}
  bool next(sources::Frame& fa, sources::Frame& fb) {
    if (!a_.next(fa) || !b_.next(fb)) return false;
    for (;;) {
      const double ka = key(fa, first_a_), kb = key(fb, first_b_);
      if (std::abs(ka - kb) <= (by_time_ ? tol_ : 0.5)) return true;
      if (ka < kb) {
        ++dropped_a;
        if (!a_.next(fa)) return false;
      } else {
        ++dropped_b;
        if (!b_.next(fb)) return false;
      }
    }
  }
  std::uint64_t dropped_a = 0, dropped_b = 0;

 private:
  double key(const sources::Frame& f, std::optional<double>& first) const {
    const double k = by_time_ ? f.timestamp_s : static_cast<double>(f.sequence);
    if (!first) first = k;
    return k - *first;
  }
  sources::FrameSource& a_;
  sources::FrameSource& b_;
  bool by_time_;
  double tol_;
  std::optional<double> first_a_, first_b_;
};

}  // namespace

LiveReport run_live_stereo(const LiveConfig& config, sources::FrameSource& left, sources::FrameSource& right,
                           dct::stereo::StereoPipeline& pipeline,
                           const std::function<void(const FrameRecord&, const dct::FrameOutput&, const cv::Mat&)>& on_frame) {
  namespace fs = std::filesystem;
  if (config.reference != "first")
    throw InputError("a stereo run takes its reference from the first pair of frames; drop 'reference' (or set it to "
                     "first)");
  LiveReport rep;
  const fs::path dir(config.output);
  Pairer pairs(left, right, config.pair_by_timestamp, config.pair_tolerance_s);
  sources::Frame fl, fr;
  auto stats = [&] {
    rep.source = left.stats();
    rep.source2 = right.stats();
    rep.unpaired_first = pairs.dropped_a;
    rep.unpaired_second = pairs.dropped_b;
  };
  if (!pairs.next(fl, fr)) {
    stats();
    throw InputError(fmt::format("sources '{}' and '{}' gave no pair of frames to take the reference from{}; check "
                                 "both sources",
                                 left.spec().text, right.spec().text,
                                 rep.source.last_error.empty() && rep.source2.last_error.empty()
                                     ? ""
                                     : " (" + rep.source.last_error + rep.source2.last_error + ")"));
  }
  pipeline.set_reference(fl.image, fr.image);
  pipeline.left().time_device_stages(true);  // every frame's stages, as run_live's
  pipeline.right().time_device_stages(true);
  rep.reference_sequence = fl.sequence;
  rep.reference_dots = static_cast<int>(pipeline.left().reference_dots().size());
  rep.stereo_reference = pipeline.reference_matches().summary();
  std::ofstream log;
  if (!dir.empty()) {
    fs::create_directories(dir);
    log.open(dir / "frames.csv");
    if (!log) throw InputError(fmt::format("cannot write {}; give an output folder you can write", (dir / "frames.csv").string()));
    log << "frame,sequence,timestamp_s,sequence_right,timestamp_right_s,latency_ms,process_ms,write_ms,dots,matched,"
           "valid_points,mean_e_xx_microstrain,mean_e_yy_microstrain,triangulated,mean_u_z_mm\n";
  }
  double first_arrival = -1, last_end = 0;
  for (std::int64_t k = 0; config.max_frames == 0 || k < config.max_frames; ++k) {
    const double w0 = sources::steady_seconds();
    bool got = false;
    try {
      got = pairs.next(fl, fr);
    } catch (const std::exception& e) {
      rep.stopped_because = e.what();
      break;
    }
    if (!got) {
      if (left.stats().disconnected || right.stats().disconnected)
        rep.stopped_because = fmt::format("a source went away: {}{}", left.stats().last_error, right.stats().last_error);
      break;
    }
    rep.wait_seconds.push_back(sources::steady_seconds() - w0);
    const double arrival = std::max(fl.arrival_s, fr.arrival_s);
    if (first_arrival < 0) first_arrival = arrival;
    FrameRecord r;
    r.sequence = fl.sequence;
    r.timestamp_s = fl.timestamp_s;
    dct::stereo::StereoFrame out;
    const double p0 = sources::steady_seconds();
    try {
      out = pipeline.process(fl.image, fr.image);
    } catch (const std::exception& e) {
      rep.stopped_because = fmt::format("frame pair {}/{}: {}", fl.sequence, fr.sequence, e.what());
      break;
    }
    r.process_s = sources::steady_seconds() - p0;
    int uz_points = 0;
    for (std::size_t i = 0; i < out.left.fields.size(); ++i) {
      const auto& f = out.left.fields[i];
      if (f.status == dct::PointStatus::ok) {
        ++r.valid_points;
        r.mean_exx += f.exx;
        r.mean_eyy += f.eyy;
      }
      if (out.fields[i].status == dct::PointStatus::ok) {
        ++uz_points;
        r.mean_uz += out.fields[i].uz;
      }
    }
    if (r.valid_points) {
      r.mean_exx /= r.valid_points;
      r.mean_eyy /= r.valid_points;
    }
    if (uz_points) r.mean_uz /= uz_points;
    r.dots = static_cast<int>(out.left.dots.size());
    r.matched = out.left.matches.matched;
    r.triangulated = out.triangulated;
    const double c0 = sources::steady_seconds();
    const std::size_t index = rep.frames.size() + 1;
    if (!dir.empty()) {
      dct::stereo::write_stereo_fields_csv(dir / fmt::format("frame_{:06d}.csv", index), pipeline.points(),
                                           out.left.fields, out.fields);
      dct::stereo::write_stereo_dots_csv(dir / fmt::format("frame_{:06d}_dots3d.csv", index), pipeline, out);
      if (config.overlay_every > 0 && (index - 1) % static_cast<std::size_t>(config.overlay_every) == 0) {
        for (dct::Field f : {dct::Field::ux, dct::Field::uy, dct::Field::exx, dct::Field::eyy, dct::Field::exy}) {
          std::vector<double> v;
          for (const auto& x : out.left.fields)
            v.push_back(x.status == dct::PointStatus::ok ? dct::field_value(x, f) : std::nan(""));
          dct::write_image(dir / fmt::format("frame_{:06d}_{}.png", index, dct::field_name(f)),
                           dct::overlay(fl.image, pipeline.points(), config.pipeline.points_x,
                                        config.pipeline.points_y, v, dct::field_name(f), dct::field_unit(f)));
        }
        std::vector<double> v;
        for (const auto& x : out.fields) v.push_back(x.status == dct::PointStatus::ok ? x.uz : std::nan(""));
        dct::write_image(dir / fmt::format("frame_{:06d}_u_z.png", index),
                         dct::overlay(fl.image, pipeline.points(), config.pipeline.points_x, config.pipeline.points_y, v,
                                      "u_z", "mm"));
      }
    }
    const double end = sources::steady_seconds();
    r.write_s = end - c0;
    r.latency_s = end - arrival;
    last_end = end;
    for (const auto& [stage, sec] : out.seconds) rep.stage_seconds[stage].push_back(sec);
    rep.frames.push_back(r);
    if (log.is_open())
      log << fmt::format("{},{},{:.6f},{},{:.6f},{:.3f},{:.3f},{:.3f},{},{},{},{:.2f},{:.2f},{},{:.6f}\n",
                         rep.frames.size(), r.sequence, r.timestamp_s, fr.sequence, fr.timestamp_s, 1e3 * r.latency_s,
                         1e3 * r.process_s, 1e3 * r.write_s, r.dots, r.matched, r.valid_points, 1e6 * r.mean_exx,
                         1e6 * r.mean_eyy, r.triangulated, r.mean_uz)
          << std::flush;
    if (on_frame) on_frame(r, out.left, fl.image);
    if (r.valid_points == 0 || uz_points == 0) {
      rep.stopped_because = fmt::format("frame pair {}/{}: no point has a valid {} ({} dots found, {} matched, {} "
                                        "triangulated); check the threshold, polarity and area limits against the "
                                        "images, and that the calibration is of this pair",
                                        fl.sequence, fr.sequence, r.valid_points == 0 ? "in-plane value" : "u_z",
                                        r.dots, r.matched, r.triangulated);
      break;
    }
  }
  stats();
  rep.wall_s = first_arrival < 0 ? 0 : last_end - first_arrival;
  return rep;
}

}  // namespace dtflop::live
