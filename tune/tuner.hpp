// Model-guided autotuning (docs/tune.md): a scenario's space is enumerated and constrained (the
// workload's own checks, what this machine can run, the accuracy the application needs, the
// deadline judged against each prediction's interval), ranked by the DTFLOP model, and searched
// by a strategy that chooses what to measure next; every measurement goes through the caller's
// measure function (the sample store, so nothing is measured twice).
//
// The tuner knows no machine and no store: the CLI gives it a predict function (profile,
// calibrations, uncertainty) and a measure function (the protocol and the store).
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "tune/accuracy.hpp"
#include "tune/scenario.hpp"
#include "workloads/workload.hpp"

namespace dtflop::tune {

// A prediction of one step (frame) of a configuration, as the caller's predictor makes it.
struct Predicted {
  double seconds = 0;          // the model's value
  double lo = 0, hi = 0;       // its 90% interval
  double sigma = 0;            // standard deviation of log(time)
  std::string basis;           // probe-only, calibrated, transferred
  std::optional<double> p_met; // P(time <= deadline), when there is a deadline
  std::string verdict;         // met, missed, uncertain (empty without a deadline)
  std::string note;            // e.g. the variant it fell back to
};
using PredictFn = std::function<Predicted(const workload::Backend&, const workload::Config&)>;

struct Candidate {
  const workload::Backend* backend = nullptr;
  workload::Config config;
  std::string key;     // the store key (Workload::key)
  std::string label;   // backend and the parameters the space varies, for tables
  // The backend and its choice and flag parameters (host memory, convolution, interpolation,
  // graph; not those the counts price, ParamSpec::priced): configurations whose predictions
  // share a bias, corrected together by `model`.
  std::string group;
  AccuracyJudgement accuracy;
  Predicted predicted;
  std::optional<double> measured;  // seconds per step (median), once measured
  bool from_store = false;         // the measurement was already in the store
  std::string failure;             // why measuring it failed (then it has no time and is not chosen)
  bool done() const { return measured.has_value() || !failure.empty(); }
};

// Seconds per step (frame) of a candidate, and whether it was already stored. A measure function
// throws (std::exception) for a configuration that cannot run: the search records why and goes on.
struct Measurement {
  double seconds = 0;
  bool from_store = false;
};
using MeasureFn = std::function<Measurement(const Candidate&)>;

// The space after its constraints.
struct Space {
  std::vector<Candidate> valid;
  std::size_t enumerated = 0;
  // How many configurations each constraint removed, and one example of its reason.
  std::map<std::string, std::size_t> removed;
  std::map<std::string, std::string> example;
  void remove(const std::string& constraint, const std::string& reason);
};

// Enumerates every backend x axis-value combination of the scenario (axes that do not apply to a
// backend are left out for it), validates each through the workload (constraint "parameters"),
// drops backends this machine cannot run when `unavailable` says so (constraint "backend"),
// judges accuracy (the model's constraints), then predicts the rest and drops those whose
// deadline verdict is `missed` (constraint "deadline": missed with the scenario's confidence,
// judged on the interval, not only on the centre). Progress lines go to `progress` unless null.
// Throws InputError naming the constraints and what they removed when nothing is left.
Space constrain(const Scenario& s, const workload::Workload& w, AccuracyModel& accuracy,
                const std::function<std::string(const workload::Backend&)>& unavailable, const PredictFn& predict,
                std::FILE* progress);

// ---- Strategies ---------------------------------------------------------------------------

// What a strategy sees: every valid candidate (measured ones carry their time) and the order in
// which they were measured.
struct SearchState {
  const std::vector<Candidate>& candidates;
  const std::vector<std::size_t>& measured;  // indices, in measurement order
  std::size_t budget = 0;
};

class Strategy {
 public:
  virtual ~Strategy() = default;
  // The candidate to measure next, or none to stop (why: stop_reason()).
  virtual std::optional<std::size_t> next(const SearchState& s) = 0;
  virtual std::string stop_reason() const { return "every valid configuration was measured"; }
};

struct StrategyOptions {
  std::uint64_t seed = 1;
  // model: stop when this many measurements in a row did not improve the best by 1%, ...
  int patience = 6;
  // ... or when no unmeasured candidate beats the measured best with at least this probability.
  double min_chance = 0.02;
};

struct StrategyInfo {
  std::string_view name;
  std::string_view description;
  std::unique_ptr<Strategy> (*make)(const StrategyOptions&);
};
// The registered strategies, in --help order (tune/strategies.cpp holds the one list).
const std::vector<StrategyInfo>& strategies();
// Throws InputError naming the strategies when `name` is unknown.
const StrategyInfo& find_strategy(std::string_view name);
std::string strategy_names();

std::unique_ptr<Strategy> make_model_strategy(const StrategyOptions& o);
std::unique_ptr<Strategy> make_exhaustive_strategy(const StrategyOptions& o);
std::unique_ptr<Strategy> make_random_strategy(const StrategyOptions& o);

// The model strategy's correction of a candidate's prediction by what was measured: the
// geometric mean of measured / predicted over the measured candidates of its group
// (Candidate::group), 1 for a group nothing was measured of; and the scatter (standard
// deviation of log(measured / predicted)) in that group, or the prediction's own sigma.
struct Correction {
  double factor = 1;
  double sigma = 0;
  int measured = 0;
};
std::map<std::string, Correction> corrections(const std::vector<Candidate>& candidates,
                                              const std::vector<std::size_t>& measured);

// ---- A tuning -----------------------------------------------------------------------------

struct Search {
  std::vector<std::size_t> order;  // measured (or failed), in order
  std::string stop_reason;
  int failed = 0;
};
// Runs `strategy` over `space` (measuring with `measure`, at most `budget` candidates: 0 means no
// limit) and records each measurement in the candidates; a candidate whose measurement throws
// gets the message as its failure and counts against the budget. Progress lines to `progress`
// unless null.
Search search(Space& space, Strategy& strategy, std::size_t budget, const MeasureFn& measure, std::FILE* progress);

// The fastest measured candidate (`measured`), or by prediction the fastest whose deadline verdict
// is met (else the one most likely to meet it). None when nothing qualifies.
std::optional<std::size_t> fastest_measured(const std::vector<Candidate>& c);
std::optional<std::size_t> fastest_predicted(const std::vector<Candidate>& c, bool have_deadline);

// The Pareto front of time against the accuracy figure (both smaller-is-better) over the measured
// candidates (`measured`) or over every candidate by prediction: indices, fastest first.
std::vector<std::size_t> pareto_front(const std::vector<Candidate>& c, bool measured);

// ---- Replaying strategies on a fully measured space (the benchmark of docs/PERFORMANCE.md) ----

// After every valid candidate was measured: for each strategy, budget and seed, the fraction of
// the optimum it reached (optimum / best measured, in (0, 1]) replaying the stored times; the
// median over seeds per budget.
struct ReplayRow {
  std::string strategy;
  std::size_t budget = 0;
  std::vector<double> fractions;  // one per seed
  double median = 0;
  double measured_median = 0;     // measurements the strategy used (it may stop before the budget)
};
std::vector<ReplayRow> replay(const Space& space, const std::vector<std::string>& strategies,
                              const std::vector<std::size_t>& budgets, int seeds);

}  // namespace dtflop::tune
