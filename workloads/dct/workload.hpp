// The DCT workload behind the workload contract (workloads/workload.hpp): its parameter space,
// its backends (the list of backend.hpp, declared once), its plans and protocol defaults.
//
// A configuration is a synthetic specimen and a pipeline: a WxH image (8- or 16-bit) holding
// `dots` random dots of `radius` px (edge-to-edge gap >= radius, from `seed`), a reference
// frame and one deformed frame (uniform strain kStrain, Poisson 0.3: at most ~0.6 px of
// motion at 24 MP), an Otsu threshold, and `points` (a grid NXxNY over the reference dots)
// evaluated by MLS with `support` dots per support domain, or by FE.
//
// Counts before a frame: Backend::counts(config) estimates one frame from the image size and
// the expected dots, points and support (estimate_shape: the dots, points and support entries
// are exact, the pixel classes are estimated from the dot radius). A prepared Run renders the
// specimen, sets the reference, and declares the exact counts of a repetition before its first
// frame: dots, points and support entries from the reference the backend analysed, the pixel
// classes (components, foreground, window, ring and weighted pixels) from a float64 analysis
// of the rendered deformed frame (analyze(), outside the timed frames). After each repetition
// check() compares what the frame reported (FrameOutput.shape, .counts) with the declaration.
#pragma once

#include <cstdint>
#include <string>

#include "workloads/dct/backend.hpp"
#include "workloads/dct/counts.hpp"
#include "workloads/dct/specimen.hpp"
#include "workloads/workload.hpp"

namespace dtflop::dct {

const ::dtflop::workload::Workload& workload();

// The deformation every configuration's deformed frame carries: uniform strain e_xx (e_yy =
// -0.3 e_xx) about the image centre.
inline constexpr double kStrain = 2e-4;

// What a validated configuration means, for the Run, the tests and the CLI.
PipelineOptions pipeline_options(const ::dtflop::workload::Config& c, const std::string& backend);
// The reference and deformed frames of `c` (the dots from its seed). Throws InputError when the
// dots cannot be placed.
Specimen specimen_of(const ::dtflop::workload::Config& c);
// One frame's shape estimated from `c` alone (no image): what Backend::counts() prices.
FrameShape estimated_shape(const ::dtflop::workload::Config& c);
// Bytes of host memory a run of `c` holds at its peak (rendering, frames, mask and labels):
// checked against the machine's memory before anything is allocated.
std::int64_t host_bytes(const ::dtflop::workload::Config& c, const std::string& backend);

// The shape of one frame that `pipeline` (with its reference set) will report for `frame`,
// from a float64 analysis of the frame on the host: what a Run declares before its first frame.
FrameShape declared_shape(const Backend& pipeline, const cv::Mat& frame);
// Where two shapes or count sets differ, one line ("" when they agree).
std::string shape_difference(const FrameShape& declared, const FrameShape& measured);
std::string counts_difference(const CostCounts& declared, const CostCounts& measured);

}  // namespace dtflop::dct
