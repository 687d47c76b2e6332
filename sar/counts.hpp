// The cost counts of a team step (one helicopter's step; every helicopter does the same work),
// for the DTFLOP model: its RBE backend's step, the likelihoods, the fusion's arithmetic, the
// the estimate and the control's sums where the belief lives, and the messages (net_messages, net_bytes: the network
// term, docs/model.md 2.8). Belief fusion happens every `interval` steps, so the counts are of
// one period of `interval` steps (one step for observation fusion and none).
#pragma once

#include <cstdint>
#include <string>

#include "model/cost_counts.hpp"
#include "sar/scenario.hpp"
#include "workloads/rbe/backend.hpp"

namespace dtflop::sar {

// FLOPs per cell of a likelihood (distance, a Gaussian's exponent, exp ~ 12 FLOPs).
inline constexpr std::int64_t kLikelihoodFlopsPerCell = 20;

struct TeamCounts {
  CostCounts rbe;      // the RBE backend's steps of the period and, where beliefs are fused, its
                       // fusion and wire belief (fusion_counts.hpp; the backend's own precision)
  CostCounts host;     // the host's float64 work of the period: likelihoods, observation fusion
  CostCounts summary;  // the estimate and the control's footprint sums of the period, where the
                       // belief lives (Backend::summarize, summary_counts.hpp), for a helicopter
                       // whose look-ahead windows lie inside the grid (one at its centre)
  CostCounts net;      // the period's messages
  std::int64_t steps = 1;  // steps in the period
  rbe::Shape shape;    // grid and kernel of a step
};
// Throws InputError for a bad scenario or backend.
TeamCounts team_counts(const Scenario& s, std::int64_t team, const rbe::BackendOptions& options = {});

}  // namespace dtflop::sar
