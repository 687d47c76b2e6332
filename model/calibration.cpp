#include "model/calibration.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/json_io.hpp"

namespace dtflop {

using nlohmann::json;

const CalibrationFactor* Calibration::find(Param p) const {
  for (const auto& f : factors)
    if (f.id == p) return &f;
  return nullptr;
}

std::string hardware_class(const MachineIdentity& id, bool gpu) {
  if (gpu) return id.gpu_name.empty() ? std::string("no GPU") : id.gpu_name;
  return fmt::format("{} ({} threads)", id.cpu_model.empty() ? "unknown CPU" : id.cpu_model, id.cpu_threads);
}

bool uses_gpu(const Calibration& c) {
  for (const auto& f : c.factors)
    if (device_param(f.id)) return true;
  return false;
}

std::string_view to_string(Basis b) {
  switch (b) {
    case Basis::probe_only: return "probe-only";
    case Basis::calibrated: return "calibrated";
    case Basis::transferred: return "transferred";
  }
  return "?";
}

Applied apply_calibration(const Calibration& c, const MachineProfile& target) {
  for (const auto& [p, v] : target.params())
    if (v.provenance == Provenance::fitted)
      throw InputError(fmt::format(
          "the target profile holds fitted parameters ({} and maybe more): a calibration is applied to a probe "
          "profile; give the target machine's `dtflop probe` profile instead of a fitted one",
          info(p).name));
  const bool gpu = uses_gpu(c);
  if (gpu && target.identity.gpu_name.empty())
    throw InputError(fmt::format("the calibration is of {}'s GPU backend {} but the target profile has no GPU; "
                                 "probe a machine with a GPU, or use a CPU backend's calibration",
                                 c.workload, c.backend));
  Applied out;
  out.profile = target;
  const bool same_probe = c.fitted_on.measured_at.empty() || c.fitted_on.measured_at == target.identity.measured_at;
  const bool here = same_machine(c.fitted_on, target.identity);
  out.basis = here && same_probe ? Basis::calibrated : Basis::transferred;
  const std::string from = hardware_class(c.fitted_on, gpu);
  if (here && !same_probe)
    out.notes.push_back(fmt::format(
        "the calibration was fitted against another probe of this kind of machine ({}, this one {}): predicted as "
        "carried, with a carried calibration's interval; for a calibrated prediction fit it here (`dtflop calibrate "
        "--machine` this probe)",
        c.fitted_on.measured_at, target.identity.measured_at.empty() ? "undated" : target.identity.measured_at));
  for (const auto& f : c.factors) {
    Parameter par;
    par.provenance = Provenance::fitted;
    if (f.log_sigma > 0) par.uncertainty = f.value * (std::exp(1.959963984540054 * f.log_sigma) - 1);
    const Parameter* probed = target.find(f.id);
    if (f.relative && probed) {
      par.value = f.factor * probed->value;
      if (par.uncertainty) par.uncertainty = *par.uncertainty / f.value * par.value;
      par.note = fmt::format("{} {} calibration (fitted on {}): {:.4g} x the probed value", c.workload, c.backend,
                             from, f.factor);
    } else {
      par.value = f.value;
      par.note = fmt::format("{} {} calibration: the value fitted on {}", c.workload, c.backend, from);
      if (f.relative)
        out.notes.push_back(fmt::format("the target profile has no probe of {}: carried the value fitted on {} "
                                        "as it is; probe it (`dtflop probe`) to scale it to this machine",
                                        info(f.id).name, from));
      else if (out.basis == Basis::transferred)
        out.notes.push_back(fmt::format("{} has no probe: carried the value fitted on {} ({:.4g} {}) as it is",
                                        info(f.id).name, from, f.value, info(f.id).unit));
    }
    out.profile.set(f.id, par);
  }
  // The figures of code whose probes came after calibrations were first made (cpu-mls, gpu-mls,
  // gpu-centroid, cpu-pixel's kinds of step apart, cpu-records, gpu-frame-pass): a fit that had none of them priced that
  // code as other FLOPs, bytes or steps (or not at all) and fitted the rest around it, so a calibration without one
  // is applied without the target's probe of it, priced as it was fitted. (A fit made since finds
  // each one its backend's counts exercise, and carries it as a factor.)
  const auto carries = [&c](Param p) {
    return std::any_of(c.factors.begin(), c.factors.end(), [p](const CalibrationFactor& f) { return f.id == p; });
  };
  for (Param p : {Param::V_CM, Param::V_CM_all, Param::V_GM, Param::L_GP, Param::L_label, Param::L_label_all,
                  Param::L_hist, Param::L_hist_all, Param::L_scan, Param::L_scan_all, Param::L_record, Param::L_GF})
    if (!carries(p)) out.profile.erase(p);
  // A frame's fixed cost on many threads (L_pass_all) is another matter: a fit exercises it only where
  // its machine's probe found one, and cpu-pixel finds none where it is under a tenth of a small
  // frame's pass (the 2-vCPU VM). A calibration that carries the all-thread pixel steps was fitted
  // with that probe, so the source machine had no fixed cost worth a parameter, and the target's, where
  // its probe found one, is the target's: kept. Only a calibration from before the kinds drops it.
  if (!carries(Param::L_pass_all) && !(carries(Param::L_label_all) && carries(Param::L_hist_all) &&
                                       carries(Param::L_scan_all)))
    out.profile.erase(Param::L_pass_all);
  out.profile.metadata[kChosenVariantKey] = std::string(to_string(c.variant));
  out.profile.metadata["calibration"] = fmt::format("{}/{} fitted on {}", c.workload, c.backend, from);
  return out;
}

// ---- JSON ---------------------------------------------------------------------------------------

namespace {

using json_field::bad;
using json_field::need;
std::string str(const json& o, const std::string& key, const std::string& path, bool required = true) {
  return json_field::get_string(o, key, path, required);
}
double number(const json& v, const std::string& field, double lo, double hi) {
  if (!v.is_number()) bad(field, v, fmt::format("a number in [{}, {}]", lo, hi));
  const double d = v.get<double>();
  if (!std::isfinite(d) || d < lo || d > hi) bad(field, v, fmt::format("a finite number in [{}, {}]", lo, hi));
  return d;
}

}  // namespace

double ErrorFigure::sigma() const { return std::hypot(rms_log, round_log_sd); }

json to_json(const ErrorFigure& e) {
  json j = {{"samples", e.samples}, {"mean_rel", e.mean_rel}, {"max_rel", e.max_rel}, {"rms_log", e.rms_log},
            {"how", e.how}};
  if (e.round_log_sd > 0) {
    j["round_log_sd"] = e.round_log_sd;
    j["round_configs"] = e.round_configs;
  }
  return j;
}

ErrorFigure error_figure_from_json(const json& j, const std::string& field) {
  if (!j.is_object()) bad(field, j, "an object with samples, mean_rel, max_rel, rms_log and how");
  ErrorFigure e;
  e.samples = static_cast<int>(number(need(j, "samples", field + "."), field + ".samples", 0, 1e9));
  e.mean_rel = number(need(j, "mean_rel", field + "."), field + ".mean_rel", 0, 1e6);
  e.max_rel = number(need(j, "max_rel", field + "."), field + ".max_rel", 0, 1e6);
  e.rms_log = number(need(j, "rms_log", field + "."), field + ".rms_log", 0, 100);
  e.how = str(j, "how", field + ".", false);
  if (j.contains("round_log_sd")) {
    e.round_log_sd = number(j.at("round_log_sd"), field + ".round_log_sd", 0, 100);
    e.round_configs = static_cast<int>(number(need(j, "round_configs", field + "."), field + ".round_configs", 1, 1e9));
  }
  return e;
}

json to_json(const Calibration& c) {
  json factors = json::object();
  for (const auto& f : c.factors) {
    json e = {{"kind", f.relative ? "relative" : "absolute"}, {"value", f.value}, {"unit", info(f.id).unit},
              {"fitted", f.fitted}};
    if (f.relative) e["factor"] = f.factor;
    if (f.source_probed) e["source_probed"] = *f.source_probed;
    if (f.log_sigma > 0) e["log_sigma"] = f.log_sigma;
    factors[std::string(info(f.id).name)] = e;
  }
  // The machine the calibration was fitted on, in a profile's identity form.
  MachineProfile id;
  id.identity = c.fitted_on;
  json out = {{"schema", kCalibrationSchemaName},
              {"schema_version", kCalibrationSchemaVersion},
              {"workload", c.workload},
              {"backend", c.backend},
              {"match", c.match},
              {"variant", std::string(to_string(c.variant))},
              {"hardware_class", hardware_class(c.fitted_on, uses_gpu(c))},
              {"fitted_on", to_json(id)["identity"]},
              {"factors", factors},
              {"fit_error", to_json(c.fit_error)}};
  if (c.transfer_error) {
    out["transfer_error"] = to_json(*c.transfer_error);
    out["transfer_measured_on"] = c.transfer_measured_on;
  }
  if (!c.metadata.empty()) out["metadata"] = c.metadata;
  return out;
}

Calibration calibration_from_json(const json& j) {
  if (!j.is_object()) bad("(top level)", j, "a JSON object holding a dtflop calibration");
  const std::string schema = str(j, "schema", "");
  if (schema != kCalibrationSchemaName)
    bad("schema", schema, fmt::format("\"{}\" (a machine profile is read by --machine)", kCalibrationSchemaName));
  const auto& ver = need(j, "schema_version", "");
  if (!ver.is_number_integer() || ver.get<long long>() != kCalibrationSchemaVersion)
    bad("schema_version", ver, fmt::format("{} (this dtflop reads version {} only)", kCalibrationSchemaVersion,
                                           kCalibrationSchemaVersion));
  Calibration c;
  c.workload = str(j, "workload", "");
  c.backend = str(j, "backend", "");
  if (c.workload.empty() || c.backend.empty()) bad("workload/backend", json(), "non-empty names");
  if (auto it = j.find("match"); it != j.end()) {
    if (!it->is_array()) bad("match", *it, "an array of strings");
    for (const auto& m : *it) {
      if (!m.is_string()) bad("match[]", m, "a string");
      c.match.push_back(m.get<std::string>());
    }
  }
  const std::string v = str(j, "variant", "");
  const auto var = variant_from_string(v);
  if (!var) bad("variant", v, variant_names());
  c.variant = *var;
  // The identity is read as a profile's, by the profile's own validation.
  json as_profile = {{"schema", kProfileSchemaName},
                     {"schema_version", kProfileSchemaVersion},
                     {"identity", need(j, "fitted_on", "")},
                     {"parameters", json::object()}};
  try {
    c.fitted_on = profile_from_json(as_profile).identity;
  } catch (const InputError& e) {
    throw InputError(fmt::format("fitted_on: {}", e.what()));
  }
  const auto& factors = need(j, "factors", "");
  if (!factors.is_object() || factors.empty()) bad("factors", factors, "an object of fitted parameters");
  for (const auto& [name, e] : factors.items()) {
    const std::string field = "factors." + name;
    const auto p = param_from_name(name);
    if (!p) bad(field, json(name), "a model parameter name (docs/model.md)");
    if (!e.is_object()) bad(field, e, "an object");
    CalibrationFactor f;
    f.id = *p;
    const std::string kind = str(e, "kind", field + ".");
    if (kind != "relative" && kind != "absolute") bad(field + ".kind", kind, "\"relative\" or \"absolute\"");
    f.relative = kind == "relative";
    f.value = number(need(e, "value", field + "."), field + ".value", 0, 1e30);
    if (!(f.value > 0)) bad(field + ".value", e["value"], "a positive number");
    if (f.relative) {
      f.factor = number(need(e, "factor", field + "."), field + ".factor", 1e-9, 1e9);
      if (auto it = e.find("source_probed"); it != e.end())
        f.source_probed = number(*it, field + ".source_probed", 1e-30, 1e30);
    }
    if (auto it = e.find("log_sigma"); it != e.end()) f.log_sigma = number(*it, field + ".log_sigma", 0, 100);
    if (auto it = e.find("fitted"); it != e.end()) {
      if (!it->is_boolean()) bad(field + ".fitted", *it, "true or false");
      f.fitted = it->get<bool>();
    }
    if (c.find(f.id)) bad(field, json(name), "each parameter once");
    c.factors.push_back(f);
  }
  c.fit_error = error_figure_from_json(need(j, "fit_error", ""), "fit_error");
  if (auto it = j.find("transfer_error"); it != j.end()) {
    c.transfer_error = error_figure_from_json(*it, "transfer_error");
    c.transfer_measured_on = str(j, "transfer_measured_on", "", false);
  }
  c.metadata = json_field::string_map(j, "metadata");
  return c;
}

Calibration load_calibration(const std::filesystem::path& path) {
  const json j = read_json_file(path, "calibration",
                                "write one with `dtflop calibrate ... --write-calibration FILE` (docs/portability.md)");
  try {
    return calibration_from_json(j);
  } catch (const InputError& e) {
    throw InputError(fmt::format("calibration '{}': {}", path.string(), e.what()));
  }
}

void save_calibration(const Calibration& c, const std::filesystem::path& path) {
  write_file_atomically(path, to_json(c).dump(2) + "\n");
}

}  // namespace dtflop
