#include "tune/scenario.hpp"

#include <cmath>
#include <set>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/units.hpp"

namespace dtflop::tune {

namespace {

constexpr std::uintmax_t kMaxScenarioBytes = std::uintmax_t{1} << 20;
constexpr int kMaxYamlDepth = 16;

std::size_t invalid_utf8_at(const std::string& t);

struct Reader {
  std::string origin;
  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw InputError(fmt::format("scenario {}: {}: {}", origin, field, what));
  }
};

std::string scalar_text(const YAML::Node& n, const Reader& r, const std::string& field) {
  if (!n.IsScalar()) r.fail(field, "expected a single value (text or number)");
  if (invalid_utf8_at(n.Scalar()) != std::string::npos) r.fail(field, "a key that is not UTF-8 text");
  return n.Scalar();
}

// A YAML node as JSON: scalars become numbers where they read as finite numbers, booleans for
// true/false, else text. Deeper than kMaxYamlDepth is refused.
nlohmann::json to_json(const YAML::Node& n, const Reader& r, const std::string& field, int depth = 0) {
  if (depth > kMaxYamlDepth) r.fail(field, fmt::format("nested deeper than {} levels", kMaxYamlDepth));
  switch (n.Type()) {
    case YAML::NodeType::Null:
    case YAML::NodeType::Undefined: return nullptr;
    case YAML::NodeType::Scalar: {
      const std::string& s = n.Scalar();
      if (invalid_utf8_at(s) != std::string::npos) r.fail(field, "a value that is not UTF-8 text");
      if (n.Tag() != "!" && !s.empty()) {  // quoted scalars ("!") stay text
        if (s == "true") return true;
        if (s == "false") return false;
        char* end = nullptr;
        const double v = std::strtod(s.c_str(), &end);
        if (end == s.c_str() + s.size()) {
          if (!std::isfinite(v)) r.fail(field, fmt::format("'{}' is not a finite number", s));
          return v;
        }
      }
      return s;
    }
    case YAML::NodeType::Sequence: {
      nlohmann::json a = nlohmann::json::array();
      for (std::size_t i = 0; i < n.size(); ++i)
        a.push_back(to_json(n[i], r, fmt::format("{}[{}]", field, i), depth + 1));
      return a;
    }
    case YAML::NodeType::Map: {
      nlohmann::json o = nlohmann::json::object();
      for (const auto& kv : n) {
        const std::string k = scalar_text(kv.first, r, field);
        o[k] = to_json(kv.second, r, field + "." + k, depth + 1);
      }
      return o;
    }
  }
  return nullptr;
}

std::string number_text(double v) {
  if (v == std::floor(v) && std::abs(v) < 9e15) return fmt::format("{}", static_cast<long long>(v));
  return fmt::format("{}", v);
}

// The values of one axis: a list, or a range {from, to, step[, square]}.
std::vector<std::string> axis_values(const nlohmann::json& v, const Reader& r, const std::string& field) {
  std::vector<std::string> out;
  auto text = [&](const nlohmann::json& x, const std::string& f) -> std::string {
    if (x.is_string()) return x.get<std::string>();
    if (x.is_number()) return number_text(x.get<double>());
    if (x.is_boolean()) return x.get<bool>() ? "true" : "false";
    if (x.is_array() && x.size() == 2 && x[0].is_number() && x[1].is_number())
      return number_text(x[0].get<double>()) + "x" + number_text(x[1].get<double>());
    r.fail(f, "expected a value (text, number, true/false or [W, H])");
  };
  if (v.is_array()) {
    if (v.empty()) r.fail(field, "an empty list: give at least one value, or leave the parameter out");
    for (std::size_t i = 0; i < v.size(); ++i) out.push_back(text(v[i], fmt::format("{}[{}]", field, i)));
  } else if (v.is_object()) {
    for (const auto& [k, _] : v.items())
      if (k != "from" && k != "to" && k != "step" && k != "square")
        r.fail(field + "." + k, "unknown field of a range (expected from, to, step and optionally square)");
    for (const char* k : {"from", "to", "step"})
      if (!v.contains(k) || !v[k].is_number())
        r.fail(fmt::format("{}.{}", field, k), "a range needs from, to and step as numbers");
    const double from = v["from"].get<double>(), to = v["to"].get<double>(), step = v["step"].get<double>();
    if (!(step > 0)) r.fail(field + ".step", fmt::format("{} is not positive", step));
    if (to < from) r.fail(field + ".to", fmt::format("{} is below from ({})", to, from));
    const double n = std::floor((to - from) / step + 1e-9) + 1;
    if (n > static_cast<double>(kMaxSpace))
      r.fail(field, fmt::format("the range holds {:.0f} values, more than {}", n, kMaxSpace));
    bool square = false;
    if (v.contains("square")) {
      if (!v["square"].is_boolean()) r.fail(field + ".square", "expected true or false");
      square = v["square"].get<bool>();
    }
    for (long long i = 0; i < static_cast<long long>(n); ++i) {
      const std::string x = number_text(from + static_cast<double>(i) * step);
      out.push_back(square ? x + "x" + x : x);
    }
  } else {
    out.push_back(text(v, field));
  }
  std::set<std::string> seen;
  for (const auto& x : out)
    if (!seen.insert(x).second) r.fail(field, fmt::format("'{}' is listed twice", x));
  return out;
}

// The byte offset of the first byte that does not continue valid UTF-8 (YAML text is UTF-8), or
// npos: no over-long forms, no surrogates, nothing beyond U+10FFFF.
std::size_t invalid_utf8_at(const std::string& t) {
  const auto* b = reinterpret_cast<const unsigned char*>(t.data());
  const std::size_t n = t.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned c = b[i];
    std::size_t len = 0;
    unsigned lo = 0x80, hi = 0xBF;  // the range of the second byte
    if (c < 0x80) len = 1;
    else if (c >= 0xC2 && c <= 0xDF) len = 2;
    else if (c == 0xE0) len = 3, lo = 0xA0;
    else if ((c >= 0xE1 && c <= 0xEC) || c == 0xEE || c == 0xEF) len = 3;
    else if (c == 0xED) len = 3, hi = 0x9F;
    else if (c == 0xF0) len = 4, lo = 0x90;
    else if (c >= 0xF1 && c <= 0xF3) len = 4;
    else if (c == 0xF4) len = 4, hi = 0x8F;
    else return i;
    if (i + len > n) return i;
    for (std::size_t k = 1; k < len; ++k) {
      const unsigned d = b[i + k];
      if (k == 1 ? (d < lo || d > hi) : (d < 0x80 || d > 0xBF)) return i;
    }
    i += len;
  }
  return std::string::npos;
}

std::string resolve(const std::string& p, const std::filesystem::path& base) {
  if (p.empty()) return p;
  const std::filesystem::path path(p);
  return path.is_absolute() || base.empty() ? p : (base / path).lexically_normal().string();
}

}  // namespace

Scenario parse_scenario(const std::string& yaml, const std::filesystem::path& base, const std::string& origin) {
  const Reader r{origin};
  if (const std::size_t at = invalid_utf8_at(yaml); at != std::string::npos)
    throw InputError(fmt::format("scenario {}: byte {} is not UTF-8 text; save the file as UTF-8", origin, at));
  // YAML allows no control characters but tab, line feed and carriage return (and a NUL would
  // make yaml-cpp guess UTF-16 or UTF-32 and transcode the text).
  for (std::size_t i = 0; i < yaml.size(); ++i) {
    const auto c = static_cast<unsigned char>(yaml[i]);
    if ((c < 0x20 && c != '\t' && c != '\n' && c != '\r') || c == 0x7F)
      throw InputError(fmt::format("scenario {}: byte {} is a control character (0x{:02x}); a scenario is text", origin,
                                   i, c));
  }
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("scenario {}: not valid YAML (line {}, column {}: {}); fix the file", origin,
                                 e.mark.line + 1, e.mark.column + 1, e.msg));
  }
  if (!root.IsMap()) r.fail("(top level)", "expected a mapping of fields (name:, workload:, space:, ...)");
  const nlohmann::json j = to_json(root, r, "(top level)");
  static const std::set<std::string> known = {"name",     "description", "workload", "machine", "calibrations",
                                              "deadline", "confidence",  "space",    "fixed",   "accuracy"};
  for (const auto& [k, _] : j.items())
    if (!known.count(k))
      r.fail(k, "unknown field (expected name, description, workload, machine, calibrations, deadline, confidence, "
                "space, fixed, accuracy)");
  Scenario s;
  s.file = origin;
  auto text = [&](const char* k, bool required) -> std::string {
    if (!j.contains(k) || j[k].is_null()) {
      if (required) r.fail(k, "missing; it is required");
      return {};
    }
    if (!j[k].is_string()) r.fail(k, fmt::format("expected text, got {}", j[k].dump()));
    return j[k].get<std::string>();
  };
  s.name = text("name", true);
  if (s.name.empty() || s.name.size() > 100) r.fail("name", "expected 1 to 100 characters");
  s.description = text("description", false);
  s.workload = text("workload", true);
  s.machine = resolve(text("machine", false), base);
  if (j.contains("calibrations")) {
    const auto& c = j["calibrations"];
    if (!c.is_array()) r.fail("calibrations", "expected a list of calibration files");
    for (std::size_t i = 0; i < c.size(); ++i) {
      if (!c[i].is_string()) r.fail(fmt::format("calibrations[{}]", i), "expected a file name");
      s.calibrations.push_back(resolve(c[i].get<std::string>(), base));
    }
  }
  if (j.contains("deadline") && !j["deadline"].is_null()) {
    const auto& d = j["deadline"];
    const std::string t = d.is_number() ? number_text(d.get<double>()) : d.is_string() ? d.get<std::string>() : "";
    if (t.empty()) r.fail("deadline", "expected a duration such as 33ms or 0.05 (seconds)");
    try {
      s.deadline = parse_duration(t, "deadline");
    } catch (const InputError& e) {
      r.fail("deadline", e.what());
    }
    if (!(*s.deadline > 0)) r.fail("deadline", fmt::format("'{}' is not a positive duration", t));
  }
  if (j.contains("confidence")) {
    const auto& c = j["confidence"];
    if (!c.is_number() || !(c.get<double>() >= 0.5 && c.get<double>() < 1))
      r.fail("confidence", fmt::format("{} is not a probability in [0.5, 1)", c.dump()));
    s.confidence = c.get<double>();
  }
  if (!j.contains("space") || !j["space"].is_object())
    r.fail("space", "missing or not a mapping of parameter: values (e.g. backend: [cpu-seq, cpu-par])");
  std::size_t total = 1;
  for (const auto& [k, v] : j["space"].items()) {
    const std::vector<std::string> values = axis_values(v, r, "space." + k);
    if (k == "backend") {
      s.backends = values;
    } else {
      s.axes.push_back({k, values});
    }
    total *= values.size();
    if (total > kMaxSpace)
      r.fail("space", fmt::format("the space holds more than {} configurations; narrow a range", kMaxSpace));
  }
  if (j.contains("fixed")) {
    if (!j["fixed"].is_object()) r.fail("fixed", "expected a mapping of parameter: value");
    for (const auto& [k, v] : j["fixed"].items()) {
      const auto values = axis_values(v, r, "fixed." + k);
      if (values.size() != 1) r.fail("fixed." + k, "expected one value");
      for (const auto& a : s.axes)
        if (a.param == k) r.fail("fixed." + k, "also in space: a parameter is either varied or fixed");
      s.fixed[k] = values[0];
    }
  }
  if (j.contains("accuracy")) {
    if (!j["accuracy"].is_object()) r.fail("accuracy", "expected a mapping (see docs/tune.md for each workload)");
    s.accuracy = j["accuracy"];
  }
  return s;
}

Scenario load_scenario(const std::filesystem::path& path) {
  const std::string text = read_file_limited(path, fmt::format("scenario '{}'", path.string()), kMaxScenarioBytes);
  Scenario s = parse_scenario(text, path.parent_path(), "'" + path.string() + "'");
  s.file = path;
  return s;
}

}  // namespace dtflop::tune
