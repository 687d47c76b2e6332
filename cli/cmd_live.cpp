// `dtflop live dct --source SPEC --config run.yaml`: the DCT workload on a live stream (a
// camera, a video file paced like one, a GStreamer pipeline). Frames are measured as they come;
// each frame's fields are written as CSV at once; at the end (the stream's end, --max-frames,
// or a stop) it prints the per-frame latency (p50/p99/max), the throughput, the frames the
// source dropped, where the time went per stage and, with --machine, the DTFLOP model's
// prediction of a frame beside the measured time.
#include <algorithm>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.hpp"
#include "cli/table.hpp"
#include "cli/workload_cli.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/units.hpp"
#include "sources/frame_source.hpp"
#include "sources/live.hpp"
#include "workloads/dct/io.hpp"
#ifdef DTFLOP_HAVE_VIEWER
#include "sources/viewer.hpp"
#endif
#include <chrono>
#include <thread>
#include "workloads/dct/backend.hpp"
#include "workloads/dct/specimen.hpp"
#include "workloads/dct/stereo_dots.hpp"
#include "workloads/dct/workload.hpp"
#include "workloads/workload.hpp"

#include <opencv2/videoio.hpp>

namespace dtflop::cli {
namespace {

struct LiveArgs {
  std::string source;
  std::string source2;
  std::string calibration;
  std::string config;
  std::string output;
  std::int64_t max_frames = -1;
  PredictArgs predict;
  int serve = 0;            // viewer port (0: none)
  std::string serve_field = "e_xx";
  double linger = 0;        // seconds the viewer stays up after the run
};

double steady_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

dct::Field field_named(const std::string& name) {
  for (dct::Field f : {dct::Field::ux, dct::Field::uy, dct::Field::exx, dct::Field::eyy, dct::Field::exy})
    if (dct::field_name(f) == name) return f;
  throw InputError(fmt::format("--serve-field '{}': give u_x, u_y, e_xx, e_yy or e_xy", name));
}

// The configuration `dtflop tune -o` chose (schema dtflop.tuned, workload dct), validated by the
// DCT workload like `dtflop run --tuned`, applied to the live configuration.
void apply_tuned_file(live::LiveConfig& c, const std::string& config_name) {
  const std::string what = fmt::format("'tuned: {}' in {}", c.tuned, config_name);
  const nlohmann::json t = parse_json_limited(read_file_limited(c.tuned, what, kMaxJsonFileBytes), what);
  if (!t.is_object() || t.value("schema", "") != "dtflop.tuned" || !t.contains("workload") || !t.contains("backend") ||
      !t.contains("config") || !t["config"].is_object() || !t["backend"].is_string())
    throw InputError(fmt::format("{} is not a result of `dtflop tune -o` (schema dtflop.tuned with workload, backend and "
                                 "config); give the file tune wrote",
                                 what));
  if (t["workload"] != "dct")
    throw InputError(fmt::format("{} is a configuration of {}, not dct; tune the dct workload", what,
                                 t["workload"].dump()));
  const std::string backend = t["backend"].get<std::string>();
  const workload::Workload& w = workload::find("dct");
  workload::Config cfg;
  try {
    cfg = w.validate(t["config"], w.backend(backend));
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", what, e.what()));
  }
  live::apply_tuned(c, backend, dct::pipeline_options(cfg, backend));
}

void run_live_dct(const LiveArgs& a) {
  live::LiveConfig c = live::load_live_config(a.config);
  if (!a.source.empty()) c.source = a.source;
  if (!a.source2.empty()) c.source2 = a.source2;
  if (!a.calibration.empty()) c.calibration = a.calibration;
  if (!c.source2.empty() && c.calibration.empty())
    throw InputError(fmt::format("a second source needs the pair's calibration: give --calibration rig.yaml or "
                                 "'calibration:' in {} (dtflop live stereo-calibrate writes one)",
                                 a.config));
  if (c.source2.empty() && !c.calibration.empty())
    throw InputError("a stereo calibration is given but no second source: give --source2 (or 'source2:'), or drop the "
                     "calibration");
  if (!c.tuned.empty()) apply_tuned_file(c, a.config);
  if (!a.output.empty()) c.output = a.output;
  if (a.max_frames >= 0) c.max_frames = a.max_frames;
  if (c.source.empty())
    throw InputError(fmt::format("no source: give --source (e.g. file:clip.mp4?paced=1) or 'source:' in {}", a.config));
  if (c.output.empty())
    throw InputError(fmt::format("no output folder: give -o DIR or 'output:' in {}", a.config));
  {
    std::error_code ec;
    const auto st = std::filesystem::symlink_status(c.output, ec);
    if (std::filesystem::exists(st) && !std::filesystem::is_directory(st))
      throw InputError(fmt::format("output '{}' exists and is not a folder; name a new folder", c.output));
  }
  // The prediction's profile is read before any frame, so a bad one costs no measurement.
  std::optional<MachineProfile> profile;
  Variant wanted = Variant::extended;
  if (!a.predict.machine.empty()) {
    profile = load_profile(a.predict.machine);
    wanted = wanted_variant(a.predict, *profile);
  }
  const sources::SourceSpec spec = sources::parse_source_spec(c.source);
  const dct::Field shown = field_named(a.serve_field);
#ifdef DTFLOP_HAVE_VIEWER
  std::unique_ptr<live::Viewer> viewer;
  if (a.serve) viewer = std::make_unique<live::Viewer>(a.serve);
#else
  if (a.serve) throw InputError("--serve: this dtflop was built without cpp-httplib; install libcpp-httplib-dev and rebuild");
#endif
  const bool stereo = !c.source2.empty();
  std::optional<sources::SourceSpec> spec2;
  std::optional<dct::stereo::Rig> rig;
  if (stereo) {
    spec2 = sources::parse_source_spec(c.source2);
    rig = dct::stereo::read_rig(c.calibration);
  }
  std::unique_ptr<dct::Backend> backend;
  std::unique_ptr<dct::stereo::StereoPipeline> pipeline;
  if (stereo) {
    dct::stereo::StereoMatchOptions so;
    so.epipolar_tolerance = c.epipolar_tolerance;
    pipeline = std::make_unique<dct::stereo::StereoPipeline>(*rig, c.backend, c.pipeline, so);
  } else {
    backend = dct::make_backend(c.backend, c.pipeline);
  }
  const std::string backend_name = stereo ? pipeline->left().name() : backend->name();
  auto source = sources::open_source(spec);
  std::unique_ptr<sources::FrameSource> source2;
  if (stereo) source2 = sources::open_source(*spec2);
  const std::string described = stereo ? source->describe() + " + " + source2->describe() : source->describe();
  fmt::print(stderr, "dtflop live dct: {} -> {} on backend {}{}\n", described, c.output, backend_name,
             stereo ? " (stereo)" : "");
  const double period = source->frame_rate() > 0 ? 1.0 / source->frame_rate() : 0.0;
  double last_publish = -1, first_time = -1;
  std::int64_t measured = 0;
#ifdef DTFLOP_HAVE_VIEWER
  if (viewer) fmt::print(stderr, "dtflop live dct: viewer at {}\n", viewer->url());
#endif

  std::vector<double> predicted;
  std::string fallback;
  std::optional<Judged> first_judged;
  auto on_frame = [&](const live::FrameRecord& r, const dct::FrameOutput& out, const cv::Mat& image) {
    const std::vector<dct::Vec2>& points = stereo ? pipeline->points() : backend->points();
    (void)points;
    ++measured;
    const double now = steady_now();
    if (first_time < 0) first_time = now;
#ifdef DTFLOP_HAVE_VIEWER
    // The viewer gets a frame at most every 0.2 s (encoding a PNG costs time of its own).
    if (viewer && (last_publish < 0 || now - last_publish >= 0.2)) {
      last_publish = now;
      std::vector<double> v;
      for (const auto& x : out.fields) v.push_back(x.status == dct::PointStatus::ok ? dct::field_value(x, shown) : std::nan(""));
      const nlohmann::json status = {
          {"frame", r.sequence},
          {"fps", measured > 1 && now > first_time ? nlohmann::json(static_cast<double>(measured - 1) / (now - first_time)) : nlohmann::json()},
          {"latency_s", r.latency_s},
          {"margin_s", period > 0 ? nlohmann::json(period - r.latency_s) : nlohmann::json()},
          {"dropped", source->stats().dropped},
          {"field", dct::field_name(shown) + " [" + dct::field_unit(shown) + "]"}};
      viewer->publish(dct::overlay(image, points, c.pipeline.points_x, c.pipeline.points_y, v,
                                   dct::field_name(shown), dct::field_unit(shown)),
                      status);
    }
#else
    (void)r;
    (void)image;
    (void)shown;
    (void)last_publish;
    (void)period;
#endif
    if (!profile) return;
    const Predicted p = predict_with_fallback(*profile, out.counts, wanted);
    predicted.push_back(p.prediction.total);
    if (!first_judged) {
      fallback = p.fallback;
      PredictionProfile pp;
      pp.profile = *profile;
      first_judged = judge(p, pp, out.counts, std::nullopt);
    }
  };
  const live::LiveReport rep = stereo ? live::run_live_stereo(c, *source, *source2, *pipeline, on_frame)
                                      : live::run_live(c, *source, *backend, on_frame);

  std::vector<double> latency, process, write;
  for (const auto& r : rep.frames) {
    latency.push_back(r.latency_s);
    process.push_back(r.process_s);
    write.push_back(r.write_s);
  }
  const auto n = rep.frames.size();
  const double fps = n > 1 && rep.wall_s > 0 ? static_cast<double>(n) / rep.wall_s : std::nan("");
  // A live source's rate is the deadline; a file read as fast as it decodes has none.
  const bool live_rate = spec.paced || (spec.kind != sources::SourceSpec::Kind::file &&
                                        spec.kind != sources::SourceSpec::Kind::images);
  const double nominal = live_rate ? source->frame_rate() : 0.0;
  fmt::print("reference: {} dots; {} frames measured ({} delivered by the source, {} dropped{}{})\n",
             rep.reference_dots, n, rep.source.delivered, rep.source.dropped,
             rep.source.incomplete ? fmt::format(", {} of them damaged", rep.source.incomplete) : "",
             rep.source.reopened ? fmt::format(", reopened {} time(s)", rep.source.reopened) : "");
  if (stereo) {
    fmt::print("stereo: reference {}; second source: {} delivered, {} dropped; unpaired frames dropped: {} of the "
               "first source, {} of the second\n",
               rep.stereo_reference, rep.source2.delivered, rep.source2.dropped, rep.unpaired_first,
               rep.unpaired_second);
  }
  nlohmann::json js = {{"source", described},
                       {"backend", backend_name},
                       {"reference_dots", rep.reference_dots},
                       {"frames_measured", n},
                       {"frames_delivered", rep.source.delivered},
                       {"frames_dropped", rep.source.dropped},
                       {"frames_damaged", rep.source.incomplete},
                       {"reopened", rep.source.reopened},
                       {"disconnected", rep.source.disconnected},
                       {"stopped_because", rep.stopped_because}};
  if (rep.reference_sequence) js["reference_sequence"] = *rep.reference_sequence;
  if (stereo)
    js["stereo"] = {{"calibration", c.calibration},
                    {"reference_matching", rep.stereo_reference},
                    {"second_source_delivered", rep.source2.delivered},
                    {"second_source_dropped", rep.source2.dropped},
                    {"unpaired_dropped_first", rep.unpaired_first},
                    {"unpaired_dropped_second", rep.unpaired_second}};
  if (!c.tuned.empty()) js["tuned"] = c.tuned;
  if (n > 0) {
    fmt::print("latency per frame (arrival to fields written): p50 {}, p99 {}, max {}; throughput {:.2f} frames/s\n",
               format_duration(live::percentile(latency, 50)), format_duration(live::percentile(latency, 99)),
               format_duration(live::percentile(latency, 100)), fps);
    Table t({"stage", "p50", "p99", "max"});
    auto row = [&](const std::string& name, const std::vector<double>& v) {
      t.row({name, format_duration(live::percentile(v, 50)), format_duration(live::percentile(v, 99)),
             format_duration(live::percentile(v, 100))});
      js["stages"][name] = {{"p50", live::percentile(v, 50)}, {"p99", live::percentile(v, 99)},
                            {"max", live::percentile(v, 100)}};
    };
    row("waiting for the frame", rep.wait_seconds);
    for (const auto& [stage, v] : rep.stage_seconds) row("backend: " + stage, v);
    row("backend (measured around it)", process);
    row("writing the CSV", write);
    fmt::print("{}", t.str());
    js["latency"] = {{"p50", live::percentile(latency, 50)},
                     {"p99", live::percentile(latency, 99)},
                     {"max", live::percentile(latency, 100)}};
    js["throughput_fps"] = std::isfinite(fps) ? nlohmann::json(fps) : nlohmann::json();
    if (nominal > 0) {
      // Keeping up: every frame done within one frame period and none dropped; else the stage
      // that takes the largest part of the period is named.
      const double frame_period = 1.0 / nominal;
      const bool keeps_up = live::percentile(latency, 99) <= frame_period && rep.source.dropped == 0;
      js["period_s"] = frame_period;
      js["keeps_up"] = keeps_up;
      if (keeps_up) {
        fmt::print("keeps up with {:.3g} frames/s: p99 latency {} within the {} frame period, no frame dropped\n",
                   nominal, format_duration(live::percentile(latency, 99)), format_duration(frame_period));
      } else {
        std::string slowest = "writing the CSV";
        double worst = live::percentile(write, 50);
        for (const auto& [stage, v] : rep.stage_seconds)
          if (stage != "total" && live::percentile(v, 50) > worst) {
            worst = live::percentile(v, 50);
            slowest = "backend: " + stage;
          }
        fmt::print("does NOT keep up with {:.3g} frames/s (period {}): p99 latency {}, {} dropped; the slowest stage "
                   "is {} ({} median){}\n",
                   nominal, format_duration(frame_period), format_duration(live::percentile(latency, 99)),
                   rep.source.dropped, slowest, format_duration(worst),
                   live::percentile(process, 50) > frame_period ? "; the backend alone takes longer than a period" : "");
        js["slowest_stage"] = slowest;
      }
    }
    if (!predicted.empty()) {
      const double pm = live::percentile(predicted, 50), mm = live::percentile(process, 50);
      fmt::print("predicted by the DTFLOP model on {}: {} per frame (median over frames); measured {}; "
                 "predicted/measured {:.2f}\n",
                 machine_name(*profile), format_duration(pm), format_duration(mm), pm / mm);
      if (!fallback.empty()) fmt::print(stderr, "dtflop: note: {}\n", fallback);
      js["predicted_per_frame_s"] = pm;
      js["measured_per_frame_s"] = mm;
      js["machine"] = machine_json(a.predict.machine, *profile);
      if (first_judged)
        js["first_frame_interval"] = {{"lo", first_judged->interval.lo}, {"hi", first_judged->interval.hi}};
    }
  }
  const std::filesystem::path dir(c.output);
  if (std::filesystem::is_directory(dir)) write_file_atomically(dir / "summary.json", js.dump(2) + "\n");
  fmt::print("wrote {0}/frames.csv (one row per frame), {0}/frame_NNNNNN.csv (fields) and {0}/summary.json\n",
             c.output);
#ifdef DTFLOP_HAVE_VIEWER
  if (viewer && a.linger > 0) {
    fmt::print(stderr, "dtflop live dct: the viewer stays at {} for {} s\n", viewer->url(), a.linger);
    std::this_thread::sleep_for(std::chrono::duration<double>(a.linger));
  }
#endif
  if (!rep.stopped_because.empty()) {
    if (rep.source.disconnected || rep.source2.disconnected) {
      fmt::print(stderr, "dtflop: failed: the run stopped: {}; the {} frames measured before are kept\n",
                 rep.stopped_because, n);
      set_exit_status(kExitFailure);
      return;
    }
    throw InputError(fmt::format("the run stopped: {} ({} frames measured before it are kept in {})",
                                 rep.stopped_because, n, c.output));
  }
}

// The specimen's deformation scaled by t (0: the reference, 1: the full closed form): a ramp of
// frames for a video, each frame a closed form of its own.
class Scaled final : public dct::Deformation {
 public:
  Scaled(std::shared_ptr<const dct::Deformation> d, double t) : d_(std::move(d)), t_(t) {}
  dct::Vec2 displacement(dct::Vec2 X) const override {
    const dct::Vec2 u = d_->displacement(X);
    return {t_ * u.x, t_ * u.y};
  }
  dct::Gradient gradient(dct::Vec2 X) const override {
    const dct::Gradient g = d_->gradient(X);
    return {t_ * g.ux_x, t_ * g.ux_y, t_ * g.uy_x, t_ * g.uy_y};
  }
  bool in_material(dct::Vec2 X) const override { return d_->in_material(X); }
  std::string describe() const override { return fmt::format("{:.3f} x ({})", t_, d_->describe()); }

 private:
  std::shared_ptr<const dct::Deformation> d_;
  double t_;
};

struct VideoArgs {
  std::string spec;
  std::string output;
  int frames = 60;
  double fps = 30;
};

// Renders `frames` frames of the specimen, its deformation ramping from none to the full closed
// form, into an MJPG AVI at `fps`: a video source with known content for `live dct`.
void write_specimen_video(const VideoArgs& a) {
  const dct::Specimen s = dct::parse_specimen(a.spec);
  if (s.render.bit_depth != 8) throw InputError("a video holds 8-bit frames; leave bits at 8 in the specimen");
  check_output(a.output, {});
  if (std::filesystem::path(a.output).extension() != ".avi")
    throw InputError(fmt::format("-o '{}': the video is written as MJPG in an .avi file; name it NAME.avi", a.output));
  const std::string tmp = a.output + ".part.avi";
  cv::VideoWriter w(tmp, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), a.fps, {s.render.width, s.render.height}, false);
  if (!w.isOpened()) throw InputError(fmt::format("cannot write a video to '{}'; give a writable path", a.output));
  w.set(cv::VIDEOWRITER_PROP_QUALITY, 100);
  for (int k = 0; k < a.frames; ++k) {
    const double t = a.frames == 1 ? 1.0 : static_cast<double>(k) / (a.frames - 1);
    const Scaled d(s.deformation, t);
    w.write(dct::render(s.dots, d, s.render, s.hole));
  }
  w.release();
  std::filesystem::rename(tmp, a.output);
  fmt::print("wrote {}: {} frames of {}x{} at {:.3g} fps, {} ramping from none to full\n", a.output, a.frames,
             s.render.width, s.render.height, a.fps, s.deformation->describe());
}

struct CalibrateArgs {
  std::vector<std::string> left, right;
  std::string board = "checkerboard:9x6:30";
  std::string output;
};

// "checkerboard:9x6:30" or "circles:4x11:30" (inner corners or circles, square or pitch in mm).
dct::stereo::Board parse_board(const std::string& text) {
  const auto bad = [&] {
    return InputError(fmt::format("--board '{}': write checkerboard:COLSxROWS:SQUARE_MM (inner corners, e.g. "
                                  "checkerboard:9x6:30) or circles:COLSxROWS:PITCH_MM (asymmetric grid, e.g. "
                                  "circles:4x11:30)",
                                  text));
  };
  const auto c1 = text.find(':'), c2 = text.rfind(':');
  if (c1 == std::string::npos || c2 == c1) throw bad();
  dct::stereo::Board b;
  const std::string kind = text.substr(0, c1);
  if (kind == "checkerboard") b.target = dct::stereo::Board::Target::checkerboard;
  else if (kind == "circles") b.target = dct::stereo::Board::Target::circles;
  else throw bad();
  int w = 0, h = 0;
  char x = 0, end = 0;
  if (std::sscanf(text.substr(c1 + 1, c2 - c1 - 1).c_str(), "%d%c%d%c", &w, &x, &h, &end) != 3 || x != 'x' || w < 2 ||
      h < 2 || w > 100 || h > 100)
    throw bad();
  char* e = nullptr;
  const std::string sq = text.substr(c2 + 1);
  const double square = std::strtod(sq.c_str(), &e);
  if (sq.empty() || *e != '\0' || !std::isfinite(square) || square <= 0 || square > 10000) throw bad();
  b.inner = {w, h};
  b.square = square;
  return b;
}

void stereo_calibrate(const CalibrateArgs& a) {
  const dct::stereo::Board board = parse_board(a.board);
  if (a.left.size() != a.right.size())
    throw InputError(fmt::format("{} left and {} right views: give the views as pairs, in the same order",
                                 a.left.size(), a.right.size()));
  check_output(a.output, [&] {
    std::vector<std::string> in = a.left;
    in.insert(in.end(), a.right.begin(), a.right.end());
    return in;
  }());
  std::vector<cv::Mat> L, R;
  for (std::size_t i = 0; i < a.left.size(); ++i) {
    cv::Mat l = dct::read_grey(a.left[i]), r = dct::read_grey(a.right[i]);
    // calib3d's corner finders take 8-bit views.
    if (l.depth() == CV_16U) l.convertTo(l, CV_8U, 1.0 / 257);
    if (r.depth() == CV_16U) r.convertTo(r, CV_8U, 1.0 / 257);
    L.push_back(l);
    R.push_back(r);
  }
  const dct::stereo::Calibration c = dct::stereo::calibrate(L, R, board);
  for (const auto& n : c.notes) fmt::print("{}\n", n);
  fmt::print("focal lengths {:.2f} / {:.2f} px (left), {:.2f} / {:.2f} px (right); baseline {:.3f} mm\n", c.rig.left.K(0, 0),
             c.rig.left.K(1, 1), c.rig.right.K(0, 0), c.rig.right.K(1, 1), c.rig.baseline());
  const std::string tmp = a.output + ".part.yaml";
  dct::stereo::write_rig(tmp, c);
  std::filesystem::rename(tmp, a.output);
  fmt::print("wrote {} (`dtflop live dct --source2 ... --calibration {}` uses it)\n", a.output, a.output);
}

}  // namespace

void add_live_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "live", "Measure a workload live, frame by frame, from a camera or stream: per-frame latency, throughput, "
              "dropped frames, fields as they are measured, and the model's prediction beside them.");
  app->require_subcommand(1);
  auto* dct = app->add_subcommand(
      "dct", "Dot centroid tracking on a live source (docs/sources.md): the first frame is the reference (or the "
             "config's 'reference'), each further frame's fields go to OUTPUT/frame_NNNNNN.csv as it is measured.");
  auto a = std::make_shared<LiveArgs>();
  dct->add_option("--source", a->source,
                  "device:0, file:clip.mp4[?paced=1&fps=30], images:def_%04d.png, gst:'PIPELINE ! appsink', gphoto2:0, "
                  "aravis:CAMERA-ID[?exposure=US&gain=DB&fps=HZ&roi=X,Y,W,H&format=Mono16] (overrides the config's)");
  dct->add_option("--source2", a->source2,
                  "Stereo: the second (right) camera, in --source's forms (overrides the config's 'source2'; needs "
                  "--calibration)");
  dct->add_option("--calibration", a->calibration,
                  "Stereo: the pair's calibration (dtflop live stereo-calibrate; overrides the config's)");
  dct->add_option("--config", a->config, "Run configuration (YAML: source, roi, threshold, polarity, area, backend, "
                                         "interpolation, weight, support, points, threads, output, max_frames, overlay_every, source2, "
                                         "calibration, pair, pair_tolerance_ms, epipolar_tolerance, tuned; "
                                         "docs/sources.md)")
      ->required();
  dct->add_option("-o,--output", a->output, "Output folder (overrides the config's 'output')");
  dct->add_option("--max-frames", a->max_frames, "Stop after this many measured frames (0: at the stream's end)")
      ->check(number_in(0, 1e8, true));
  dct->add_option("--machine", a->predict.machine, "Machine profile (dtflop probe) for the model's prediction per frame");
  dct->add_option("--variant", a->predict.variant, "Model variant: seed, memory or extended (default: the profile's)");
  dct->add_option("--serve", a->serve,
                  "Serve a live view (field image with colour bar, frame rate, deadline margin) on 127.0.0.1:PORT")
      ->check(number_in(1024, 65535, true));
  dct->add_option("--serve-field", a->serve_field, "Field the viewer shows: u_x, u_y, e_xx, e_yy or e_xy")
      ->capture_default_str();
  dct->add_option("--serve-linger", a->linger, "Seconds the viewer stays up after the run ends")
      ->check(number_in(0, 86400));
  dct->callback([a] { run_live_dct(*a); });

  auto* vid = app->add_subcommand(
      "specimen-video", "Render a specimen (as `dtflop specimen` takes it) into an MJPG .avi video whose deformation "
                        "ramps from none to the full closed form: a known source for `live dct` and its benchmark.");
  auto v = std::make_shared<VideoArgs>();
  vid->add_option("spec", v->spec, "KIND:key=value,... as `dtflop specimen` (8-bit)")->required();
  vid->add_option("-o,--output", v->output, "Video file (.avi)")->required();
  vid->add_option("--frames", v->frames, "Frames")->check(number_in(1, 100000, true))->capture_default_str();
  vid->add_option("--fps", v->fps, "Frame rate written in the file")->check(number_in(0.1, 1000))->capture_default_str();
  vid->callback([v] { write_specimen_video(*v); });

  auto* cal = app->add_subcommand(
      "stereo-calibrate", "Calibrate a camera pair from views of a checkerboard or an asymmetric circle grid (OpenCV "
                          "calib3d): both cameras and the pair, the reprojection and epipolar errors judged, written "
                          "as YAML for `live dct --source2 ... --calibration`.");
  auto ca = std::make_shared<CalibrateArgs>();
  cal->add_option("--left", ca->left, "The left camera's views (image files)")->required();
  cal->add_option("--right", ca->right, "The right camera's views, in the same order")->required();
  cal->add_option("--board", ca->board,
                  "checkerboard:COLSxROWS:SQUARE_MM (inner corners) or circles:COLSxROWS:PITCH_MM (asymmetric grid)")
      ->capture_default_str();
  cal->add_option("-o,--output", ca->output, "Calibration file (YAML)")->required();
  cal->callback([ca] { stereo_calibrate(*ca); });
}

}  // namespace dtflop::cli
