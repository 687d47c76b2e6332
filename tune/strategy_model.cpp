// The `model` strategy (docs/tune.md): rank every valid configuration by its prediction; first
// measure the best-ranked of each group (Candidate::group: a backend with its choices, whose
// predictions share one bias), so every group's predictions can be corrected by a measurement of
// it; then measure the best by corrected prediction, correct, re-rank, until the measured best
// stops improving or nothing left can beat it.
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <fmt/format.h>

#include "tune/tuner.hpp"

namespace dtflop::tune {

namespace {

double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

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
    return pick;
  }
  std::string stop_reason() const override { return reason_.empty() ? Strategy::stop_reason() : reason_; }

 private:
  StrategyOptions o_;
  std::string reason_;
  std::size_t explored_ = 0;  // measurements of phase 1
};

}  // namespace

std::unique_ptr<Strategy> make_model_strategy(const StrategyOptions& o) { return std::make_unique<ModelStrategy>(o); }

}  // namespace dtflop::tune
