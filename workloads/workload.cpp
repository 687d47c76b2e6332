#include "workloads/workload.hpp"

#include <cmath>
#include <filesystem>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/units.hpp"

namespace dtflop::workload {

using nlohmann::json;

std::string_view to_string(Kind k) {
  switch (k) {
    case Kind::integer: return "integer";
    case Kind::real: return "real";
    case Kind::size2: return "size WxH";
    case Kind::choice: return "choice";
    case Kind::flag: return "flag";
    case Kind::text: return "text";
  }
  return "?";
}

bool ParamSpec::applies_to(std::string_view backend) const {
  if (backends.empty()) return true;
  for (const auto& b : backends)
    if (b == backend) return true;
  return false;
}

std::string Backend::unavailable() const { return {}; }

void Workload::write_estimate(const Backend& /*backend*/, const Config& /*config*/, std::int64_t /*steps*/,
                              const std::string& /*file*/) const {
  throw InputError(fmt::format("{}: --estimate is not available for this workload; leave it out", name()));
}

const Backend& Workload::backend(std::string_view name) const {
  for (const auto& b : backends())
    if (b->name() == name) return *b;
  throw InputError(fmt::format("{} has no backend '{}'; use one of {}", this->name(), name, backend_names()));
}

std::string Workload::backend_names(std::string_view separator) const {
  std::string out;
  for (const auto& b : backends()) out += (out.empty() ? "" : std::string(separator)) + b->name();
  return out;
}

const ParamSpec* Workload::find_param(std::string_view name) const {
  for (const auto& p : params())
    if (p.name == name) return &p;
  return nullptr;
}

namespace {

std::string as_text(const json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); }
// A value as messages show it: on one line, at most 60 characters.
std::string shown(const json& v) {
  std::string s = as_text(v);
  for (char& ch : s)
    if (static_cast<unsigned char>(ch) < 0x20) ch = ' ';
  return s.size() <= 60 ? s : s.substr(0, 57) + "...";
}

// A whole number from JSON or from text as typed ("12"), in [min, max].
std::int64_t whole(const json& v, const ParamSpec& p, std::string_view wname) {
  std::int64_t x = 0;
  bool ok = false;
  if (v.is_number_integer()) {
    x = v.get<std::int64_t>();
    ok = true;
  } else if (v.is_number_float()) {
    const double d = v.get<double>();
    ok = std::isfinite(d) && d == std::floor(d) && std::abs(d) < 9e15;
    if (ok) x = static_cast<std::int64_t>(d);
  } else if (v.is_string()) {
    const std::string s = v.get<std::string>();
    try {
      std::size_t used = 0;
      x = std::stoll(s, &used);
      ok = used == s.size() && !s.empty();
    } catch (...) {
      ok = false;
    }
  }
  if (!ok)
    throw InputError(fmt::format("{} --{} '{}' is not a whole number; give one in [{}, {}]", wname, p.name,
                                 shown(v), static_cast<std::int64_t>(p.min), static_cast<std::int64_t>(p.max)));
  if (static_cast<double>(x) < p.min || static_cast<double>(x) > p.max)
    throw InputError(fmt::format("{} --{} {} is outside [{}, {}]{}; give a value inside it", wname, p.name, x,
                                 static_cast<std::int64_t>(p.min), static_cast<std::int64_t>(p.max),
                                 p.unit.empty() ? "" : " " + p.unit));
  return x;
}

double real(const json& v, const ParamSpec& p, std::string_view wname) {
  double x = 0;
  bool ok = false;
  if (v.is_number()) {
    x = v.get<double>();
    ok = true;
  } else if (v.is_string()) {
    const std::string s = v.get<std::string>();
    try {
      std::size_t used = 0;
      x = std::stod(s, &used);
      ok = used == s.size() && !s.empty();
    } catch (...) {
      ok = false;
    }
  }
  if (!ok || !std::isfinite(x))
    throw InputError(fmt::format("{} --{} '{}' is not a finite number; give one in [{}, {}]", wname, p.name,
                                 shown(v), p.min, p.max));
  if (x < p.min || x > p.max)
    throw InputError(fmt::format("{} --{} {} is outside [{}, {}]{}; give a value inside it", wname, p.name, x, p.min,
                                 p.max, p.unit.empty() ? "" : " " + p.unit));
  return x;
}

json size2(const json& v, const ParamSpec& p, std::string_view wname) {
  std::int64_t w = 0, h = 0;
  if (v.is_array() && v.size() == 2) {
    ParamSpec side = p;
    w = whole(v[0], side, wname);
    h = whole(v[1], side, wname);
  } else if (v.is_string()) {
    const Size2 s = parse_size2(v.get<std::string>(), fmt::format("--{}", p.name), static_cast<std::int64_t>(p.max));
    w = s.x;
    h = s.y;
  } else {
    throw InputError(fmt::format("{} --{} '{}' is not a size WxH (e.g. 1000x1000)", wname, p.name, shown(v)));
  }
  for (auto x : {w, h})
    if (static_cast<double>(x) < p.min || static_cast<double>(x) > p.max)
      throw InputError(fmt::format("{} --{} {}x{}: each side must be in [{}, {}]{}; give a size inside it", wname,
                                   p.name, w, h, static_cast<std::int64_t>(p.min), static_cast<std::int64_t>(p.max),
                                   p.unit.empty() ? "" : " " + p.unit));
  return json::array({w, h});
}

bool flag(const json& v, const ParamSpec& p, std::string_view wname) {
  if (v.is_boolean()) return v.get<bool>();
  if (v.is_string()) {
    const std::string s = v.get<std::string>();
    if (s == "true" || s == "1" || s == "on" || s == "yes") return true;
    if (s == "false" || s == "0" || s == "off" || s == "no") return false;
  }
  if (v.is_number_integer() && (v.get<int>() == 0 || v.get<int>() == 1)) return v.get<int>() == 1;
  throw InputError(fmt::format("{} --{} '{}' is not true or false", wname, p.name, shown(v)));
}

json value_of(const json& v, const ParamSpec& p, std::string_view wname) {
  switch (p.kind) {
    case Kind::integer: return whole(v, p, wname);
    case Kind::real: return real(v, p, wname);
    case Kind::size2: return size2(v, p, wname);
    case Kind::flag: return flag(v, p, wname);
    case Kind::choice: {
      const std::string s = as_text(v);
      for (const auto& c : p.choices)
        if (c == s) return s;
      std::string known;
      for (const auto& c : p.choices) known += (known.empty() ? "" : ", ") + c;
      throw InputError(fmt::format("{} --{} '{}' is unknown; use one of {}", wname, p.name, shown(v), known));
    }
    case Kind::text:
      if (!v.is_string())
        throw InputError(fmt::format("{} --{} must be text, got {}", wname, p.name, shown(v)));
      return v;
  }
  return v;
}

}  // namespace

Config Workload::validate(const json& given, const Backend& b) const {
  if (!given.is_object())
    throw InputError(fmt::format("a {} configuration must be a JSON object of parameters, got {}", name(),
                                 shown(given)));
  for (auto it = given.begin(); it != given.end(); ++it) {
    const ParamSpec* p = find_param(it.key());
    if (!p) {
      std::string known;
      for (const auto& q : params()) known += (known.empty() ? "" : ", ") + q.name;
      throw InputError(fmt::format("{} has no parameter '{}'; its parameters are {}", name(), it.key(), known));
    }
    if (!p->applies_to(b.name())) {
      std::string which;
      for (const auto& n : p->backends) which += (which.empty() ? "" : ", ") + n;
      throw InputError(fmt::format("{} --{} applies to {} only, not {}; drop it, or use {}", name(), p->name, which,
                                   b.name(), p->backends.size() == 1 ? "that backend" : "one of those backends"));
    }
  }
  Config c = json::object();
  const std::string wname(name());
  for (const auto& p : params()) {
    if (!p.applies_to(b.name())) continue;
    auto it = given.find(p.name);
    if (it != given.end()) c[p.name] = value_of(*it, p, wname);
    else if (!p.fallback.is_null()) c[p.name] = value_of(p.fallback, p, wname);
    else throw InputError(fmt::format("{} needs --{} ({}); give it", wname, p.name, p.help));
  }
  check(c, b);
  return c;
}

std::string Workload::key(const Backend& b, const Config& c) const {
  std::string k = fmt::format("{}/{}", name(), b.name());
  for (const auto& p : params()) {
    auto it = c.find(p.name);
    if (it == c.end()) continue;
    if (!p.keyed_at_default && !p.fallback.is_null() && *it == value_of(p.fallback, p, name())) continue;
    if (p.kind == Kind::size2)
      k += fmt::format("/{}={}x{}", p.name, (*it)[0].get<std::int64_t>(), (*it)[1].get<std::int64_t>());
    else if (p.kind == Kind::flag) k += fmt::format("/{}={}", p.name, it->get<bool>() ? 1 : 0);
    else k += fmt::format("/{}={}", p.name, as_text(*it));
  }
  return k;
}

PlanConfigs Workload::plan_from_file(const std::string& path, const Backend& b) const {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw InputError(fmt::format("--plan '{}' is neither a plan of {} ({}) nor a plan file", path, name(), [this] {
      std::string s;
      for (const auto& [n, d] : plan_names()) s += (s.empty() ? "" : ", ") + n;
      return s + ", random:N";
    }()));
  const std::string what = fmt::format("plan '{}'", path);
  const json j = parse_json_limited(read_file_limited(path, what, kMaxJsonFileBytes), what);
  if (!j.is_object() || !j.contains("configs") || !j["configs"].is_array() || j["configs"].empty())
    throw InputError(fmt::format("plan '{}' needs a non-empty \"configs\" array of parameter objects (e.g. "
                                 "{{\"configs\": [{{\"{}\": ...}}]}})",
                                 path, params().empty() ? "" : params().front().name));
  if (j["configs"].size() > 1000000)
    throw InputError(fmt::format("plan '{}' lists {} configurations; split it into plans of at most 1000000", path,
                                 j["configs"].size()));
  PlanConfigs p;
  p.name = std::filesystem::path(path).filename().string();
  if (j.contains("description") && !j["description"].is_string())
    throw InputError(fmt::format("plan '{}': \"description\" must be text", path));
  p.description = j.value("description", fmt::format("configurations listed in {}", path));
  for (std::size_t i = 0; i < j["configs"].size(); ++i) {
    try {
      p.configs.push_back(validate(j["configs"][i], b));
    } catch (const InputError& e) {
      throw InputError(fmt::format("plan '{}': configs[{}]: {}", path, i, e.what()));
    }
  }
  return p;
}

std::int64_t Workload::random_plan_size(const std::string& spec) {
  const std::string text = spec.rfind("random:", 0) == 0 ? spec.substr(7) : std::string();
  std::int64_t n = 0;
  try {
    std::size_t used = 0;
    n = std::stoll(text, &used);
    if (used != text.size()) n = 0;
  } catch (...) {
    n = 0;
  }
  if (n < 1 || n > 100000)
    throw InputError(fmt::format("--plan '{}': N must be a whole number in 1..100000 (e.g. random:50)", spec));
  return n;
}

// ---- Typed access --------------------------------------------------------------------------

namespace {
const json& at(const Config& c, std::string_view name) {
  auto it = c.find(std::string(name));
  if (it == c.end())
    throw std::logic_error(fmt::format("configuration has no parameter '{}' (a workload bug)", name));
  return *it;
}
}  // namespace

std::int64_t get_int(const Config& c, std::string_view n) { return at(c, n).get<std::int64_t>(); }
double get_real(const Config& c, std::string_view n) { return at(c, n).get<double>(); }
std::pair<std::int64_t, std::int64_t> get_size2(const Config& c, std::string_view n) {
  const json& v = at(c, n);
  return {v.at(0).get<std::int64_t>(), v.at(1).get<std::int64_t>()};
}
std::string get_text(const Config& c, std::string_view n) { return at(c, n).get<std::string>(); }
bool get_flag(const Config& c, std::string_view n) { return at(c, n).get<bool>(); }
bool has(const Config& c, std::string_view n) { return c.contains(std::string(n)); }

}  // namespace dtflop::workload
