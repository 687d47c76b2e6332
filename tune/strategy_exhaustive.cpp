// The `exhaustive` strategy: every valid configuration, in the order the space enumerates them.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "tune/tuner.hpp"

namespace dtflop::tune {

namespace {

class ExhaustiveStrategy final : public Strategy {
 public:
  std::optional<std::size_t> next(const SearchState& s) override {
    for (std::size_t i = 0; i < s.candidates.size(); ++i)
      if (!s.candidates[i].done()) return i;
    return std::nullopt;
  }
};

}  // namespace

std::unique_ptr<Strategy> make_exhaustive_strategy(const StrategyOptions&) {
  return std::make_unique<ExhaustiveStrategy>();
}

}  // namespace dtflop::tune
