#include "calibrate/rounds.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include <fmt/format.h>

#include "calibrate/machine.hpp"
#include "model/errors.hpp"

namespace dtflop::calib {

namespace {

constexpr std::string_view kRoundSuffix = "/round=";

}  // namespace

std::string round_key(const std::string& key, int round) {
  return round <= 1 ? key : fmt::format("{}{}{}", key, kRoundSuffix, round);
}

std::string base_key(const std::string& key) {
  const auto at = key.rfind(kRoundSuffix);
  if (at == std::string::npos) return key;
  const std::string digits = key.substr(at + kRoundSuffix.size());
  if (digits.empty() || digits.size() > 9 || digits.front() == '0' ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return key;
  return key.substr(0, at);
}

std::string MergedRounds::summary() const {
  const std::string rounds = min_rounds == max_rounds
                                 ? fmt::format("{} round{}", max_rounds, max_rounds == 1 ? "" : "s")
                                 : fmt::format("{}-{} rounds", min_rounds, max_rounds);
  return fmt::format("{} configuration{} from {} sample{} ({})", samples.size(), samples.size() == 1 ? "" : "s",
                     input, input == 1 ? "" : "s", rounds);
}

std::string_view to_string(RoundCombine c) {
  switch (c) {
    case RoundCombine::fastest: return "fastest";
    case RoundCombine::p25: return "p25";
    case RoundCombine::median: break;
  }
  return "median";
}

std::optional<RoundCombine> round_combine_from_string(std::string_view s) {
  if (s == "median") return RoundCombine::median;
  if (s == "fastest") return RoundCombine::fastest;
  if (s == "p25") return RoundCombine::p25;
  return std::nullopt;
}

RoundCombine parse_round_combine(std::string_view s) {
  if (auto c = round_combine_from_string(s)) return *c;
  throw InputError(fmt::format("--rounds-combine '{}' is unknown; use fastest, median or p25", s));
}

std::string MergedRounds::how() const {
  if (max_rounds <= 1) return "";
  switch (combine) {
    case RoundCombine::fastest: return "; a configuration's time is its fastest round's median";
    case RoundCombine::p25: return "; a configuration's time is the lower quartile of its rounds' medians";
    case RoundCombine::median: break;
  }
  return "; a configuration's time is the median of its rounds' medians";
}

MergedRounds merge_rounds(std::vector<Sample> samples, RoundCombine combine) {
  MergedRounds out;
  out.combine = combine;
  out.input = static_cast<int>(samples.size());

  // Configurations in the order first met; each with its rounds (by round number).
  struct Config {
    std::string key;  // without the round suffix
    std::vector<Sample> rounds;
  };
  std::vector<Config> configs;
  std::map<std::string, std::vector<std::size_t>> by_key;  // base key -> indices into configs
  for (auto& s : samples) {
    const std::string key = base_key(s.key);
    std::vector<std::size_t>& candidates = by_key[key];
    Config* cfg = nullptr;
    for (std::size_t i : candidates) {
      const Sample& first = configs[i].rounds.front();
      if (first.workload == s.workload && first.backend == s.backend && same_machine(first.machine, s.machine)) {
        cfg = &configs[i];
        break;
      }
    }
    if (!cfg) {
      candidates.push_back(configs.size());
      configs.push_back({key, {}});
      cfg = &configs.back();
    }
    const bool duplicate = std::any_of(cfg->rounds.begin(), cfg->rounds.end(),
                                       [&s](const Sample& r) { return r.round == s.round; });
    if (duplicate) {
      out.warnings.push_back(fmt::format("sample '{}' (round {} of '{}') appears more than once in the stores; "
                                         "keeping the first",
                                         s.key, s.round, key));
      continue;
    }
    cfg->rounds.push_back(std::move(s));
  }

  int counts_differ = 0;
  std::string counts_first;
  double drift_squares = 0;  // over every configuration of 2+ rounds: sum of (log t - mean log t)^2
  int drift_dof = 0;         // and of its rounds less one
  for (auto& cfg : configs) {
    std::stable_sort(cfg.rounds.begin(), cfg.rounds.end(),
                     [](const Sample& a, const Sample& b) { return a.round < b.round; });
    // Rounds timed with other steps per repetition than the first do not compare with it.
    const Sample& head = cfg.rounds.front();
    bool differ = false;
    for (auto it = cfg.rounds.begin() + 1; it != cfg.rounds.end();) {
      if (it->steps != head.steps) {
        out.warnings.push_back(fmt::format("round {} of '{}' ran {} steps per repetition, round {} ran {}; "
                                           "leaving round {} out",
                                           it->round, cfg.key, it->steps, head.round, head.steps, it->round));
        it = cfg.rounds.erase(it);
        continue;
      }
      if (!(it->counts == head.counts)) differ = true;
      ++it;
    }
    if (differ && counts_differ++ == 0) counts_first = cfg.key;

    const int n = static_cast<int>(cfg.rounds.size());
    out.min_rounds = out.samples.empty() ? n : std::min(out.min_rounds, n);
    out.max_rounds = std::max(out.max_rounds, n);
    if (n == 1) {
      out.samples.push_back(std::move(cfg.rounds.front()));
      continue;
    }

    Sample merged = cfg.rounds.front();
    merged.key = cfg.key;
    merged.round = 1;
    const int reps = merged.repetitions();
    merged.components.clear();
    double round_spread = 0;
    for (Component c : all_components()) {
      std::vector<double> medians;
      for (const auto& r : cfg.rounds)
        if (const Stats* st = r.find(c)) medians.push_back(st->median);
      if (medians.empty()) continue;
      Stats st = summarize(std::move(medians));
      if (c == Component::total) {
        round_spread = st.median > 0 ? (st.max - st.min) / st.median : 0.0;
        if (st.min > 0) {
          double mean = 0;
          for (double t : st.values) mean += std::log(t);
          mean /= static_cast<double>(st.values.size());
          for (double t : st.values) drift_squares += (std::log(t) - mean) * (std::log(t) - mean);
          drift_dof += static_cast<int>(st.values.size()) - 1;
          ++out.round_configs;
        }
      }
      // The value the model is compared with.
      if (combine == RoundCombine::fastest) st.median = st.min;
      if (combine == RoundCombine::p25) st.median = st.p25;
      merged.components[c] = std::move(st);
    }
    if (!merged.detail.is_object()) merged.detail = nlohmann::json::object();
    merged.detail["rounds"] = n;
    merged.detail["round_spread"] = round_spread;  // (slowest - fastest) / median of the rounds' totals
    merged.detail["rounds_combined_by"] = std::string(to_string(combine));
    merged.detail["repetitions_per_round"] = reps;
    out.samples.push_back(std::move(merged));
  }
  if (drift_dof > 0) out.round_log_sd = std::sqrt(drift_squares / drift_dof);
  if (counts_differ > 0)
    out.warnings.push_back(fmt::format(
        "{} configuration{} (first: '{}') {} rounds with different cost counts (measured by different dtflop "
        "versions?); merged with the first round's counts",
        counts_differ, counts_differ == 1 ? "" : "s", counts_first, counts_differ == 1 ? "has" : "have"));
  return out;
}

}  // namespace dtflop::calib
