#include "sar/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <set>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "model/errors.hpp"
#include "model/json_io.hpp"

namespace dtflop::sar {
namespace {

constexpr std::uintmax_t kMaxScenarioBytes = std::uintmax_t{1} << 20;
constexpr std::int64_t kMaxCells = std::int64_t{1} << 26;  // 64 Mi cells: 256 MiB of float32 per belief
constexpr std::int64_t kMaxSteps = 10'000'000;
constexpr std::int64_t kMaxHelicopters = 1024;

[[noreturn]] void bad(const std::string& what, const std::string& field, const std::string& value,
                      const std::string& expected) {
  throw InputError(fmt::format("{}: field {} is {}; expected {}", what, field, value, expected));
}

std::string show(double v) { return fmt::format("{}", v); }

void positive(const std::string& what, const char* field, double v) {
  if (!(v > 0) || !std::isfinite(v)) bad(what, field, show(v), "a finite number > 0");
}
void non_negative(const std::string& what, const char* field, double v) {
  if (!(v >= 0) || !std::isfinite(v)) bad(what, field, show(v), "a finite number >= 0");
}
void finite(const std::string& what, const char* field, double v) {
  if (!std::isfinite(v)) bad(what, field, show(v), "a finite number");
}
void in_range(const std::string& what, const char* field, double v, double lo, double hi, const char* expected) {
  if (!(v >= lo && v <= hi)) bad(what, field, show(v), expected);
}

// Reads a YAML tree against the scenario's fields, naming the path of each field in messages.
class Reader {
 public:
  explicit Reader(std::string what) : what_(std::move(what)) {}

  // Visits the keys of map `node` at `path`; each key must be one of `handlers`.
  void map(const YAML::Node& node, const std::string& path,
           const std::vector<std::pair<std::string, std::function<void(const YAML::Node&, const std::string&)>>>& handlers) {
    if (!node.IsMap()) bad(what_, path.empty() ? "(top level)" : path, kind(node), "a mapping of fields");
    std::set<std::string> seen;
    for (const auto& kv : node) {
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "?";
      const std::string full = path.empty() ? key : path + "." + key;
      bool found = false;
      for (const auto& [name, fn] : handlers)
        if (name == key) {
          if (!seen.insert(key).second) bad(what_, full, "given twice", "each field once");
          fn(kv.second, full);
          found = true;
        }
      if (!found) {
        std::string known;
        for (const auto& h : handlers) known += (known.empty() ? "" : ", ") + h.first;
        bad(what_, full, "unknown", fmt::format("one of {}", known));
      }
    }
  }
  double number(const YAML::Node& n, const std::string& path) {
    if (!n.IsScalar()) bad(what_, path, kind(n), "a number");
    try {
      const double v = n.as<double>();
      if (!std::isfinite(v)) bad(what_, path, n.Scalar(), "a finite number");
      return v;
    } catch (const YAML::Exception&) {
      bad(what_, path, fmt::format("'{}'", n.Scalar()), "a number");
    }
  }
  std::int64_t integer(const YAML::Node& n, const std::string& path, std::int64_t lo, std::int64_t hi) {
    const double v = number(n, path);
    if (v != std::floor(v) || v < double(lo) || v > double(hi))
      bad(what_, path, n.Scalar(), fmt::format("a whole number in [{}, {}]", lo, hi));
    return static_cast<std::int64_t>(v);
  }
  bool flag(const YAML::Node& n, const std::string& path) {
    if (!n.IsScalar()) bad(what_, path, kind(n), "true or false");
    const std::string t = n.Scalar();
    if (t == "true") return true;
    if (t == "false") return false;
    bad(what_, path, fmt::format("'{}'", t), "true or false");
  }
  std::string text(const YAML::Node& n, const std::string& path) {
    if (!n.IsScalar() || n.Scalar().size() > 200) bad(what_, path, kind(n), "a short text");
    return n.Scalar();
  }
  std::vector<double> numbers(const YAML::Node& n, const std::string& path, std::size_t count) {
    if (!n.IsSequence() || n.size() != count) bad(what_, path, kind(n), fmt::format("a list of {} numbers", count));
    std::vector<double> v;
    for (std::size_t i = 0; i < count; ++i) v.push_back(number(n[i], fmt::format("{}[{}]", path, i)));
    return v;
  }
  const std::string& what() const { return what_; }

  static std::string kind(const YAML::Node& n) {
    if (n.IsMap()) return "a mapping";
    if (n.IsSequence()) return fmt::format("a list of {}", n.size());
    if (n.IsNull()) return "empty";
    return fmt::format("'{}'", n.Scalar().substr(0, 40));
  }

 private:
  std::string what_;
};

void read_into(Scenario& s, const YAML::Node& root, Reader& r) {
  using N = const YAML::Node&;
  using S = const std::string&;
  auto mean_sigma = [&r](double& mean, double& sigma) {
    return [&r, &mean, &sigma](N n, S p) {
      r.map(n, p, {{"mean", [&](N m, S q) { mean = r.number(m, q); }}, {"sigma", [&](N m, S q) { sigma = r.number(m, q); }}});
    };
  };
  r.map(root, "", {
      {"name", [&](N n, S p) { s.name = r.text(n, p); }},
      {"area", [&](N n, S p) {
         r.map(n, p, {{"x", [&](N m, S q) { auto v = r.numbers(m, q, 2); s.x_min = v[0], s.x_max = v[1]; }},
                      {"y", [&](N m, S q) { auto v = r.numbers(m, q, 2); s.y_min = v[0], s.y_max = v[1]; }},
                      {"cells", [&](N m, S q) {
                         if (!m.IsSequence() || m.size() != 2) bad(r.what(), q, Reader::kind(m), "a list of 2 whole numbers");
                         s.nx = r.integer(m[0], q + "[0]", 1, 65536);
                         s.ny = r.integer(m[1], q + "[1]", 1, 65536);
                       }}});
       }},
      {"time", [&](N n, S p) {
         r.map(n, p, {{"step", [&](N m, S q) { s.step_time = r.number(m, q); }},
                      {"steps", [&](N m, S q) { s.steps = r.integer(m, q, 1, kMaxSteps); }}});
       }},
      {"target", [&](N n, S p) {
         r.map(n, p, {{"speed", mean_sigma(s.target_speed_mean, s.target_speed_sigma)},
                      {"heading", mean_sigma(s.target_heading_mean, s.target_heading_sigma)},
                      {"prior", [&](N m, S q) {
                         r.map(m, q, {{"mean", [&](N k, S t) { auto v = r.numbers(k, t, 2); s.prior_x = v[0], s.prior_y = v[1]; }},
                                      {"sigma", [&](N k, S t) { auto v = r.numbers(k, t, 2); s.prior_sigma_x = v[0], s.prior_sigma_y = v[1]; }}});
                       }},
                      {"kernel_mass", [&](N m, S q) { s.kernel_mass = r.number(m, q); }}});
       }},
      {"helicopters", [&](N n, S p) {
         r.map(n, p, {{"speed", [&](N m, S q) { s.heli_speed = r.number(m, q); }},
                      {"turn_coefficient", [&](N m, S q) { s.turn_coefficient = r.number(m, q); }},
                      {"max_turn", [&](N m, S q) { s.max_turn = r.number(m, q); }},
                      {"start", [&](N m, S q) {
                         if (!m.IsSequence() || m.size() < 1 || m.size() > std::size_t(kMaxHelicopters))
                           bad(r.what(), q, Reader::kind(m), fmt::format("a list of 1 to {} [x, y, heading] entries", kMaxHelicopters));
                         s.helicopters.clear();
                         for (std::size_t i = 0; i < m.size(); ++i) {
                           auto v = r.numbers(m[i], fmt::format("{}[{}]", q, i), 3);
                           s.helicopters.push_back({v[0], v[1], v[2]});
                         }
                       }}});
       }},
      {"sensor", [&](N n, S p) {
         r.map(n, p, {{"detection", [&](N m, S q) {
                         r.map(m, q, {{"max", [&](N k, S t) { s.detection_max = r.number(k, t); }},
                                      {"spread", [&](N k, S t) { s.detection_spread = r.number(k, t); }}});
                       }},
                      {"noise", [&](N m, S q) {
                         r.map(m, q, {{"min", [&](N k, S t) { s.noise_min = r.number(k, t); }},
                                      {"per_km", [&](N k, S t) { s.noise_per_km = r.number(k, t); }}});
                       }}});
       }},
      {"control", [&](N n, S p) {
         r.map(n, p, {{"turns", [&](N m, S q) { s.control_turns = r.integer(m, q, 1, 101); }},
                      {"lookahead", [&](N m, S q) { s.control_lookahead = r.integer(m, q, 1, 1000); }}});
       }},
      {"fusion", [&](N n, S p) {
         r.map(n, p, {{"rule", [&](N m, S q) {
                         const std::string t = r.text(m, q);
                         try {
                           s.rule = parse_rule(t);
                         } catch (const InputError&) {
                           bad(r.what(), q, "'" + t + "'", "none, observation, belief or loglinear");
                         }
                       }},
                      {"interval", [&](N m, S q) { s.interval = r.integer(m, q, 1, kMaxSteps); }}});
       }},
      {"link", [&](N n, S p) {
         r.map(n, p, {{"enabled", [&](N m, S q) { s.link_enabled = r.flag(m, q); }},
                      {"bandwidth_mbps", [&](N m, S q) { s.bandwidth_mbps = r.number(m, q); }},
                      {"latency_ms", [&](N m, S q) { s.latency_ms = r.number(m, q); }},
                      {"sleep", [&](N m, S q) { s.link_sleep = r.flag(m, q); }}});
       }},
      {"backend", [&](N n, S p) { s.backend = r.text(n, p); }},
      {"seed", [&](N n, S p) { s.seed = static_cast<std::uint64_t>(r.integer(n, p, 0, std::int64_t{1} << 53)); }},
  });
}

}  // namespace

std::string to_string(Rule r) {
  switch (r) {
    case Rule::none: return "none";
    case Rule::observation: return "observation";
    case Rule::belief: return "belief";
    case Rule::loglinear: return "loglinear";
  }
  return "?";
}

Rule parse_rule(const std::string& text) {
  for (Rule r : {Rule::none, Rule::observation, Rule::belief, Rule::loglinear})
    if (to_string(r) == text) return r;
  throw InputError(fmt::format("fusion rule '{}' is unknown; give none, observation, belief or loglinear", text));
}

void validate(const Scenario& s) {
  const std::string w = "scenario '" + s.name + "'";
  for (auto [f, v] : {std::pair{"area.x[0]", s.x_min}, {"area.x[1]", s.x_max}, {"area.y[0]", s.y_min},
                      {"area.y[1]", s.y_max}, {"target.speed.mean", s.target_speed_mean},
                      {"target.heading.mean", s.target_heading_mean}, {"target.prior.mean[0]", s.prior_x},
                      {"target.prior.mean[1]", s.prior_y}})
    finite(w, f, v);
  if (!(s.x_max > s.x_min)) bad(w, "area.x", fmt::format("[{}, {}]", s.x_min, s.x_max), "[min, max] with max > min");
  if (!(s.y_max > s.y_min)) bad(w, "area.y", fmt::format("[{}, {}]", s.y_min, s.y_max), "[min, max] with max > min");
  if (s.nx < 1 || s.ny < 1 || s.nx > 65536 || s.ny > 65536 || s.nx * s.ny > kMaxCells)
    bad(w, "area.cells", fmt::format("[{}, {}]", s.nx, s.ny), fmt::format("whole numbers >= 1 with at most {} cells", kMaxCells));
  positive(w, "time.step", s.step_time);
  if (s.steps < 1 || s.steps > kMaxSteps) bad(w, "time.steps", std::to_string(s.steps), fmt::format("1 to {}", kMaxSteps));
  positive(w, "target.speed.mean", s.target_speed_mean);
  positive(w, "target.speed.sigma", s.target_speed_sigma);
  positive(w, "target.heading.sigma", s.target_heading_sigma);
  positive(w, "target.prior.sigma[0]", s.prior_sigma_x);
  positive(w, "target.prior.sigma[1]", s.prior_sigma_y);
  if (!(s.kernel_mass > 0 && s.kernel_mass < 1)) bad(w, "target.kernel_mass", show(s.kernel_mass), "a fraction in (0, 1)");
  positive(w, "helicopters.speed", s.heli_speed);
  positive(w, "helicopters.turn_coefficient", s.turn_coefficient);
  positive(w, "helicopters.max_turn", s.max_turn);
  if (s.helicopters.empty()) bad(w, "helicopters.start", "empty", "at least one [x, y, heading]");
  for (std::size_t i = 0; i < s.helicopters.size(); ++i) {
    const auto& h = s.helicopters[i];
    if (!std::isfinite(h.x) || !std::isfinite(h.y) || !std::isfinite(h.heading))
      bad(w, fmt::format("helicopters.start[{}]", i), fmt::format("[{}, {}, {}]", h.x, h.y, h.heading), "finite numbers");
  }
  in_range(w, "sensor.detection.max", s.detection_max, 0, 1, "a probability in [0, 1]");
  positive(w, "sensor.detection.spread", s.detection_spread);
  positive(w, "sensor.noise.min", s.noise_min);
  non_negative(w, "sensor.noise.per_km", s.noise_per_km);
  if (s.control_turns < 1 || s.control_turns > 101) bad(w, "control.turns", std::to_string(s.control_turns), "1 to 101");
  if (s.control_lookahead < 1 || s.control_lookahead > 1000)
    bad(w, "control.lookahead", std::to_string(s.control_lookahead), "1 to 1000");
  if (s.interval < 1) bad(w, "fusion.interval", std::to_string(s.interval), "a whole number >= 1");
  positive(w, "link.bandwidth_mbps", s.bandwidth_mbps);
  non_negative(w, "link.latency_ms", s.latency_ms);
  // The prior must put mass on the grid.
  if (s.prior_x < s.x_min || s.prior_x > s.x_max || s.prior_y < s.y_min || s.prior_y > s.y_max)
    bad(w, "target.prior.mean", fmt::format("[{}, {}]", s.prior_x, s.prior_y), "a point inside the area");
}

Scenario parse_scenario(const std::string& text, const std::string& what) {
  // yaml-cpp recurses once per level of nesting: refuse deep nesting before it parses (a scenario
  // is 4 levels deep). Flow brackets outside quotes, and indentation, both count.
  {
    int depth = 0, top = 0;
    char quote = 0;
    std::size_t indent = 0;
    bool line_start = true;
    for (char c : text) {
      if (c == '\n') line_start = true, indent = 0, quote = 0;
      else if (line_start && c == ' ') ++indent;
      else line_start = false;
      if (indent > 64) throw InputError(fmt::format("{}: indented more than 64 spaces; a scenario is at most a few levels deep", what));
      if (quote) {
        if (c == quote) quote = 0;
        continue;
      }
      if (c == '"' || c == '\'') quote = c;
      else if (c == '[' || c == '{') top = std::max(top, ++depth);
      else if (c == ']' || c == '}') --depth;
      if (top > 16) throw InputError(fmt::format("{}: nested more than 16 levels deep; a scenario is at most a few", what));
    }
  }
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}: not YAML ({}, line {}); fix the file", what, e.msg, e.mark.line + 1));
  }
  Scenario s;
  Reader r(what);
  read_into(s, root, r);
  if (s.helicopters.empty()) bad(what, "helicopters.start", "missing", "a list of [x, y, heading] entries");
  try {
    validate(s);
  } catch (const InputError& e) {
    // Name the file rather than the scenario.
    std::string m = e.what();
    const std::string prefix = "scenario '" + s.name + "'";
    if (m.rfind(prefix, 0) == 0) m = what + m.substr(prefix.size());
    throw InputError(m);
  }
  return s;
}

Scenario load_scenario(const std::string& path) {
  const std::string what = fmt::format("scenario '{}'", path);
  return parse_scenario(read_file_limited(path, what, kMaxScenarioBytes), what);
}

std::uint64_t team_digest(const Scenario& s) {
  // FNV-1a over the fields' text: stable across processes and machines.
  std::string t = fmt::format(
      "{:.17g} {:.17g} {:.17g} {:.17g} {} {} {:.17g} {} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} "
      "{:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {} {} {} {} {} {:.17g} {:.17g} {}",
      s.x_min, s.x_max, s.y_min, s.y_max, s.nx, s.ny, s.step_time, s.steps, s.target_speed_mean,
      s.target_speed_sigma, s.target_heading_mean, s.target_heading_sigma, s.prior_x, s.prior_y, s.prior_sigma_x,
      s.prior_sigma_y, s.kernel_mass, s.heli_speed, s.turn_coefficient, s.max_turn, s.detection_max,
      s.detection_spread, s.noise_min, s.noise_per_km, s.control_turns, s.control_lookahead, to_string(s.rule),
      s.interval, s.link_enabled, s.bandwidth_mbps, s.latency_ms, s.seed);
  for (const auto& h : s.helicopters) t += fmt::format(" {:.17g} {:.17g} {:.17g}", h.x, h.y, h.heading);
  std::uint64_t h = 1469598103934665603ULL;
  for (unsigned char c : t) h = (h ^ c) * 1099511628211ULL;
  return h;
}

}  // namespace dtflop::sar
