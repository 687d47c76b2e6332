#include "model/predict.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/terms.hpp"

namespace dtflop {

std::string_view to_string(Variant v) {
  switch (v) {
    case Variant::seed: return "seed";
    case Variant::latency: return "latency";
    case Variant::memory: return "memory";
    case Variant::extended: return "extended";
  }
  return "?";
}

const std::vector<Variant>& all_variants() {
  static const std::vector<Variant> v = {Variant::seed, Variant::latency, Variant::memory, Variant::extended};
  return v;
}

std::string variant_names(std::string_view last_separator) {
  std::string out;
  const auto& v = all_variants();
  for (std::size_t i = 0; i < v.size(); ++i)
    out += fmt::format("{}{}", i == 0 ? "" : i + 1 == v.size() ? last_separator : std::string_view(", "), to_string(v[i]));
  return out;
}

std::optional<Variant> variant_from_string(std::string_view s) {
  for (auto v : all_variants())
    if (to_string(v) == s) return v;
  return std::nullopt;
}

std::optional<Variant> simpler_variant(Variant v) {
  switch (v) {
    case Variant::seed: return std::nullopt;
    case Variant::latency: return Variant::seed;
    case Variant::memory:
    case Variant::extended: return Variant::latency;
  }
  return std::nullopt;
}

namespace {

bool fp64(Precision p) { return p == Precision::fp64; }
Param v_c1(Precision p) { return fp64(p) ? Param::V_C1_fp64 : Param::V_C1_fp32; }
Param v_c(Precision p) { return fp64(p) ? Param::V_C_fp64 : Param::V_C_fp32; }

// Picks the single-thread or all-thread figure: one thread uses the first, as many
// threads as the machine has use the second, and in between threads x first, capped.
double scaled_rate(const MachineProfile& m, Param one, Param all, int threads) {
  if (threads <= 1) return m.get(one).value;
  const int hw = std::max(1, m.identity.cpu_threads);
  if (threads >= hw || !m.has(one)) return m.get(all).value;
  return std::min(threads * m.get(one).value, m.get(all).value);
}

}  // namespace

double cpu_rate(const MachineProfile& m, Precision precision, int threads) {
  return scaled_rate(m, v_c1(precision), v_c(precision), threads);
}

double host_bandwidth(const MachineProfile& m, int threads) {
  return scaled_rate(m, Param::B_host_1, Param::B_host, threads);
}

double llc_share_missed(const MachineProfile& m, const CostCounts& c) {
  const std::int64_t llc = model_llc_bytes(m.identity);
  if (c.cpu_footprint <= 0 || llc <= 0) return 1.0;
  return std::min(1.0, static_cast<double>(c.cpu_footprint) / static_cast<double>(llc));
}

double host_seconds_per_byte(const MachineProfile& m, const CostCounts& c) {
  const double w = llc_share_missed(m, c);
  double s = w / host_bandwidth(m, c.cpu_threads);
  if (w < 1.0) s += (1.0 - w) / scaled_rate(m, Param::B_llc_1, Param::B_llc, c.cpu_threads);
  return s;
}

bool has_staging(const MachineProfile& m) {
  return m.has(Param::B_GC_staged) && m.has(Param::S_GC_staged) && m.has(Param::S_GC_flat);
}

double staged_copy_seconds(const MachineProfile& m, std::int64_t bytes) {
  const double b = static_cast<double>(bytes);
  const double staged = m.get(Param::S_GC_staged).value, flat = m.get(Param::S_GC_flat).value;
  return std::min(b, staged) / m.get(Param::B_GC_staged).value +
         std::max(b - staged - flat, 0.0) / m.get(Param::B_GC_pageable).value;
}

namespace {

// Parameters no probe measures: only `dtflop calibrate` finds them (docs/model.md, section 3).
bool fitted_only(Param p) {
  switch (p) {
    case Param::B_GC_staged:
    case Param::S_GC_staged:
    case Param::S_GC_flat:
    case Param::L_graph: return true;
    default: return false;
  }
}

std::vector<Param> lacking(const MachineProfile& m, const CostCounts& c, Variant variant) {
  std::vector<Param> out;
  for (Param p : required_params(c, variant, Pricing::of(m)))
    if (!m.has(p)) out.push_back(p);
  return out;
}

// "B_GS (what it is), K_CW (what it is)" and "B_GS, K_CW" of the fitted-only ones.
std::string described(const std::vector<Param>& params, bool fitted_ones_only = false) {
  std::string out;
  for (Param p : params) {
    if (fitted_ones_only && !fitted_only(p)) continue;
    const ParamInfo& i = info(p);
    out += fmt::format("{}{}", out.empty() ? "" : ", ",
                       fitted_ones_only ? std::string(i.name) : fmt::format("{} ({})", i.name, i.what));
  }
  return out;
}

MissingParameter missing_parameters(const std::vector<Param>& missing, Variant variant) {
  const std::string unprobed = described(missing, true);
  return MissingParameter(fmt::format(
      "the machine profile lacks {} needed to predict this computation with the {} variant; {}", described(missing),
      to_string(variant),
      unprobed.empty()
          ? "probe a machine that has it (`dtflop probe`), or use one of the profiles in docs/examples/"
          : fmt::format("no probe measures {}: fit it to measured runs of this machine (`dtflop sweep`, then "
                        "`dtflop calibrate`, docs/calibration.md), or predict with a simpler --variant",
                        unprobed)));
}

}  // namespace

std::vector<Param> priced_params(const MachineProfile& m, const CostCounts& c, Variant variant) {
  return required_params(c, variant, Pricing::of(m));
}

std::vector<Param> required_params(const CostCounts& c, Variant variant, const Pricing& x) {
  std::vector<Param> out;
  for (const Term& t : terms()) {
    if (!t.applies(variant) || !t.price.counted(c)) continue;
    for (Param p : t.price.needs(c, variant, x))
      if (std::find(out.begin(), out.end(), p) == out.end()) out.push_back(p);
  }
  return out;
}

Prediction predict(const MachineProfile& m, const CostCounts& c, Variant variant) {
  if (c.P <= 0) throw InputError(fmt::format("bytes per value P must be positive, got {}", c.P));
  check_consistent(c);
  // Report every missing parameter at once.
  if (const auto missing = lacking(m, c, variant); !missing.empty()) throw missing_parameters(missing, variant);

  const Pricing x = Pricing::of(m);
  Prediction r;
  r.variant = variant;
  // A count of zero needs no parameter and costs nothing; a term outside its variants neither.
  for (const Term& t : terms())
    if (t.applies(variant) && t.price.counted(c)) r.*t.field = t.price.seconds(m, c, variant, x);
  r.dt_C = phase_seconds(r, Phase::C);
  for (Phase phase : all_phases()) r.total += phase_seconds(r, phase);
  return r;
}

Variant richest_supported_variant(const MachineProfile& m, const CostCounts& c, Variant wanted,
                                  std::vector<Param>* missing) {
  if (missing) *missing = lacking(m, c, wanted);
  for (std::optional<Variant> v = wanted; v; v = simpler_variant(*v))
    if (lacking(m, c, *v).empty()) return *v;
  throw missing_parameters(lacking(m, c, Variant::seed), Variant::seed);
}

std::string fallback_note(Variant wanted, Variant used, const std::vector<Param>& missing) {
  if (wanted == used || missing.empty()) return {};
  std::string fitted, probed;
  for (Param p : missing) {
    std::string& list = fitted_only(p) ? fitted : probed;
    list += fmt::format("{}{}", list.empty() ? "" : ", ", info(p).name);
  }
  std::string todo;
  if (!fitted.empty())
    todo = fmt::format("fit {} to measured runs of this machine (`dtflop sweep`, then `dtflop calibrate`, "
                       "docs/calibration.md)",
                       fitted);
  if (!probed.empty()) todo += fmt::format("{}measure {} with `dtflop probe`", todo.empty() ? "" : ", and ", probed);
  return fmt::format("the machine profile lacks {} for the {} variant: predicting with the {} variant instead; {}",
                     described(missing), to_string(wanted), to_string(used), todo);
}

std::optional<Variant> chosen_variant(const MachineProfile& m) {
  auto it = m.metadata.find(kChosenVariantKey);
  if (it == m.metadata.end()) return std::nullopt;
  if (auto v = variant_from_string(it->second)) return v;
  throw InputError(fmt::format("the machine profile's field 'metadata.{}' is \"{}\", which is no model variant ({}); "
                               "correct it, or fit the profile again with `dtflop calibrate`",
                               kChosenVariantKey, it->second, variant_names()));
}

}  // namespace dtflop
