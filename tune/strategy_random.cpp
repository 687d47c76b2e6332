// The `random` strategy: valid configurations in a random order drawn from the seed, the baseline
// every guided search is judged against.
#include <algorithm>
#include <cmath>
#include <random>

#include <fmt/format.h>

#include "tune/tuner.hpp"

namespace dtflop::tune {

namespace {

class RandomStrategy final : public Strategy {
 public:
  explicit RandomStrategy(const StrategyOptions& o) : rng_(o.seed) {}
  std::optional<std::size_t> next(const SearchState& s) override {
    if (order_.empty()) {
      order_.resize(s.candidates.size());
      for (std::size_t i = 0; i < order_.size(); ++i) order_[i] = i;
      // Fisher-Yates with a platform-independent draw.
      for (std::size_t i = order_.size(); i > 1; --i) {
        const std::uint64_t span = i, limit = UINT64_MAX - UINT64_MAX % span;
        std::uint64_t x;
        do x = rng_();
        while (x >= limit);
        std::swap(order_[i - 1], order_[x % span]);
      }
    }
    while (at_ < order_.size())
      if (!s.candidates[order_[at_++]].done()) return order_[at_ - 1];
    return std::nullopt;
  }

 private:
  std::mt19937_64 rng_;
  std::vector<std::size_t> order_;
  std::size_t at_ = 0;
};

}  // namespace

std::unique_ptr<Strategy> make_random_strategy(const StrategyOptions& o) { return std::make_unique<RandomStrategy>(o); }

}  // namespace dtflop::tune
