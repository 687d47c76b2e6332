// DCT accuracy: what the dots of a configuration deliver, measured on the workload's own
// specimen of that configuration (its size, dots, radius, bits and seed; a grey level of sensor
// noise; uniform strain with a closed form, workloads/dct/workload.hpp), by the workload's CPU
// pipeline with the configuration's support (dots or radius), points, interpolation, weight
// function and threshold. The error-against-
// density table the tuner judges by is this measurement, made for each configuration of the
// space (cached by everything it depends on), not a constant. A configuration is accurate
// enough when
//   strain-error:   the RMS error of its worst strain component over its valid points is at most
//                   `max-strain-rms` microstrain;
//   valid-points:   at least `min-valid-points` of its points are valid (an ill-conditioned MLS
//                   moment matrix, a support short of dots or a point outside the triangulation
//                   make a point invalid).
// The figure of merit is that RMS strain error in microstrain. The GPU backend computes the same
// fields (its tests hold it to the CPU's within float32 rounding), so one measurement serves
// every backend.
#include <cmath>
#include <map>
#include <set>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "tune/accuracy.hpp"
#include "workloads/dct/backend.hpp"
#include "workloads/dct/workload.hpp"

namespace dtflop::tune {

namespace {

class DctAccuracy final : public AccuracyModel {
 public:
  explicit DctAccuracy(const nlohmann::json& j) {
    for (const auto& [k, v] : j.items()) {
      if (k == "max-strain-rms") {
        if (!v.is_number() || !(v.get<double>() > 0 && v.get<double>() <= 1e6))
          accuracy_field_error(k, fmt::format("{} is not a strain in microstrain in (0, 1e6]", v.dump()));
        max_rms_ = v.get<double>();
      } else if (k == "min-valid-points") {
        if (!v.is_number() || !(v.get<double>() > 0 && v.get<double>() <= 1))
          accuracy_field_error(k, fmt::format("{} is not a share in (0, 1]", v.dump()));
        min_valid_ = v.get<double>();
      } else {
        accuracy_field_error(k, "unknown field (expected max-strain-rms, min-valid-points)");
      }
    }
  }
  std::string error_name() const override { return "strain RMS error"; }
  std::string error_unit() const override { return "microstrain"; }
  nlohmann::json needs() const override {
    return {{"max_strain_rms_microstrain", max_rms_ ? nlohmann::json(*max_rms_) : nlohmann::json(nullptr)},
            {"min_valid_points", min_valid_}};
  }
  AccuracyJudgement judge(const workload::Backend&, const workload::Config& c) override {
    // What the fields depend on: everything but how the work is spread (threads, host memory,
    // the cuda block layout). The weight, the threshold and the support (dots or radius) change
    // the fields, and so the measured error.
    nlohmann::json key = c;
    for (const char* spread : {"threads", "host-memory", "block-pixels", "block-points", "block-dots"})
      key.erase(spread);
    const std::string k = key.dump();
    auto it = cache_.find(k);
    if (it == cache_.end()) it = cache_.emplace(k, measure(c)).first;
    const Measured& m = it->second;
    AccuracyJudgement a;
    a.error = m.rms;
    a.figures = {{"strain_rms_microstrain", {m.exx, m.eyy, m.exy}},
                 {"displacement_rms_px", m.u},
                 {"valid_points", m.valid},
                 {"points", m.points}};
    const double share = m.points ? static_cast<double>(m.valid) / static_cast<double>(m.points) : 0;
    if (share < min_valid_) {
      a.ok = false;
      a.constraint = "valid-points";
      a.reason = fmt::format("{} of {} points valid ({:.1f}%), under {:.1f}%", m.valid, m.points, 100 * share,
                             100 * min_valid_);
    } else if (max_rms_ && m.rms > *max_rms_) {
      a.ok = false;
      a.constraint = "strain-error";
      a.reason = fmt::format("strain RMS error {:.1f} microstrain over {} valid points, above {}", m.rms, m.valid,
                             *max_rms_);
    }
    return a;
  }

 private:
  struct Measured {
    double exx = 0, eyy = 0, exy = 0, rms = 0, u = 0;
    std::int64_t valid = 0, points = 0;
  };
  Measured measure(const workload::Config& c) const {
    const dct::Specimen s = dct::specimen_of(c);
    dct::PipelineOptions o = dct::pipeline_options(c, "cpu-seq");  // the fields do not depend on the backend
    o.threads = 0;
    auto b = dct::make_backend("cpu-par", o);
    b->set_reference(s.reference_image());
    const dct::FrameOutput out = b->process(s.deformed_image());
    Measured m;
    m.points = static_cast<std::int64_t>(out.fields.size());
    double sxx = 0, syy = 0, sxy = 0, su = 0;
    for (std::size_t i = 0; i < out.fields.size(); ++i) {
      const auto& f = out.fields[i];
      if (f.status != dct::PointStatus::ok) continue;
      const dct::Vec2 p = b->points()[i];
      const dct::Strain e = s.deformation->strain(p);
      const dct::Vec2 u = s.deformation->displacement(p);
      sxx += std::pow(f.exx - e.xx, 2);
      syy += std::pow(f.eyy - e.yy, 2);
      sxy += std::pow(f.exy - e.xy, 2);
      su += std::pow(f.ux - u.x, 2) + std::pow(f.uy - u.y, 2);
      ++m.valid;
    }
    if (m.valid > 0) {
      const double n = static_cast<double>(m.valid);
      m.exx = 1e6 * std::sqrt(sxx / n);
      m.eyy = 1e6 * std::sqrt(syy / n);
      m.exy = 1e6 * std::sqrt(sxy / n);
      m.rms = std::max({m.exx, m.eyy, m.exy});
      m.u = std::sqrt(su / (2 * n));
    } else {
      m.rms = INFINITY;
    }
    return m;
  }

  std::optional<double> max_rms_;
  double min_valid_ = 0.99;
  std::map<std::string, Measured> cache_;
};

}  // namespace

std::unique_ptr<AccuracyModel> make_dct_accuracy(const nlohmann::json& needs) {
  return std::make_unique<DctAccuracy>(needs);
}

}  // namespace dtflop::tune
