#include "calibrate/sample.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "workloads/workload.hpp"

namespace dtflop::calib {

using nlohmann::json;

std::string_view to_string(Component c) {
  switch (c) {
    case Component::total: return "total";
    case Component::CG: return "CG";
    case Component::GC: return "GC";
    case Component::G: return "G";
    case Component::C: return "C";
  }
  return "?";
}

const std::vector<Component>& all_components() {
  static const std::vector<Component> all = {Component::total, Component::CG, Component::GC,
                                             Component::G, Component::C};
  return all;
}

std::optional<Component> component_from_string(std::string_view s) {
  for (auto c : all_components())
    if (to_string(c) == s) return c;
  return std::nullopt;
}

std::optional<Phase> phase(Component c) {
  switch (c) {
    case Component::total: return std::nullopt;
    case Component::CG: return Phase::CG;
    case Component::GC: return Phase::GC;
    case Component::G: return Phase::G;
    case Component::C: return Phase::C;
  }
  return std::nullopt;
}

double predicted(const Prediction& p, Component c) {
  const auto ph = phase(c);
  return ph ? phase_seconds(p, *ph) : p.total;
}

std::string_view to_string(TimingSource s) { return s == TimingSource::cupti ? "cupti" : "host"; }

int Sample::repetitions() const {
  const Stats* t = find(Component::total);
  return t ? static_cast<int>(t->values.size()) : 0;
}

namespace {

[[noreturn]] void bad(const std::string& field, const json& value, const std::string& expected) {
  std::string shown = value.is_null() ? std::string("missing") : value.dump();
  if (shown.size() > 60) shown = shown.substr(0, 57) + "...";
  throw InputError(fmt::format("sample field '{}' is {}, expected {}", field, shown, expected));
}

const json& need(const json& j, const char* key) {
  auto it = j.find(key);
  if (it == j.end()) bad(key, json(), "to be present");
  return *it;
}

std::string need_string(const json& j, const char* key, bool allow_empty = false) {
  const json& v = need(j, key);
  if (!v.is_string() || (!allow_empty && v.get<std::string>().empty())) bad(key, v, "a non-empty string");
  return v.get<std::string>();
}

std::string opt_string(const json& j, const char* key) {
  auto it = j.find(key);
  if (it == j.end()) return {};
  if (!it->is_string()) bad(key, *it, "a string");
  return it->get<std::string>();
}

double time_value(const json& v, const std::string& field) {
  if (!v.is_number()) bad(field, v, "a time in seconds");
  const double d = v.get<double>();
  if (!std::isfinite(d) || d < 0) bad(field, v, "a finite, non-negative time in seconds");
  return d;
}

json stats_json(const Stats& s) {
  return {{"median", s.median}, {"p25", s.p25}, {"p75", s.p75},
          {"min", s.min},       {"max", s.max}, {"values", s.values}};
}

Stats stats_from_json(const json& j, const std::string& field) {
  if (!j.is_object()) bad(field, j, "an object with the repetitions' values");
  const json& v = j.contains("values") ? j["values"] : json();
  if (!v.is_array() || v.empty()) bad(field + ".values", v, "a non-empty array of times in seconds");
  std::vector<double> values;
  values.reserve(v.size());
  for (std::size_t i = 0; i < v.size(); ++i)
    values.push_back(time_value(v[i], fmt::format("{}.values[{}]", field, i)));
  // The summary is recomputed from the values, so it can never disagree with them.
  return summarize(std::move(values));
}

}  // namespace

json to_json(const MachineIdentity& id) {
  MachineProfile p;
  p.identity = id;
  return dtflop::to_json(p)["identity"];
}

MachineIdentity identity_from_json(const json& j) {
  json wrapper = {{"schema", kProfileSchemaName},
                  {"schema_version", kProfileSchemaVersion},
                  {"identity", j},
                  {"parameters", json::object()}};
  try {
    return profile_from_json(wrapper).identity;
  } catch (const InputError& e) {
    throw InputError(fmt::format("sample field 'machine': {}", e.what()));
  }
}

json to_json(const Sample& s) {
  json comps = json::object();
  for (const auto& [c, st] : s.components) comps[std::string(to_string(c))] = stats_json(st);
  json out = {{"schema", kSampleSchema},
              {"schema_version", kSampleSchemaVersion},
              {"key", s.key},
              {"measured_at", s.measured_at},
              {"machine", to_json(s.machine)},
              {"workload", s.workload},
              {"backend", s.backend},
              {"plan", s.plan},
              {"round", s.round},
              {"parameters", s.parameters},
              {"steps", s.steps},
              {"warmup", s.warmup},
              {"counts", dtflop::to_json(s.counts)},
              {"timing", {{"source", to_string(s.source)}, {"note", s.timing_note}}},
              {"components", comps}};
  if (!s.detail.empty()) out["detail"] = s.detail;
  return out;
}

Sample sample_from_json(const json& j) {
  if (!j.is_object()) bad("(line)", j, "a JSON object");
  const json& schema = need(j, "schema");
  if (schema != kSampleSchema) bad("schema", schema, fmt::format("\"{}\"", kSampleSchema));
  const json& ver = need(j, "schema_version");
  if (!ver.is_number_integer() || ver.get<int>() != kSampleSchemaVersion)
    bad("schema_version", ver, fmt::format("{} (this dtflop reads version {} only)",
                                           kSampleSchemaVersion, kSampleSchemaVersion));
  Sample s;
  s.key = need_string(j, "key");
  s.measured_at = opt_string(j, "measured_at");
  s.machine = identity_from_json(need(j, "machine"));
  s.workload = need_string(j, "workload");
  s.backend = need_string(j, "backend");
  const workload::Workload* w = nullptr;
  const workload::Backend* b = nullptr;
  try {
    w = &workload::find(s.workload);
    b = &w->backend(s.backend);
  } catch (const InputError& e) {
    throw InputError(fmt::format("sample field 'workload'/'backend': {}", e.what()));
  }
  s.plan = opt_string(j, "plan");
  if (auto it = j.find("round"); it != j.end()) {  // absent in samples written before rounds: round 1
    if (!it->is_number_integer() || it->get<long long>() < 1 || it->get<long long>() > 1000000)
      bad("round", *it, "an integer >= 1");
    s.round = it->get<int>();
  }
  s.parameters = need(j, "parameters");
  if (!s.parameters.is_object()) bad("parameters", s.parameters, "an object");
  try {
    // Every value of a parameter the workload has is checked as on the command line; names it no
    // longer has (stores kept from earlier versions, e.g. rbe's Ix) are kept as they are.
    json known = json::object();
    for (const auto& [name, value] : s.parameters.items())
      if (const auto* p = w->find_param(name); p && p->applies_to(b->name())) known[name] = value;
    (void)w->validate(known, *b);
  } catch (const InputError& e) {
    throw InputError(fmt::format("sample field 'parameters': {}", e.what()));
  }
  const json& steps = need(j, "steps");
  if (!steps.is_number_integer() || steps.get<long long>() < 1) bad("steps", steps, "an integer >= 1");
  s.steps = steps.get<std::int64_t>();
  if (auto it = j.find("warmup"); it != j.end()) {
    if (!it->is_number_integer() || it->get<int>() < 0) bad("warmup", *it, "an integer >= 0");
    s.warmup = it->get<int>();
  }
  try {
    s.counts = counts_from_json(need(j, "counts"));
  } catch (const InputError& e) {
    throw InputError(fmt::format("sample field 'counts': {}", e.what()));
  }
  const json& timing = need(j, "timing");
  if (!timing.is_object()) bad("timing", timing, "an object");
  const std::string src = timing.value("source", std::string());
  if (src == "cupti") s.source = TimingSource::cupti;
  else if (src == "host") s.source = TimingSource::host;
  else bad("timing.source", timing.value("source", json()), "\"cupti\" or \"host\"");
  if (auto it = timing.find("note"); it != timing.end() && it->is_string()) s.timing_note = it->get<std::string>();

  const json& comps = need(j, "components");
  if (!comps.is_object()) bad("components", comps, "an object of measured components");
  for (const auto& [name, st] : comps.items()) {
    auto c = component_from_string(name);
    if (!c) bad("components." + name, name, "one of total, CG, GC, G, C");
    s.components[*c] = stats_from_json(st, "components." + name);
  }
  const Stats* total = s.find(Component::total);
  if (!total) bad("components.total", json(), "to be present (every sample has a total)");
  for (std::size_t i = 0; i < total->values.size(); ++i)
    if (!(total->values[i] > 0))
      bad(fmt::format("components.total.values[{}]", i), total->values[i],
          "a positive time (a repetition takes time; a zero total is a broken measurement)");
  if (auto it = j.find("detail"); it != j.end()) s.detail = *it;
  return s;
}

std::string utc_now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace dtflop::calib
