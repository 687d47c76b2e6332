// The one list of search strategies. Adding one is a file (strategy_<name>.cpp with its
// make_<name>_strategy) and one line here.
#include <fmt/format.h>

#include "model/errors.hpp"
#include "tune/tuner.hpp"

namespace dtflop::tune {

const std::vector<StrategyInfo>& strategies() {
  static const std::vector<StrategyInfo> list = {
      {"model",
       "rank by the model's prediction, measure the best-ranked, correct each backend's predictions by what was "
       "measured of it, re-rank; stop when the measured best stops improving or nothing left can beat it",
       make_model_strategy},
      {"exhaustive", "measure every valid configuration", make_exhaustive_strategy},
      {"random", "measure valid configurations in a random order (--seed)", make_random_strategy},
  };
  return list;
}

const StrategyInfo& find_strategy(std::string_view name) {
  for (const auto& s : strategies())
    if (s.name == name) return s;
  throw InputError(fmt::format("unknown strategy '{}'; use one of {}", name, strategy_names()));
}

std::string strategy_names() {
  std::string s;
  for (const auto& x : strategies()) s += (s.empty() ? "" : ", ") + std::string(x.name);
  return s;
}

}  // namespace dtflop::tune
