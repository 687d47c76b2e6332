#include "tune/tuner.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/units.hpp"

namespace dtflop::tune {

void Space::remove(const std::string& constraint, const std::string& reason) {
  if (removed[constraint]++ == 0) example[constraint] = reason;
}

namespace {

std::string removed_text(const Space& sp) {
  std::string s;
  for (const auto& [c, n] : sp.removed)
    s += fmt::format("{}{} removed by {} (e.g. {})", s.empty() ? "" : "; ", n, c, sp.example.at(c));
  return s;
}

}  // namespace

Space constrain(const Scenario& s, const workload::Workload& w, AccuracyModel& accuracy,
                const std::function<std::string(const workload::Backend&)>& unavailable, const PredictFn& predict,
                std::FILE* progress) {
  Space sp;
  // Every axis and fixed parameter must be one of the workload's.
  for (const auto& a : s.axes)
    if (!w.find_param(a.param))
      throw InputError(fmt::format("scenario {}: space.{}: {} has no such parameter; its parameters are listed by "
                                   "`dtflop run {} --help`",
                                   s.file.string(), a.param, w.name(), w.name()));
  for (const auto& [k, _] : s.fixed)
    if (!w.find_param(k))
      throw InputError(fmt::format("scenario {}: fixed.{}: {} has no such parameter", s.file.string(), k, w.name()));
  std::vector<const workload::Backend*> backends;
  if (s.backends.empty())
    for (const auto& b : w.backends()) backends.push_back(b.get());
  else
    for (const auto& name : s.backends) backends.push_back(&w.backend(name));

  std::set<std::string> keys;
  std::vector<Candidate> accurate;
  for (const workload::Backend* b : backends) {
    std::vector<const Axis*> axes;
    for (const auto& a : s.axes)
      if (w.find_param(a.param)->applies_to(b->name())) axes.push_back(&a);
    nlohmann::json base = nlohmann::json::object();
    for (const auto& [k, v] : s.fixed)
      if (w.find_param(k)->applies_to(b->name())) base[k] = v;
    const std::string why_not = unavailable ? unavailable(*b) : std::string();
    // Odometer over the axes' values.
    std::vector<std::size_t> at(axes.size(), 0);
    for (bool more = true; more;) {
      nlohmann::json given = base;
      std::string label = b->name();
      for (std::size_t i = 0; i < axes.size(); ++i) {
        given[axes[i]->param] = axes[i]->values[at[i]];
        label += " " + axes[i]->param + "=" + axes[i]->values[at[i]];
      }
      ++sp.enumerated;
      more = false;
      for (std::size_t i = axes.size(); i-- > 0;) {
        if (++at[i] < axes[i]->values.size()) {
          more = true;
          break;
        }
        at[i] = 0;
      }
      if (!why_not.empty()) {
        sp.remove("backend", why_not);
        continue;
      }
      Candidate c;
      c.backend = b;
      try {
        c.config = w.validate(given, *b);
      } catch (const InputError& e) {
        sp.remove("parameters", fmt::format("{}: {}", label, e.what()));
        continue;
      }
      c.key = w.key(*b, c.config);
      if (!keys.insert(c.key).second) continue;  // the same configuration spelled twice
      c.label = label;
      c.group = b->name();
      for (const auto& p : w.params())
        if ((p.kind == workload::Kind::choice || p.kind == workload::Kind::flag) && !p.priced &&
            c.config.contains(p.name))
          c.group += fmt::format(" {}={}", p.name, c.config[p.name].dump());
      c.accuracy = accuracy.judge(*b, c.config);
      if (!c.accuracy.ok) {
        sp.remove(c.accuracy.constraint, fmt::format("{}: {}", label, c.accuracy.reason));
        continue;
      }
      accurate.push_back(std::move(c));
      if (progress && accurate.size() % 100 == 0)
        fmt::print(progress, "tune: {} configurations enumerated, {} pass the accuracy needs\n", sp.enumerated,
                   accurate.size());
    }
  }
  for (auto& c : accurate) {
    c.predicted = predict(*c.backend, c.config);
    if (c.predicted.verdict == "missed") {
      sp.remove("deadline",
                fmt::format("{}: predicted {} (90% {} .. {}), P(meets {}) = {:.3f}", c.label,
                            format_duration(c.predicted.seconds), format_duration(c.predicted.lo),
                            format_duration(c.predicted.hi), format_duration(s.deadline.value_or(0)),
                            c.predicted.p_met.value_or(0)));
      continue;
    }
    sp.valid.push_back(std::move(c));
  }
  if (sp.valid.empty())
    throw InputError(fmt::format("scenario {}: no configuration of the {} enumerated is left: {}; widen the space, "
                                 "relax the need that removed most, or use a faster machine",
                                 s.file.string(), sp.enumerated, removed_text(sp)));
  return sp;
}

// ---- Strategies -----------------------------------------------------------------------------

std::map<std::string, Correction> corrections(const std::vector<Candidate>& candidates,
                                              const std::vector<std::size_t>& measured) {
  std::map<std::string, std::vector<double>> logs;
  for (std::size_t i : measured) {
    const Candidate& c = candidates[i];
    if (c.measured && c.predicted.seconds > 0) logs[c.group].push_back(std::log(*c.measured / c.predicted.seconds));
  }
  std::map<std::string, Correction> out;
  for (const auto& [g, v] : logs) {
    double mean = 0;
    for (double x : v) mean += x;
    mean /= static_cast<double>(v.size());
    double var = 0;
    for (double x : v) var += (x - mean) * (x - mean);
    Correction c;
    c.factor = std::exp(mean);
    c.measured = static_cast<int>(v.size());
    // One measurement says nothing of the scatter: keep a 10% spread until a second one does.
    c.sigma = v.size() > 1 ? std::sqrt(var / static_cast<double>(v.size() - 1)) : 0.1;
    out[g] = c;
  }
  return out;
}

// ---- A tuning -------------------------------------------------------------------------------

Search search(Space& space, Strategy& strategy, std::size_t budget, const MeasureFn& measure, std::FILE* progress) {
  Search out;
  auto& c = space.valid;
  double best = INFINITY;
  while (budget == 0 || out.order.size() < budget) {
    const SearchState state{c, out.order, budget};
    const auto i = strategy.next(state);
    if (!i) {
      out.stop_reason = strategy.stop_reason();
      return out;
    }
    if (*i >= c.size() || c[*i].done())
      throw std::logic_error("tune: a strategy chose a configuration out of range or already measured");
    Measurement m;
    try {
      m = measure(c[*i]);
    } catch (const std::exception& e) {
      c[*i].failure = e.what();
      out.order.push_back(*i);
      ++out.failed;
      if (progress) fmt::print(progress, "tune: [{}] {}: failed: {}\n", out.order.size(), c[*i].label, e.what());
      continue;
    }
    if (!(m.seconds > 0) || !std::isfinite(m.seconds))
      throw std::runtime_error(fmt::format("tune: {} measured {} s per step", c[*i].label, m.seconds));
    c[*i].measured = m.seconds;
    c[*i].from_store = m.from_store;
    out.order.push_back(*i);
    best = std::min(best, m.seconds);
    if (progress)
      fmt::print(progress, "tune: [{}{}] {}: {} (predicted {}){}; best {}\n", out.order.size(),
                 budget ? fmt::format("/{}", budget) : "", c[*i].label, format_duration(m.seconds),
                 format_duration(c[*i].predicted.seconds), m.from_store ? " from the store" : "",
                 format_duration(best));
  }
  out.stop_reason = fmt::format("the budget of {} measurements is spent", budget);
  return out;
}

std::optional<std::size_t> fastest_measured(const std::vector<Candidate>& c) {
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (c[i].measured && (!best || *c[i].measured < *c[*best].measured)) best = i;
  return best;
}

std::optional<std::size_t> fastest_predicted(const std::vector<Candidate>& c, bool have_deadline) {
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (have_deadline && c[i].predicted.verdict != "met") continue;
    if (!best || c[i].predicted.seconds < c[*best].predicted.seconds) best = i;
  }
  if (best || !have_deadline) return best;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (!best || c[i].predicted.p_met.value_or(0) > c[*best].predicted.p_met.value_or(0)) best = i;
  return best;
}

std::vector<std::size_t> pareto_front(const std::vector<Candidate>& c, bool measured) {
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (!measured || c[i].measured) idx.push_back(i);
  auto time = [&](std::size_t i) { return measured ? *c[i].measured : c[i].predicted.seconds; };
  std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) {
    return time(a) != time(b) ? time(a) < time(b) : c[a].accuracy.error < c[b].accuracy.error;
  });
  std::vector<std::size_t> front;
  double best_error = INFINITY;
  for (std::size_t i : idx)
    if (c[i].accuracy.error < best_error) {
      front.push_back(i);
      best_error = c[i].accuracy.error;
    }
  return front;
}

std::vector<ReplayRow> replay(const Space& space, const std::vector<std::string>& names,
                              const std::vector<std::size_t>& budgets, int seeds) {
  double optimum = INFINITY;
  for (const auto& c : space.valid) {
    if (!c.done()) throw InputError("tune: replaying strategies needs every valid configuration measured");
    if (c.measured) optimum = std::min(optimum, *c.measured);
  }
  std::vector<ReplayRow> rows;
  for (const auto& name : names) {
    const StrategyInfo& info = find_strategy(name);
    for (std::size_t budget : budgets) {
      ReplayRow row{name, budget, {}, 0, 0};
      std::vector<double> used;
      for (int seed = 1; seed <= seeds; ++seed) {
        Space copy = space;
        for (auto& c : copy.valid) c.measured.reset();  // failures stay: they would fail again
        StrategyOptions o;
        o.seed = static_cast<std::uint64_t>(seed);
        auto strategy = info.make(o);
        const Search r = search(
            copy, *strategy, budget,
            [&](const Candidate& c) {
              return Measurement{*space.valid[static_cast<std::size_t>(&c - copy.valid.data())].measured, true};
            },
            nullptr);
        double best = INFINITY;
        for (std::size_t i : r.order)
          if (copy.valid[i].measured) best = std::min(best, *copy.valid[i].measured);
        row.fractions.push_back(optimum / best);
        used.push_back(static_cast<double>(r.order.size()));
      }
      auto median = [](std::vector<double> v) {
        std::sort(v.begin(), v.end());
        const std::size_t n = v.size();
        return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
      };
      row.median = median(row.fractions);
      row.measured_median = median(used);
      rows.push_back(std::move(row));
    }
  }
  return rows;
}

}  // namespace dtflop::tune
