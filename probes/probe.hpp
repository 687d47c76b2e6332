// The probe framework: a probe is a small unit that measures part of the machine and reports
// measurements (value, unit, spread of the repetitions, and the model parameter it fills).
//
// Adding a probe is adding a file: probes/probe_<name>.cpp holding
//     DTFLOP_PROBE_UNIT(probe_<name>) { registry.add({...}); }
// probes/CMakeLists.txt finds every probe_*.cpp and generates the index that calls these
// functions, so no list has to be edited (and no registration is lost to the linker).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "model/profile.hpp"
#include "model/stats.hpp"

namespace dtflop::probes {

// How long the probes may take. `full` is what `dtflop probe` runs (a minute or two on a GPU
// machine); `quick` is `dtflop probe --quick` (under 30 s on a 2-core CPU machine); `smoke`
// only checks that everything runs and validates (tests, sanitizer builds).
enum class Effort { smoke, quick, full };
const char* to_string(Effort e);

// Progress lines for runs longer than a few seconds; the CLI sends them to stderr.
using ProgressFn = std::function<void(const std::string& line)>;

struct ProbeOptions {
  Effort effort = Effort::full;
  ProgressFn progress;  // may be empty
  void say(const std::string& line) const {
    if (progress) progress(line);
  }
};

// One measured figure.
struct Measurement {
  std::string key;    // stable identifier, unique within the probe, e.g. "h2d_pinned_16MiB"
  std::string label;  // for people, e.g. "host->device, pinned, 16 MiB"
  std::string unit;   // "B/s", "FLOP/s", "s" or another unit ("x" for ratios)
  double value = 0;
  // Statistics of the repetitions behind the value, in the unit the repetitions were timed
  // in (seconds). Empty (n = 0) for derived figures such as a fit or a ratio.
  Stats stats;
  std::optional<Param> param;          // the model parameter this value is, if any
  std::optional<double> uncertainty;   // 95% half-width, in `unit`, when known (fits)
  std::string note;                    // how it was obtained
  // One point of a sweep (e.g. one transfer size): shown only when details are asked for.
  bool detail = false;
  // A cost ratio against a rate this probe measured again beside its loop (K_CW: the FMA rate of
  // one thread): the profile rebases it on that rate's own parameter, value x (the profile's rate /
  // `reference`), so that a prediction prices the loop at the rate the loop ran at, whatever the
  // two runs of the reference gave on a machine whose speed drifts (make_profile()).
  std::optional<Param> reference_param;
  double reference = 0;  // the rate the ratio was taken against, in its parameter's unit
};

struct ProbeReport {
  std::string probe;
  std::vector<Measurement> measurements;
  // Set when the probe could not run here (no GPU, built without CUDA); the report then
  // holds no measurements, and its parameters stay absent from the profile.
  std::optional<std::string> skipped;
  // Set when the probe failed (a CUDA error, a result that did not validate); its
  // measurements are dropped, since none of them can be trusted.
  std::optional<std::string> error;
  double seconds = 0;  // wall time the probe took
  // Entries for the profile's metadata, keyed without the "probe." prefix make_profile() adds
  // (e.g. "cpu_llc_ladder"): what a probe saw beyond its measurements.
  std::map<std::string, std::string> metadata;
};

struct Probe {
  std::string name;         // e.g. "cpu-memory"
  std::string description;  // one line
  // The runner (probes/machine.cpp) skips a probe that needs a GPU where none is usable, saying
  // why once, so its run() is called only with a usable device.
  bool needs_gpu = false;
  int order = 0;            // probes run in ascending order
  std::function<ProbeReport(const ProbeOptions&)> run;
};

// A probe found its result wrong (copied data differ, an FMA chain ended on the wrong value):
// its figures must not be used. The message says what differed.
class ValidationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Registry {
 public:
  // Throws std::logic_error on a duplicate name.
  void add(Probe p);
  const std::vector<Probe>& probes() const { return probes_; }

 private:
  std::vector<Probe> probes_;
};

// Every probe of this build, sorted by `order`.
const std::vector<Probe>& all_probes();

}  // namespace dtflop::probes

// Defines the registration function of one probe file; `name` is the file's stem, e.g.
//     DTFLOP_PROBE_UNIT(probe_cpu_fma) { registry.add({...}); }
#define DTFLOP_PROBE_UNIT(name)                                                  \
  namespace dtflop::probes::index {                                              \
  void name(::dtflop::probes::Registry& registry);                               \
  }                                                                              \
  void dtflop::probes::index::name([[maybe_unused]] ::dtflop::probes::Registry& registry)
