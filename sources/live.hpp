// Live DCT measurement (library dtflop_live): a YAML run configuration, and the loop that takes
// frames from a FrameSource as they come, measures each with a DCT backend, writes its fields
// as CSV at once, and keeps the per-frame latency, the stage times and the source's losses.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "sources/frame_source.hpp"
#include "workloads/dct/backend.hpp"
#include "workloads/dct/stereo_dots.hpp"

namespace dtflop::live {

// What the dissertation's GUI tabs held, as a YAML file (docs/sources.md lists the keys):
//   source: "file:clip.mp4?paced=1"   # frame_source.hpp's forms
//   reference: first | PATH            # the first frame (default) or an image file
//   roi: [x, y, width, height]
//   threshold: otsu | fixed:128 | ...  # analysis.hpp's methods
//   polarity: dark | light
//   area: [min, max]                   # accepted dot areas, px
//   backend: cpu-par                   # a DCT backend
//   interpolation: mls | fe
//   weight: cubic
//   support: 200dots | 60px
//   points: 32x32
//   threads: 0
//   search_radius: 0
//   output: folder                     # fields CSV per frame, summary.json
//   max_frames: 0                      # 0: until the stream ends
//   overlay_every: 0                   # colour-mapped PNGs of every field every N frames (0: none)
//   source2: "file:right.mp4"          # stereo: the right camera (with calibration)
//   calibration: rig.yaml              # stereo: the pair's calibration (dtflop live stereo-calibrate)
//   pair: sequence | timestamp         # stereo: how frames of the two sources are paired
//   pair_tolerance_ms: 5               # stereo, pair: timestamp: the most two paired frames differ
//   epipolar_tolerance: 1.5            # stereo: px a partner may lie off its epipolar row
//   tuned: tuned.json                  # DCT parameters from `dtflop tune -o` (keys given here win)
struct LiveConfig {
  std::string source;
  std::string source2;       // stereo: the second (right) camera
  std::string calibration;   // stereo: the pair's calibration file
  bool pair_by_timestamp = false;
  double pair_tolerance_s = 0.005;
  double epipolar_tolerance = 1.5;
  std::string tuned;         // a `dtflop tune -o` result (applied by the command, apply_tuned)
  std::set<std::string> given;  // the keys the file held
  std::string reference = "first";
  dct::PipelineOptions pipeline;
  std::string backend = "cpu-par";
  std::string support_text = "200dots";
  bool support_given = false;
  std::string output;
  std::int64_t max_frames = 0;
  std::int64_t overlay_every = 0;
};

// Reads and validates `path`. Throws InputError naming the file and the field that is wrong
// (unknown keys included) and what to write instead.
LiveConfig load_live_config(const std::filesystem::path& path);
// The same from YAML text; `name` names it in messages.
LiveConfig parse_live_config(const std::string& yaml, const std::string& name);

struct FrameRecord {
  std::uint64_t sequence = 0;
  double timestamp_s = 0;
  double latency_s = 0;   // from the frame's arrival to its fields written
  double process_s = 0;   // the backend's time on the frame
  double write_s = 0;     // writing its CSV (and overlays, on the frames that have them)
  int dots = 0, matched = 0, valid_points = 0;
  double mean_exx = 0, mean_eyy = 0;  // over valid points (strain)
  int triangulated = -1;              // stereo: dots with a 3D position (-1: one camera)
  double mean_uz = 0;                 // stereo: over valid points, mm
};

struct LiveReport {
  std::vector<FrameRecord> frames;
  std::map<std::string, std::vector<double>> stage_seconds;  // the backend's stages, per frame
  std::vector<double> wait_seconds;  // time spent waiting for each frame
  sources::SourceStats source;
  double wall_s = 0;            // from the first measured frame's arrival to the last one's end
  std::string stopped_because;  // empty: the stream ended (or max_frames); else why it stopped
  int reference_dots = 0;
  // The reference frame's sequence number (the first source's), when it came from the stream.
  std::optional<std::uint64_t> reference_sequence;
  // Stereo: the second source's counts, frames left unpaired (each source's), the reference match.
  sources::SourceStats source2;
  std::uint64_t unpaired_first = 0, unpaired_second = 0;
  std::string stereo_reference;  // the reference matching's summary
};

// Replaces the DCT parameters of `config` by `tuned` (the options of a `dtflop tune -o` result,
// for backend `backend`), except those the configuration file named itself and those that
// describe the images rather than the computation (roi, polarity, area).
void apply_tuned(LiveConfig& config, const std::string& backend, const dct::PipelineOptions& tuned);

// p-th percentile (0..100) by linear interpolation between order statistics; NaN when empty.
double percentile(std::vector<double> v, double p);

// Runs `config` on `source`: the reference is the first frame (or the configured file), then
// every further frame is measured and its fields written to `config.output`/frame_NNNNNN.csv.
// `on_frame` (optional) sees each frame's record, output and image as it is measured. A bad frame, a
// frame without valid points or a source that stops ends the run with `stopped_because` set;
// what was measured before is kept (its CSVs written, its records returned). Throws InputError
// only before the first frame is measured (no reference, a reference without dots).
LiveReport run_live(const LiveConfig& config, sources::FrameSource& source, dct::Backend& backend,
                    const std::function<void(const FrameRecord&, const dct::FrameOutput&, const cv::Mat&)>& on_frame = {});

// Stereo: frames of `left` and `right` paired (by sequence number or by timestamp, each counted
// from the source's first frame; a frame without a partner is dropped and counted), the first
// pair the reference, each further pair measured by `pipeline`: frame_NNNNNN.csv holds the
// fields with u_z and its gradient, frame_NNNNNN_dots3d.csv the stereo dots table. `on_frame`
// sees the left camera's output and image.
LiveReport run_live_stereo(const LiveConfig& config, sources::FrameSource& left, sources::FrameSource& right,
                           dct::stereo::StereoPipeline& pipeline,
                           const std::function<void(const FrameRecord&, const dct::FrameOutput&, const cv::Mat&)>& on_frame = {});

}  // namespace dtflop::live
