// Rounds: `dtflop sweep --rounds R` measures every configuration of a plan R times, in R
// interleaved passes over the plan (round 1 measures every configuration once, then round 2,
// ...). The machines' speed drifts over seconds to a minute (a shared host, clocks), and a
// sample's repetitions are back to back, so one slow spell moves a whole sample; rounds spread
// a configuration's measurements over the whole sweep, and its fastest round is the machine
// undisturbed (kDefaultRoundCombine below).
//
// In the store every round is a sample of its own: round 1 keeps the configuration's plain key
// (so stores measured before rounds existed stay valid), round r >= 2 has the key
// "<key>/round=r" and the field "round": r. calibrate and validate merge the rounds of each
// configuration into one sample (merge_rounds) right after reading the stores.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "calibrate/sample.hpp"

namespace dtflop::calib {

// The store key of round `round` (>= 1) of the configuration `key`: `key` itself for round 1,
// "<key>/round=<round>" after.
std::string round_key(const std::string& key, int round);

// The configuration's key: `key` without a trailing "/round=N" (N a positive integer).
std::string base_key(const std::string& key);

// Which value of a configuration's rounds stands for it (its Stats' `median`; min, max,
// quartiles and values still describe all the rounds), each measured component on its own:
//  median  - the median of the rounds' medians: robust to one disturbed round in three;
//  fastest - the fastest round's median. Interference from outside (co-tenants of a shared
//            host, another process) only ever adds time, so on a machine whose slow spells
//            can cover most of a configuration's rounds the fastest round is the best estimate
//            of what the machine does undisturbed, which is what the model describes;
//  p25     - the lower quartile of the rounds' medians (type 7: with 3 rounds halfway between
//            the fastest and the median, with 5 the second fastest).
enum class RoundCombine { median, fastest, p25 };
// The rule calibrate and validate use unless told otherwise: the fastest round, on every
// machine. Interference only adds time; on the shared 2-vCPU VM most rounds fall in slow spells
// and the median and the lower quartile each miss the targets on one of its two backends; on
// the H200 the rules differ by under a point of mean error.
// The evidence (held-out errors of every stored experiment under each rule): docs/calibration.md,
// "Combining the rounds", and results/rounds/.
inline constexpr RoundCombine kDefaultRoundCombine = RoundCombine::fastest;
std::string_view to_string(RoundCombine c);
std::optional<RoundCombine> round_combine_from_string(std::string_view s);
// The same for a command-line value: throws InputError naming `--rounds-combine` and the choices.
RoundCombine parse_round_combine(std::string_view s);

struct MergedRounds {
  std::vector<Sample> samples;        // one per configuration, in the order first met
  std::vector<std::string> warnings;  // duplicated samples, rounds that cannot be merged
  int input = 0;                      // samples given
  int min_rounds = 0;                 // fewest and most rounds of a configuration (0 when none)
  int max_rounds = 0;
  RoundCombine combine = kDefaultRoundCombine;
  // The machine's drift between rounds: the standard deviation of log(a round's total) about its
  // configuration's mean, pooled over the configurations of two or more rounds (the squares summed
  // over all of them, over the rounds less one each); round_configs counts them (0: none, and
  // round_log_sd 0). Rounds are minutes apart, so this is how far one measurement of a
  // configuration moves with the machine's state, which a fit's cross-validation cannot see.
  double round_log_sd = 0;
  int round_configs = 0;

  // "82 configurations from 246 samples (3 rounds)"; "(1-3 rounds)" when they differ.
  std::string summary() const;
  // "; a configuration's time is its fastest round's median" (or "... the median of its rounds'
  // medians", "... the lower quartile of its rounds' medians"); empty when no configuration has
  // more than one round.
  std::string how() const;
};

// Groups the samples of one configuration (same key once the "/round=N" suffix is removed, same
// machine (same_machine), same workload and backend) and returns one sample per configuration:
//  - a configuration with one round is returned unchanged;
//  - with several, the sample of its first round (the lowest round number) with, for each
//    measured component, Stats over the rounds' medians (values: the rounds' medians in round
//    order; the median is the value `combine` picks from them: the fastest round's, the median
//    of the medians or their lower quartile, each component on its own; min/max/p25/p75 are
//    over them), the configuration's key (no round suffix), round 1, and detail "rounds" (how
//    many were merged), "rounds_combined_by", "round_spread" ((max - min) / median of the
//    rounds' totals) and "repetitions_per_round".
// Two samples of the same configuration and round (a line stored twice, a store named twice):
// the first is kept, with a warning. A round measured with other steps per repetition than the
// first round is left out, with a warning (its times are not comparable); rounds whose cost
// counts differ (measured by different dtflop versions) are merged with the first round's
// counts, with a warning.
MergedRounds merge_rounds(std::vector<Sample> samples, RoundCombine combine = kDefaultRoundCombine);

}  // namespace dtflop::calib
