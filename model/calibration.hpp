// What a backend makes of a machine, kept apart from what the machine is.
//
// A probe profile says what a machine is: its bandwidths, rates and latencies as the probes
// measured them. A calibration says how well one backend of one workload uses a machine of a
// class: each fitted parameter as a factor of the probed value it corresponds to (the achieved
// share of a bandwidth or rate, what an event costs against the probe's figure of it) or, for
// a parameter no probe measures (K_CW, K_GR, ...), as the value itself. A calibration fitted on
// machine A applied to machine B's probe profile gives B's parameters for that backend: this is
// how dtflop predicts a machine the workload never ran on (docs/portability.md).
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "model/predict.hpp"
#include "model/profile.hpp"

namespace dtflop {

inline constexpr const char* kCalibrationSchemaName = "dtflop.calibration";
inline constexpr int kCalibrationSchemaVersion = 1;

// One fitted parameter of a backend.
struct CalibrationFactor {
  Param id{};
  // relative: the parameter is `factor` times the target machine's probed value of it (the
  // source machine's probe gave `source_probed`); absolute: no probe measures it, `value` is
  // carried as it is.
  bool relative = false;
  double factor = 1;           // relative only
  double value = 0;            // the value fitted on the source machine (both kinds)
  std::optional<double> source_probed;  // relative only
  double log_sigma = 0;        // standard deviation of log(value) from the fit; 0 unknown
  bool fitted = true;          // false: not identifiable from the samples, kept at the probe
};

// How well a provenance predicted, measured on runs it was not fitted to.
struct ErrorFigure {
  int samples = 0;
  double mean_rel = 0;  // mean |predicted - measured| / measured
  double max_rel = 0;
  double rms_log = 0;   // root mean square of log(predicted / measured)
  std::string how;      // e.g. "5-fold cross-validation of 106 samples"
  // The machine's own drift, where the figure is a fit's own error: the standard deviation of log(one
  // round's time) about its configuration's mean, pooled over the fit's configurations of two or
  // more rounds (rounds run minutes apart; calib::MergedRounds::round_log_sd). Cross-validation
  // scores folds of one sweep, measured in the same minutes, and cannot see it; a run measured
  // later does. 0: unknown or one round (a transfer's measured error already holds it).
  double round_log_sd = 0;
  int round_configs = 0;  // the configurations it was pooled over
  // The interval's sigma: rms_log and round_log_sd in quadrature.
  double sigma() const;
};

struct Calibration {
  std::string workload;                 // e.g. "rbe"
  std::string backend;                  // e.g. "cuda-seed"
  std::vector<std::string> match;       // key filters the samples were selected by (host-memory=pinned)
  Variant variant = Variant::extended;  // the model variant the fit chose
  MachineIdentity fitted_on;            // the source machine
  std::vector<CalibrationFactor> factors;
  ErrorFigure fit_error;                // cross-validated on the source machine
  // Measured when this calibration was carried to another machine and validated there (dtflop
  // validate --calibration ... --record); absent until then.
  std::optional<ErrorFigure> transfer_error;
  std::string transfer_measured_on;     // describe() of the machine it was measured on
  std::map<std::string, std::string> metadata;

  const CalibrationFactor* find(Param p) const;
};

// The class of hardware a calibration carries to: the GPU for a backend that uses one, else the
// CPU model (normalized as same_machine() compares them).
std::string hardware_class(const MachineIdentity& id, bool gpu);
// Does the calibration's backend use a GPU (any factor of a device parameter)?
bool uses_gpu(const Calibration& c);

// Where a prediction's parameters came from.
enum class Basis {
  probe_only,   // the target machine's probes alone: no run of the workload anywhere
  calibrated,   // a calibration fitted on this very machine and probe (or a fitted profile of it)
  transferred,  // a calibration fitted on another machine, or against another probe of this kind of
                // machine (another lend, another day), applied to this one's probes
};
std::string_view to_string(Basis b);

struct Applied {
  MachineProfile profile;           // the target's probe profile with the backend's parameters set
  Basis basis = Basis::calibrated;
  std::vector<std::string> notes;   // one line each: what was carried as it is, and why
};
// Applies `c` to `target`, a probe profile (dtflop probe). The basis is `calibrated` only where the
// calibration was fitted against this very probe (same machine, same measured_at; a calibration that
// records no probe time, against any probe of the same machine): the factors of one probe applied to
// another carry the two probes' noise and whatever changed between them (on two lends of one H200 an
// hour apart, a cuda-seed calibration carried from one to the other was 11.6% off where each lend's
// own was within 3.3-5.1%: docs/PERFORMANCE.md), so such a prediction is a transferred one and gets
// a transferred one's interval. Throws InputError when the target is
// itself a fitted profile (contradictory provenance: give its probe profile) or lacks the GPU a
// GPU backend's calibration needs.
Applied apply_calibration(const Calibration& c, const MachineProfile& target);

nlohmann::json to_json(const Calibration& c);
// Validates every field; throws InputError naming the field and what was expected.
Calibration calibration_from_json(const nlohmann::json& j);
Calibration load_calibration(const std::filesystem::path& path);
void save_calibration(const Calibration& c, const std::filesystem::path& path);

nlohmann::json to_json(const ErrorFigure& e);
ErrorFigure error_figure_from_json(const nlohmann::json& j, const std::string& field);

}  // namespace dtflop
