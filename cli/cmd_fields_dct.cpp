// `dtflop fields`: the DCT full-field measurement on image files or on a rendered specimen.
// Per frame it writes a CSV of the points (u_x, u_y in px, e_xx, e_yy, e_xy in microstrain,
// validity) and a colour-mapped PNG overlay of each field on the image, with a colour bar and
// units; the overlays of a sequence share one colour range per field.
#include <charconv>
#include <functional>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/printf.h>

#include "cli/command.hpp"
#include "workloads/workload.hpp"
#include "cli/table.hpp"
#include "cli/workload_cli.hpp"
#include "model/json_io.hpp"
#include "model/errors.hpp"
#include "model/units.hpp"
#include "workloads/dct/backend.hpp"
#include "workloads/dct/io.hpp"
#include "workloads/dct/specimen.hpp"
#include "workloads/dct/stereo.hpp"
#include "workloads/dct/stereo_dots.hpp"
#include "workloads/dct/support.hpp"
#include "workloads/dct/tracking.hpp"
#include "workloads/dct/uncertainty.hpp"

namespace dtflop::cli {
namespace {

struct RunDctOptions {
  std::string backend = "cpu-par";
  std::string reference;
  std::string frames;
  std::string specimen;
  std::string support = "200dots";
  bool support_given = false;
  std::string interp = "mls";
  std::string weight = "cubic";
  std::string points = "32x32";
  std::string threshold = "otsu";
  std::string polarity = "dark";
  std::string roi;
  int min_area = 12;
  int max_area = 20000;
  double search_radius = 0;
  int threads = 0;
  std::string out;
  bool no_overlays = false;
  bool per_frame_range = false;
  std::string strain_range;        // LO:HI microstrain
  std::string displacement_range;  // LO:HI px
  // Stereo: the second (right) camera's images and the pair's calibration.
  std::string reference2;
  std::string frames2;
  std::string calibration;
  double epipolar_tolerance = 1.5;
};

// Why no point of a frame has a value, in words and counts, and what to try.
std::string no_valid_point(const std::vector<dct::FieldValue<double>>& fields, const std::string& support) {
  std::map<std::string, int> why;
  int most_support = 0;
  for (const auto& f : fields) {
    why[std::string(dct::to_string(f.status))] += 1;
    most_support = std::max(most_support, f.support);
  }
  std::string counts;
  for (const auto& [w, n] : why) counts += fmt::format("{}{} {}", counts.empty() ? "" : ", ", n, w);
  return fmt::format("no point has a valid value ({}; the largest support held {} dots): with --support {} the "
                     "supports hold too few dots for the basis; give a support in dots (e.g. --support 60dots) or a "
                     "larger radius",
                     counts, most_support, support);
}

// "def_%04d.png" -> the existing files for k = 0, 1, ... (starting at 0 or 1, up to the
// first gap). A name without '%' is one frame.
std::vector<std::filesystem::path> expand_frames(const std::string& pattern) {
  std::vector<std::filesystem::path> out;
  if (pattern.find('%') == std::string::npos) {
    out.emplace_back(pattern);
    return out;
  }
  // A field width or precision is at most 3 digits: "%1000000000d" would build a 1 GB name.
  for (std::size_t at = pattern.find('%'); at != std::string::npos; at = pattern.find('%', at + 1)) {
    std::size_t digits = 0;
    for (std::size_t i = at + 1; i < pattern.size() && digits <= 3; ++i) {
      const char ch = pattern[i];
      if (ch >= '0' && ch <= '9') ++digits;
      else if (ch == '.' || ch == '-' || ch == '+' || ch == ' ' || ch == '#') digits = 0;
      else break;
    }
    if (digits > 3 || pattern.size() > 4096)
      throw InputError(fmt::format("--frames '{}': a field width of more than 3 digits (or a pattern over 4096 "
                                   "characters) names no file; write e.g. def_%04d.png",
                                   pattern.substr(0, 60)));
  }
  for (int k = 0; k < 1000000; ++k) {
    std::string name;
    try {
      name = fmt::sprintf(pattern, k);
    } catch (const std::exception& e) {
      throw InputError(fmt::format("--frames '{}' is not a printf pattern with one integer (e.g. def_%04d.png): {}",
                                   pattern, e.what()));
    }
    if (std::filesystem::exists(name)) out.emplace_back(name);
    else if (k >= 1) break;
  }
  if (out.empty())
    throw InputError(fmt::format("--frames '{}' matches no file (tried indices 0 and 1 onwards)", pattern));
  return out;
}

// x,y,width,height, each a whole number within the largest image dtflop reads (16384 a side), so the
// rectangle's corners and area never overflow.
cv::Rect parse_roi(const std::string& s) {
  constexpr std::int64_t kSide = 16384;
  std::int64_t v[4] = {0, 0, 0, 0};
  const char* p = s.data();
  const char* end = p + s.size();
  bool ok = true;
  for (int i = 0; i < 4 && ok; ++i) {
    const auto r = std::from_chars(p, end, v[i]);
    ok = r.ec == std::errc() && (i == 3 ? r.ptr == end : (r.ptr != end && *r.ptr == ','));
    p = r.ptr + 1;
  }
  if (!ok)
    throw InputError(fmt::format("--roi '{}' is not x,y,width,height (whole numbers, e.g. 100,50,800,600)",
                                 s.substr(0, 60)));
  if (v[0] < 0 || v[1] < 0 || v[2] < 1 || v[3] < 1 || v[0] + v[2] > kSide || v[1] + v[3] > kSide)
    throw InputError(fmt::format("--roi '{}' must lie within 0..{} px with width and height >= 1; give a region "
                                 "inside the image",
                                 s, kSide));
  return {static_cast<int>(v[0]), static_cast<int>(v[1]), static_cast<int>(v[2]), static_cast<int>(v[3])};
}

// The support that minimizes the total strain error (support.hpp): the measured noise and dot
// density, and the strain feature this frame shows. One line, after the first frame; returns the
// suggested dots per support (0: none could be made).
int print_support_suggestion(const dct::Backend& b, const dct::FrameOutput& out, const dct::FrameUncertainty& unc,
                             const dct::PipelineOptions& p, const Size2& grid) {
  const dct::FrameSuggestion fs = p.points.empty()
                                      ? dct::suggest_for_frame(b, out, unc, static_cast<int>(grid.x), static_cast<int>(grid.y))
                                      : dct::suggest_for_frame(b, out, unc, 0, 0);
  if (!fs.ok()) return 0;
  const dct::SupportSuggestion& s = fs.suggestion;
  const dct::StrainFeature& f = fs.feature;
  const std::string feature =
      f.length_px > 0 ? fmt::format("a strain feature of {:.0f} microstrain over {:.0f} px", 1e6 * f.amplitude, f.length_px)
                      : "no strain feature above the noise";
  std::string now;
  if (p.mls.support.kind == dct::Support::Kind::dots) {
    const dct::SupportSuggestion c =
        dct::support_error(std::min(p.mls.support.dots, fs.dots), fs.displacement_sd_px, fs.spacing_px, f);
    now = fmt::format("; {} predicts {:.1f} + {:.1f}", p.mls.support.str(), 1e6 * c.noise, 1e6 * c.bias);
  }
  fmt::print("support: suggest --support {}dots (radius ~{:.0f} px): strain noise ~{:.1f} + smoothing ~{:.1f} "
             "microstrain for displacement sd {:.4f} px, dot spacing {:.1f} px, {}{}\n",
             s.dots, s.radius_px, 1e6 * s.noise, 1e6 * s.bias, fs.displacement_sd_px, fs.spacing_px, feature, now);
  return s.dots;
}

// One overlay kind: a field's values per frame (NaN where a point has none).
struct OverlayLayer {
  std::string name, unit;
  bool strain = false, displacement_px = false;
  std::vector<std::vector<double>> per_frame;
};

OverlayLayer in_plane_layer(dct::Field f, const std::vector<std::vector<dct::FieldValue<double>>>& frames) {
  OverlayLayer l{dct::field_name(f), dct::field_unit(f), f == dct::Field::exx || f == dct::Field::eyy || f == dct::Field::exy,
                 f == dct::Field::ux || f == dct::Field::uy, {}};
  for (const auto& fields : frames) {
    std::vector<double> v;
    for (const auto& x : fields) v.push_back(x.status == dct::PointStatus::ok ? dct::field_value(x, f) : std::nan(""));
    l.per_frame.push_back(std::move(v));
  }
  return l;
}

struct FixedRanges {
  std::optional<dct::ColourRange> strain, displacement;
};
// --strain-range and --displacement-range, checked before any frame is measured.
FixedRanges fixed_ranges(const RunDctOptions& o) {
  FixedRanges r;
  if (!o.strain_range.empty()) r.strain = dct::parse_colour_range(o.strain_range, "--strain-range");
  if (!o.displacement_range.empty()) r.displacement = dct::parse_colour_range(o.displacement_range, "--displacement-range");
  return r;
}

// Writes DIR/STEM_NAME.png for every layer and frame: one colour range per layer across the
// whole sequence (so frames compare), unless --per-frame-range or a fixed range says otherwise.
void write_overlays(const std::filesystem::path& dir, const RunDctOptions& o, const FixedRanges& fixed,
                    const dct::PipelineOptions& p, const std::vector<dct::Vec2>& points, const std::vector<std::string>& stems,
                    const std::function<cv::Mat(std::size_t)>& image, const std::vector<OverlayLayer>& layers) {
  std::vector<dct::ColourRange> sequence;
  for (const auto& l : layers) {
    std::vector<double> every;
    for (const auto& v : l.per_frame)
      for (double x : v)
        if (std::isfinite(x)) every.push_back(x);
    sequence.push_back(dct::colour_range(every));
  }
  for (std::size_t k = 0; k < stems.size(); ++k) {
    const cv::Mat frame = image(k);
    for (std::size_t i = 0; i < layers.size(); ++i) {
      const auto& l = layers[i];
      std::optional<dct::ColourRange> range = l.strain ? fixed.strain : l.displacement_px ? fixed.displacement : std::nullopt;
      if (!range && !o.per_frame_range) range = sequence[i];
      dct::write_image(dir / fmt::format("{}_{}.png", stems[k], l.name),
                       dct::overlay(frame, points, p.points_x, p.points_y, l.per_frame[k], l.name, l.unit, range));
    }
  }
}

// Stereo: the left camera's images (--reference, --frames) and the right one's (--reference2,
// --frames2) measured pair by pair by the stereo pipeline (as `live dct --source2` does): the
// in-plane fields are the left camera's, with u_z and its gradient beside them.
void run_stereo(const RunDctOptions& o, const dct::PipelineOptions& p, const Size2& grid) {
  using namespace dtflop::dct;
  if (!o.specimen.empty())
    throw InputError("--specimen renders one camera; a stereo run (--reference2, --frames2, --calibration) measures "
                     "image files: give --reference and --frames for the left camera");
  if (o.reference2.empty() && o.frames2.empty())
    throw InputError("a stereo calibration is given but no second camera: give --reference2 and --frames2 (the right "
                     "camera's images), or drop --calibration");
  if (o.reference2.empty() || o.frames2.empty())
    throw InputError("the second camera needs both --reference2 and --frames2 (its reference and deformed images, in "
                     "the order of --reference and --frames)");
  if (o.calibration.empty())
    throw InputError("a second camera needs the pair's calibration: give --calibration rig.yaml (dtflop live "
                     "stereo-calibrate writes one)");
  if (o.reference.empty() || o.frames.empty())
    throw InputError("a stereo run needs the left camera's --reference and --frames beside --reference2 and --frames2");
  stereo::StereoMatchOptions so;
  so.epipolar_tolerance = o.epipolar_tolerance;
  stereo::validate(so);
  const auto left_files = expand_frames(o.frames), right_files = expand_frames(o.frames2);
  if (left_files.size() != right_files.size())
    throw InputError(fmt::format("--frames names {} left images and --frames2 {} right images: give the frames as "
                                 "pairs, one right image per left one",
                                 left_files.size(), right_files.size()));
  const FixedRanges fixed = fixed_ranges(o);
  const stereo::Rig rig = stereo::read_rig(o.calibration);
  const cv::Mat ref_left = read_grey(o.reference), ref_right = read_grey(o.reference2);
  const std::filesystem::path dir(o.out);
  {
    std::error_code ec;
    const auto st = std::filesystem::status(dir, ec);
    if (std::filesystem::exists(st) && !std::filesystem::is_directory(st))
      throw InputError(fmt::format("-o '{}' exists and is not a folder; name a new folder", o.out));
  }
  stereo::StereoPipeline pipeline(rig, o.backend, p, so);
  pipeline.set_reference(ref_left, ref_right);  // the calibration's and the images' sizes checked here
  fmt::print("backend {}: {} reference dots (left), {} points ({}x{}), {} {}, support {}\n", pipeline.left().name(),
             pipeline.left().reference_dots().size(), pipeline.points().size(), grid.x, grid.y, to_string(p.interp),
             p.interp == Interp::mls ? to_string(p.mls.weight) : "", p.mls.support.str());
  fmt::print("stereo reference: {}\n", pipeline.reference_matches().summary());

  Table t({"frame", "dots", "matched", "valid points", "mean e_xx [microstrain]", "mean e_yy [microstrain]",
           "triangulated", "u_z points", "mean u_z [mm]", "time"});
  std::vector<std::vector<FieldValue<double>>> all_fields;
  std::vector<std::vector<double>> all_uz;
  std::vector<std::string> stems;
  for (std::size_t k = 0; k < left_files.size(); ++k) {
    const cv::Mat left = read_grey(left_files[k]), right = read_grey(right_files[k]);
    const std::string label = fmt::format("{}/{}", left_files[k].filename().string(), right_files[k].filename().string());
    stereo::StereoFrame out;
    try {
      out = pipeline.process(left, right);
    } catch (const InputError& e) {
      throw InputError(fmt::format("frame pair {}: {}", label, e.what()));
    }
    int valid = 0, uz_points = 0;
    double mxx = 0, myy = 0, muz = 0;
    for (std::size_t i = 0; i < out.left.fields.size(); ++i) {
      const auto& f = out.left.fields[i];
      if (f.status == PointStatus::ok) { ++valid; mxx += f.exx; myy += f.eyy; }
      if (out.fields[i].status == PointStatus::ok) { ++uz_points; muz += out.fields[i].uz; }
    }
    if (valid == 0) throw InputError(fmt::format("frame pair {}: {}", label, no_valid_point(out.left.fields, o.support)));
    if (uz_points == 0)
      throw InputError(fmt::format("frame pair {}: no point has a valid u_z ({} dots triangulated); check that the "
                                   "calibration is of this pair and that both cameras see the dots",
                                   label, out.triangulated));
    const std::string stem = fmt::format("frame_{:04d}", k + 1);
    stereo::write_stereo_fields_csv(dir / (stem + ".csv"), pipeline.points(), out.left.fields, out.fields);
    stereo::write_stereo_dots_csv(dir / (stem + "_dots3d.csv"), pipeline, out);
    write_dots_csv(dir / (stem + "_dots.csv"), pipeline.left().reference_dots(), out.left.dots, out.left.matches, left,
                   out.left.stats.threshold, p.analysis.polarity);
    t.row({label, fmt::format("{}", out.left.dots.size()), fmt::format("{}", out.left.matches.matched),
           fmt::format("{} of {}", valid, out.left.fields.size()), fmt::format("{:.1f}", 1e6 * mxx / valid),
           fmt::format("{:.1f}", 1e6 * myy / valid), fmt::format("{}", out.triangulated),
           fmt::format("{} of {}", uz_points, out.fields.size()), fmt::format("{:.4f}", muz / uz_points),
           format_duration(out.left.seconds["total"] + out.right.seconds["total"] + out.seconds["stereo"])});
    if (!o.no_overlays) {
      std::vector<double> uz;
      for (const auto& x : out.fields) uz.push_back(x.status == PointStatus::ok ? x.uz : std::nan(""));
      all_uz.push_back(std::move(uz));
      all_fields.push_back(std::move(out.left.fields));
      stems.push_back(stem);
    }
  }
  if (!o.no_overlays) {
    std::vector<OverlayLayer> layers;
    for (Field f : {Field::ux, Field::uy, Field::exx, Field::eyy, Field::exy}) layers.push_back(in_plane_layer(f, all_fields));
    layers.push_back({"u_z", "mm", false, false, all_uz});
    write_overlays(dir, o, fixed, p, pipeline.points(), stems, [&](std::size_t k) { return read_grey(left_files[k]); },
                   layers);
  }
  fmt::print("{}", t.str());
  fmt::print("wrote per frame pair: {0}/frame_NNNN.csv (with u_z_mm, du_z_dx, du_z_dy), {0}/frame_NNNN_dots3d.csv, "
             "{0}/frame_NNNN_dots.csv{1}\n",
             dir.string(), o.no_overlays ? "" : fmt::format(" and {}/frame_NNNN_{{u_x,u_y,e_xx,e_yy,e_xy,u_z}}.png", dir.string()));
}

void run(const RunDctOptions& o) {
  using namespace dtflop::dct;
  const bool stereo = !o.reference2.empty() || !o.frames2.empty() || !o.calibration.empty();
  if (!stereo && o.specimen.empty() == o.reference.empty())
    throw InputError("give either --reference (with --frames) or --specimen, not both and not neither");
  if (!stereo && !o.reference.empty() && o.frames.empty())
    throw InputError("--reference needs --frames 'def_%04d.png' (the deformed images)");
  PipelineOptions p;
  p.interp = interp_from_string(o.interp);
  p.mls.support = parse_support(o.support);
  p.mls.support_at_most_found = !o.support_given;  // the default shrinks to small patterns
  p.mls.weight = weight_from_string(o.weight);
  const Size2 grid = parse_size2(o.points, "--points", 4096);
  if (grid.x < 2 || grid.y < 2) throw InputError("--points needs at least 2x2 points");
  p.points_x = static_cast<int>(grid.x);
  p.points_y = static_cast<int>(grid.y);
  p.threads = checked_threads(o.threads, "--threads");
  p.match.search_radius = o.search_radius;
  p.analysis.min_area = o.min_area;
  p.analysis.max_area = o.max_area;
  if (o.polarity == "dark") p.analysis.polarity = Polarity::dark_dots;
  else if (o.polarity == "light") p.analysis.polarity = Polarity::light_dots;
  else throw InputError(fmt::format("--polarity '{}' is unknown; use dark or light", o.polarity));
  if (o.threshold.rfind("fixed:", 0) == 0) {
    p.analysis.method = ThresholdMethod::fixed;
    try {
      p.analysis.threshold = std::stod(o.threshold.substr(6));
    } catch (const std::exception&) {
      throw InputError(fmt::format("--threshold '{}': write fixed:128 (8-bit scale)", o.threshold));
    }
  } else {
    p.analysis.method = threshold_method_from_string(o.threshold);
  }
  if (!o.roi.empty()) p.analysis.roi = parse_roi(o.roi);
  if (stereo) {
    run_stereo(o, p, grid);
    return;
  }

  // Inputs: files, or a rendered specimen (whose truth is then compared).
  cv::Mat reference;
  std::vector<std::filesystem::path> frame_files;
  std::unique_ptr<Specimen> specimen;
  if (!o.specimen.empty()) {
    specimen = std::make_unique<Specimen>(parse_specimen(o.specimen));
    reference = specimen->reference_image();
  } else {
    frame_files = expand_frames(o.frames);
    reference = read_grey(o.reference);
  }
  const std::filesystem::path dir(o.out);
  {  // Checked now, made with the first output: a run refused on its first frame leaves nothing behind.
    std::error_code ec;
    const auto st = std::filesystem::status(dir, ec);
    if (std::filesystem::exists(st) && !std::filesystem::is_directory(st))
      throw InputError(fmt::format("-o '{}' exists and is not a folder; name a new folder", o.out));
  }
  auto backend = make_backend(o.backend, p);
  backend->set_reference(reference);
  fmt::print("backend {}: {} reference dots, {} points ({}x{}), {} {}, support {}\n", backend->name(),
             backend->reference_dots().size(), backend->points().size(), grid.x, grid.y, to_string(p.interp),
             p.interp == Interp::mls ? to_string(p.mls.weight) : "", p.mls.support.str());

  const FixedRanges fixed = fixed_ranges(o);  // checked before any frame is measured

  Table t({"frame", "dots", "matched", "lost", "appeared", "valid points", "mean e_xx [microstrain]",
           "mean e_yy [microstrain]", "time"});
  const std::size_t n_frames = specimen ? 1 : frame_files.size();
  std::vector<std::vector<FieldValue<double>>> all_fields;  // per frame, for the overlays
  std::vector<std::string> stems;
  for (std::size_t k = 0; k < n_frames; ++k) {
    cv::Mat frame;
    std::string label;
    if (specimen) {
      frame = specimen->deformed_image();
      label = "specimen";
    } else {
      frame = read_grey(frame_files[k]);
      label = frame_files[k].filename().string();
    }
    FrameOutput out;
    int valid = 0;
    double mxx = 0, myy = 0;
    auto measure = [&] {
      try {
        out = backend->process(frame);
      } catch (const InputError& e) {
        throw InputError(fmt::format("frame {}: {}", label, e.what()));
      }
      valid = 0;
      mxx = myy = 0;
      for (const auto& f : out.fields)
        if (f.status == PointStatus::ok) { ++valid; mxx += f.exx; myy += f.eyy; }
      if (valid == 0) throw InputError(fmt::format("frame {}: {}", label, no_valid_point(out.fields, p.mls.support.str())));
    };
    measure();
    const std::string stem = fmt::format("frame_{:04d}", k + 1);
    // Uncertainty from the images' own noise (uncertainty.hpp), the dots table, and one line
    // counting the invalid points by reason.
    FrameUncertainty unc = frame_uncertainty(reference, frame, *backend, out);
    if (!unc.reference_noise.ok() || !unc.frame_noise.ok())
      fmt::print("frame {}: no standard deviations: {}\n", label,
                 unc.reference_noise.ok() ? unc.frame_noise.why_not : "reference: " + unc.reference_noise.why_not);
    else
      fmt::print("frame {}: noise {:.2f} grey levels (reference {:.2f}; from {} dots' background rings)\n", label,
                 unc.frame_noise.sigma, unc.reference_noise.sigma, unc.frame_noise.dots_used);
    if (k == 0 && unc.reference_noise.ok() && unc.frame_noise.ok()) {
      const int suggested = print_support_suggestion(*backend, out, unc, p, grid);
      // No --support given (MLS): the suggestion is the support, for this frame and the rest
      // (docs/dct.md, "Choosing the support"). The first pass at the default is its input.
      const int now = std::min(p.mls.support.dots, static_cast<int>(backend->reference_positions().size()));
      if (!o.support_given && p.interp == Interp::mls && suggested >= 6 && suggested != now) {
        p.mls.support = parse_support(fmt::format("{}dots", suggested));
        backend = make_backend(o.backend, p);
        backend->set_reference(reference);
        measure();
        unc = frame_uncertainty(reference, frame, *backend, out);
        fmt::print("support: no --support given: measuring with the suggested {} (the first pass used {}dots)\n",
                   p.mls.support.str(), now);
      }
    } else if (k == 0 && !o.support_given && p.interp == Interp::mls) {
      fmt::print("support: no noise estimate, so no suggestion: measuring with the default {}\n", p.mls.support.str());
    }
    if (valid < static_cast<int>(out.fields.size())) {
      std::map<std::string, int> why;
      for (const auto& f : out.fields)
        if (f.status != PointStatus::ok) why[to_string(f.status)] += 1;
      std::string list;
      for (const auto& [w, n] : why) list += fmt::format("{}{} {}", list.empty() ? "" : ", ", n, w);
      fmt::print("frame {}: {} of {} points invalid ({})\n", label, out.fields.size() - static_cast<std::size_t>(valid),
                 out.fields.size(), list);
    }
    write_fields_csv(dir / (stem + ".csv"), backend->points(), out.fields, unc.points);
    write_dots_csv(dir / (stem + "_dots.csv"), backend->reference_dots(), out.dots, out.matches, frame,
                   out.stats.threshold, p.analysis.polarity, &unc);
    const int lost = static_cast<int>(backend->reference_dots().size()) - out.matches.matched;
    t.row({label, fmt::format("{}", out.dots.size()), fmt::format("{}", out.matches.matched), fmt::format("{}", lost),
           fmt::format("{}", out.matches.appeared.size()), fmt::format("{} of {}", valid, out.fields.size()),
           fmt::format("{:.1f}", 1e6 * mxx / valid), fmt::format("{:.1f}", 1e6 * myy / valid),
           format_duration(out.seconds["total"])});
    if (lost > 0 || !out.matches.appeared.empty()) fmt::print("frame {}: {}\n", label, out.matches.summary());
    if (specimen) {
      double se = 0, su = 0;
      int n = 0;
      for (std::size_t m = 0; m < out.fields.size(); ++m) {
        const auto& f = out.fields[m];
        if (f.status != PointStatus::ok) continue;
        const Vec2 P = backend->points()[m];
        const Vec2 u = specimen->deformation->displacement(P);
        const Strain e = specimen->deformation->strain(P);
        su += std::pow(f.ux - u.x, 2) + std::pow(f.uy - u.y, 2);
        se += std::pow(f.exx - e.xx, 2) + std::pow(f.eyy - e.yy, 2) + std::pow(f.exy - e.xy, 2);
        ++n;
      }
      if (n)
        fmt::print("against the closed form ({}): displacement RMS error {:.4f} px, strain RMS error {:.1f} "
                   "microstrain over {} valid points\n",
                   specimen->deformation->describe(), std::sqrt(su / (2 * n)), 1e6 * std::sqrt(se / (3 * n)), n);
    }
    if (!o.no_overlays) {
      all_fields.push_back(std::move(out.fields));
      stems.push_back(stem);
    }
  }
  // Overlays: one colour range per field across the whole sequence (so frames compare), unless
  // --per-frame-range or a fixed range says otherwise.
  if (!o.no_overlays) {
    std::vector<OverlayLayer> layers;
    for (Field f : {Field::ux, Field::uy, Field::exx, Field::eyy, Field::exy}) layers.push_back(in_plane_layer(f, all_fields));
    write_overlays(dir, o, fixed, p, backend->points(), stems,
                   [&](std::size_t k) { return specimen ? specimen->deformed_image() : read_grey(frame_files[k]); }, layers);
  }
  fmt::print("{}", t.str());
  fmt::print("wrote per frame: {0}/frame_NNNN.csv, {0}/frame_NNNN_dots.csv{1}\n", dir.string(),
             o.no_overlays ? "" : fmt::format(" and {}/frame_NNNN_{{u_x,u_y,e_xx,e_yy,e_xy}}.png", dir.string()));
}

}  // namespace

void add_fields_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "fields",
      "Dot centroid tracking (the DCT workload on images): displacement and strain fields from a reference image and deformed frames "
      "(or a rendered --specimen), by MLS (eqs. 7.2-7.6) or linear FE; with a second camera's images (--reference2, "
      "--frames2) and the pair's --calibration also the out-of-plane displacement u_z");
  auto o = std::make_shared<RunDctOptions>();
  app->add_option("--backend", o->backend, "DCT backend: " + workload::find("dct").backend_names())->capture_default_str();
  app->add_option("--reference", o->reference, "Reference (undeformed) image");
  app->add_option("--frames", o->frames, "Deformed frames: a file or a printf pattern, e.g. 'def_%04d.png'");
  app->add_option("--specimen", o->specimen, "Render a specimen instead (see `dtflop specimen --help`) and compare with its truth");
  app->add_option("--support", o->support,
                  "MLS support domain (and FE's gradient recovery): dots per support (60dots) or radius (12.5px). "
                  "After the first frame a line suggests the support of least strain error for the measured noise, "
                  "dot density and strain feature; without --support, MLS then measures every frame at that "
                  "suggestion (the first pass uses 200dots, or every dot where fewer were found; FE, or images "
                  "whose noise cannot be estimated, keep 200dots)")
      ->capture_default_str()
      ->each([o](const std::string&) { o->support_given = true; });
  app->add_option("--interp", o->interp,
                  "mls (moving least squares) or fe (linear triangles; strain recovered over the --support)")
      ->capture_default_str();
  app->add_option("--weight", o->weight, "MLS weight: cubic, quartic or gaussian")->capture_default_str();
  app->add_option("--points", o->points, "Interpolation grid over the reference dots, e.g. 64x32")->capture_default_str();
  app->add_option("--threshold", o->threshold, "otsu, adaptive or fixed:128 (8-bit scale)")->capture_default_str();
  app->add_option("--polarity", o->polarity, "dark (dark dots on light ground) or light")->capture_default_str();
  app->add_option("--roi", o->roi, "Region of interest x,y,width,height (px)");
  app->add_option("--min-area", o->min_area, "Smallest dot, px (the seed's Area2)")->capture_default_str()->check(number_in(1, 100000000, true));
  app->add_option("--max-area", o->max_area, "Largest dot, px (the seed's Area1)")->capture_default_str()->check(number_in(1, 100000000, true));
  app->add_option("--search-radius", o->search_radius, "Matching radius, px (0: 0.4 x dot spacing)")->capture_default_str()->check(number_in(0, 16384));
  app->add_option("--threads", o->threads, "CPU threads of a parallel backend (0: all; at most this machine's)")->capture_default_str()->check(number_in(0, 1 << 20, true));
  app->add_option("-o,--out", o->out, "Output folder")->required();
  app->add_flag("--no-overlays", o->no_overlays, "Write only the CSV files");
  app->add_flag("--per-frame-range", o->per_frame_range,
                "Give each frame's overlay its own colour range (default: one range per field across the sequence)");
  app->add_option("--strain-range", o->strain_range, "Fixed colour range of the strain overlays, LO:HI microstrain");
  app->add_option("--displacement-range", o->displacement_range,
                  "Fixed colour range of the displacement overlays, LO:HI px");
  app->add_option("--reference2", o->reference2,
                  "Stereo: the second (right) camera's reference image; with --frames2 and --calibration, u_z and its "
                  "gradient join the fields (the in-plane fields are the left camera's, --reference's)");
  app->add_option("--frames2", o->frames2,
                  "Stereo: the right camera's deformed frames (a file or a printf pattern), one per --frames image");
  auto* calibration = app->add_option("--calibration", o->calibration,
                                      "Stereo: the pair's calibration (dtflop live stereo-calibrate writes it), of the "
                                      "images' size");
  app->add_option("--epipolar-tolerance", o->epipolar_tolerance,
                  "Stereo: px a dot's partner may lie off its rectified row")
      ->capture_default_str()
      ->check(number_in(0.01, 100))
      ->needs(calibration);
  app->callback([o] { run(*o); });
}

}  // namespace dtflop::cli
