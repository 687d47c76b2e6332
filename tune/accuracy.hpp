// What a configuration gives the application, besides its time: each workload's accuracy model
// reads the scenario's `accuracy:` block (what the application needs), discards the
// configurations that cannot deliver it (each with its reason), and gives the others one figure
// of merit (smaller is better) for the Pareto front of time against accuracy.
//
// Adding a workload's accuracy model is one file (accuracy_<workload>.cpp) and one line in
// accuracy.cpp's list.
#pragma once

#include <memory>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "workloads/workload.hpp"

namespace dtflop::tune {

struct AccuracyJudgement {
  bool ok = true;
  std::string constraint;  // short name of the constraint that discarded it ("kernel-mass")
  std::string reason;      // one line: the figure against the need
  double error = 0;        // the figure of merit (smaller is better), in error_unit()
  nlohmann::json figures = nlohmann::json::object();  // every figure computed, for reports
};

class AccuracyModel {
 public:
  virtual ~AccuracyModel() = default;
  // What the figure of merit is ("cell size", "strain RMS error") and its unit ("m", "microstrain").
  virtual std::string error_name() const = 0;
  virtual std::string error_unit() const = 0;
  // Judges one validated configuration. May measure (DCT renders a specimen and runs the
  // workload's CPU pipeline on it); judgements are cached by what they depend on.
  virtual AccuracyJudgement judge(const workload::Backend& backend, const workload::Config& config) = 0;
  // The needs as read, with defaults filled (for the report).
  virtual nlohmann::json needs() const = 0;
};

// The accuracy model of `workload` for the scenario's `accuracy:` block. Throws InputError naming
// the field for a bad block, and for a block given to a workload without a model. An empty block
// (a scenario that needs no accuracy) gets a model that accepts everything (error 0).
std::unique_ptr<AccuracyModel> make_accuracy_model(std::string_view workload, const nlohmann::json& needs);

// Throws the InputError of a bad field of the scenario's `accuracy:` block ("scenario:
// accuracy.FIELD: WHAT"), for the workloads' models.
[[noreturn]] void accuracy_field_error(const std::string& field, const std::string& what);

// ---- Workloads' models (one factory each) ----------------------------------------------------
std::unique_ptr<AccuracyModel> make_rbe_accuracy(const nlohmann::json& needs);
std::unique_ptr<AccuracyModel> make_dct_accuracy(const nlohmann::json& needs);

// The share of the target's one-step displacement that a centred kernel of `ix` x `iy` cells of
// `cell_x` x `cell_y` (any length unit) holds, for a displacement dt * v * (cos h, sin h) with
// speed v ~ N(v_mean, v_sd) and heading h ~ N(h_mean, h_sd) (eq. 5.23): a cell offset k covers
// displacements within half a cell of k * cell, and the kernel holds offsets -(I-1)/2 ..
// I-1-(I-1)/2 (workloads/rbe/motion.hpp). Deterministic quadrature (600 x 1200 nodes), accurate to
// ~1e-4.
double kernel_mass(std::int64_t ix, std::int64_t iy, double cell_x, double cell_y, double dt, double v_mean,
                   double v_sd, double h_mean, double h_sd);

// The same for independent x and y velocities vx ~ N(vx_mean, vx_sd), vy ~ N(vy_mean, vy_sd): the
// product of two 1D normal probabilities (closed form).
double kernel_mass_cartesian(std::int64_t ix, std::int64_t iy, double cell_x, double cell_y, double dt,
                             double vx_mean, double vx_sd, double vy_mean, double vy_sd);

}  // namespace dtflop::tune
