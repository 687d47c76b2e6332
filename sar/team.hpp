// The team runtime of `dtflop sar`: each helicopter is one MPI process (rank r flies helicopter
// r of the scenario). Beliefs and observations travel as MPI messages; the link model (sar/
// fusion.hpp) adds its delay to the physical time of a step and, with `link.sleep`, to the wall
// time too.
//
// Every rank writes its own records as it goes (so a lost rank leaves the others' results),
// rank 0 gathers the team's series and summary at the end of each run.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "sar/scenario.hpp"

namespace dtflop::sar {

struct TeamOptions {
  std::string out;                     // output folder (made if missing)
  std::vector<std::uint64_t> seeds;    // one run per seed (empty: the scenario's seed)
  bool records = true;                 // per-step records of every helicopter (heli-R.csv)
  std::vector<std::int64_t> snapshots; // steps at which rank 0 draws the team (PNG); 0 = the prior
  double peer_timeout = 60;            // s without a peer's message before it counts as lost
  int fail_rank = -1;                  // testing: this rank kills itself at fail_step
  std::int64_t fail_step = 0;
  bool quiet = false;
  int threads = 0;                     // cpu-par's threads per process (0: every hardware thread)
};

// Whether this build has the MPI runtime (DTFLOP_WITH_MPI).
bool have_mpi();

// A sweep over message sizes of the team's own exchange (the MPI transport the team's beliefs and
// observations travel by), to fit the network term (L_net, B_net) from real team exchanges: at
// each size every rank sends one message of that many bytes to every other and receives theirs,
// `exchanges` times in a repetition, after a barrier; a repetition's time is the slowest rank's.
struct ExchangeSweep {
  std::vector<std::int64_t> bytes;  // payload of one message, each size in turn
  int exchanges = 20;               // exchanges per repetition
  int repetitions = 5;
  int warmup = 1;                   // repetitions measured and dropped first
  double peer_timeout = 60;
};
struct ExchangeSample {
  std::int64_t bytes = 0;        // per message
  int team = 0;                  // processes
  int exchanges = 0;             // per repetition
  std::vector<double> seconds;   // per repetition, the slowest rank's wall time
};
// Runs the sweep in this process's MPI job (initializes and finalizes MPI). On rank 0, `begin`
// is called once before anything is measured (it may throw InputError: then every rank stops
// with status 2) and `sink` with each size's sample as soon as it is measured. Returns the exit
// status like run_team (2 for fewer than 2 processes).
int run_exchange_sweep(const ExchangeSweep& sweep, const std::function<void(int team)>& begin,
                       const std::function<void(const ExchangeSample&)>& sink);
// Runs the team in this process's MPI job (initializes and finalizes MPI). Returns the exit
// status: 0 done, 1 a rank was lost or a run failed, 2 bad input (the scenario against the
// job: helicopters against processes, processes that disagree on the scenario). Prints one
// line per problem on stderr (rank 0 for what every rank sees alike).
int run_team(const Scenario& s, const TeamOptions& o);

}  // namespace dtflop::sar
