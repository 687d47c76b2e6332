// The `model` strategy (docs/tune.md): rank every valid configuration by its prediction; first
// measure the best-ranked of each group (Candidate::group: a backend with its choices, whose
// predictions share one bias), so every group's predictions can be corrected by a measurement of
// it; then give each group whose correction rests on that one measurement a second look where the
// model cannot rank its configurations (they tie); then measure the best by corrected prediction,
// correct, re-rank, until the measured best stops improving or nothing left can beat it.
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <fmt/format.h>

#include "tune/tuner.hpp"

namespace dtflop::tune {

namespace {

double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

// Two predictions the model cannot separate: within 0.1% of each other, the same counts up to a few
// operations (a block layout changes no count; the weight functions differ by a few FLOPs per dot).
constexpr double kTie = 1e-3;
bool ties(double a, double b) { return std::abs(std::log(a / b)) < kTie; }

// How many of a configuration's parameters differ from another's.
int differences(const workload::Config& a, const workload::Config& b) {
  int n = 0;
  for (auto it = a.begin(); it != a.end(); ++it)
    if (!b.contains(it.key()) || b[it.key()] != it.value()) ++n;
  return n;
}

// Rank by prediction corrected by what was measured of the candidate's group; stop when the
// measured best has not improved by 1% over `patience` measurements, or when no unmeasured
// candidate has a chance >= min_chance of beating it.
class ModelStrategy final : public Strategy {
 public:
  explicit ModelStrategy(const StrategyOptions& o) : o_(o) {}
  std::optional<std::size_t> next(const SearchState& s) override {
    const auto corr = corrections(s.candidates, s.measured);
    // Phase 1: a group nothing was measured of gets its best-ranked configuration measured.
    // A group whose configurations failed and none ran is not explored further: its others would
    // likely fail the same way (a group that ran has only its failed configurations left out).
    std::set<std::string> failed;
    for (std::size_t i : s.measured)
      if (!s.candidates[i].failure.empty() && !corr.count(s.candidates[i].group)) failed.insert(s.candidates[i].group);
    {
      std::map<std::string, std::size_t> first;
      for (std::size_t i = 0; i < s.candidates.size(); ++i) {
        const Candidate& c = s.candidates[i];
        if (corr.count(c.group) || failed.count(c.group) || c.done()) continue;
        auto [it, added] = first.emplace(c.group, i);
        if (!added && c.predicted.seconds < s.candidates[it->second].predicted.seconds) it->second = i;
      }
      std::optional<std::size_t> pick;
      for (const auto& [g, i] : first)
        if (!pick || s.candidates[i].predicted.seconds < s.candidates[*pick].predicted.seconds) pick = i;
      if (pick) {
        explored_ = s.measured.size() + 1;
        return pick;
      }
    }
    // Phase 2: a group's correction from one measurement cannot tell the group's bias from that
    // configuration's own deviation in what the model does not price (a block layout, say). A group
    // whose best-ranked configurations tie gets a second look: the tied configuration that differs
    // most from the one measured. Groups in the order of their corrected predictions.
    {
      std::map<std::string, std::vector<std::size_t>> ran;
      for (std::size_t i : s.measured)
        if (s.candidates[i].measured) ran[s.candidates[i].group].push_back(i);
      std::optional<std::size_t> pick;
      double pick_score = INFINITY;
      for (const auto& [g, v] : ran) {
        if (v.size() != 1 || looked_.count(g)) continue;
        const Candidate& first = s.candidates[v[0]];
        std::optional<std::size_t> look;
        int look_diff = -1;
        for (std::size_t i = 0; i < s.candidates.size(); ++i) {
          const Candidate& c = s.candidates[i];
          if (c.group != g || c.done() || !ties(c.predicted.seconds, first.predicted.seconds)) continue;
          const int d = differences(c.config, first.config);
          if (d > look_diff || (d == look_diff && c.predicted.seconds < s.candidates[*look].predicted.seconds)) {
            look = i;
            look_diff = d;
          }
        }
        if (!look) {
          looked_.insert(g);  // nothing ties with what was measured: the ranking separates the rest
          continue;
        }
        const double score = s.candidates[*look].predicted.seconds * corr.at(g).factor;
        if (score < pick_score) {
          pick = look;
          pick_score = score;
        }
      }
      if (pick) {
        looked_.insert(s.candidates[*pick].group);
        explored_ = s.measured.size() + 1;
        return pick;
      }
    }
    double best = INFINITY;
    std::size_t since = 0;
    for (std::size_t k = 0; k < s.measured.size(); ++k) {
      if (!s.candidates[s.measured[k]].measured) continue;  // failed
      const double m = *s.candidates[s.measured[k]].measured;
      if (k < explored_) {  // the groups' first measurements set the best; patience counts after them
        best = std::min(best, m);
        continue;
      }
      if (m < best * 0.99) {
        best = m;
        since = 0;
      } else {
        best = std::min(best, m);
        ++since;
      }
    }
    if (!s.measured.empty() && since >= static_cast<std::size_t>(o_.patience)) {
      reason_ = fmt::format("the measured best did not improve by 1% over the last {} measurements", o_.patience);
      return std::nullopt;
    }
    std::optional<std::size_t> pick;
    double pick_score = INFINITY, chance_max = 0;
    for (std::size_t i = 0; i < s.candidates.size(); ++i) {
      const Candidate& c = s.candidates[i];
      if (c.done() || failed.count(c.group)) continue;
      double score = c.predicted.seconds, sigma = c.predicted.sigma;
      if (auto it = corr.find(c.group); it != corr.end()) {
        score *= it->second.factor;
        sigma = it->second.sigma;
      }
      if (std::isfinite(best)) {
        const double chance = sigma > 0 ? normal_cdf(std::log(best / score) / sigma) : (score < best ? 1.0 : 0.0);
        chance_max = std::max(chance_max, chance);
      }
      if (score < pick_score) {
        pick_score = score;
        pick = i;
      }
    }
    if (pick && std::isfinite(best) && chance_max < o_.min_chance) {
      reason_ = fmt::format("no unmeasured configuration beats the measured best with a chance of {:.0f}% or more "
                            "(corrected predictions and their scatter)",
                            100 * o_.min_chance);
      return std::nullopt;
    }
    if (!pick) return pick;
    // Configurations that tie with the best-ranked one are the same to the model: measure the one
    // whose parameter values were measured least in its group, so the measurements spread over what
    // the model cannot separate instead of walking through the ties in the order they were listed.
    std::map<std::string, std::set<std::string>> seen;  // group -> "parameter=value" measured
    for (std::size_t i : s.measured)
      if (s.candidates[i].measured)
        for (auto it = s.candidates[i].config.begin(); it != s.candidates[i].config.end(); ++it)
          seen[s.candidates[i].group].insert(it.key() + "=" + it.value().dump());
    auto novelty = [&](const Candidate& c) {
      int n = 0;
      const auto it = seen.find(c.group);
      for (auto p = c.config.begin(); p != c.config.end(); ++p)
        if (it == seen.end() || !it->second.count(p.key() + "=" + p.value().dump())) ++n;
      return n;
    };
    std::size_t chosen = *pick;
    int chosen_novelty = novelty(s.candidates[chosen]);
    double chosen_score = pick_score;
    for (std::size_t i = 0; i < s.candidates.size(); ++i) {
      const Candidate& c = s.candidates[i];
      if (i == *pick || c.done() || failed.count(c.group)) continue;
      double score = c.predicted.seconds;
      if (auto it = corr.find(c.group); it != corr.end()) score *= it->second.factor;
      if (!ties(score, pick_score)) continue;
      const int n = novelty(c);
      if (n > chosen_novelty || (n == chosen_novelty && score < chosen_score)) {
        chosen = i;
        chosen_novelty = n;
        chosen_score = score;
      }
    }
    return chosen;
  }
  std::string stop_reason() const override { return reason_.empty() ? Strategy::stop_reason() : reason_; }

 private:
  StrategyOptions o_;
  std::string reason_;
  std::size_t explored_ = 0;  // measurements of phases 1 and 2
  std::set<std::string> looked_;  // groups given their second look (or with nothing to look at)
};

}  // namespace

std::unique_ptr<Strategy> make_model_strategy(const StrategyOptions& o) { return std::make_unique<ModelStrategy>(o); }

}  // namespace dtflop::tune
