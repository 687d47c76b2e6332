// The team's network behind the workload contract ("sar-net") (workloads/workload.hpp), so that samples of
// the team's own MPI exchanges go through the generic store, `dtflop calibrate` (L_net, B_net)
// and `dtflop validate`. One backend, "mpi" (the transport of sar/team_mpi.cpp); a step is one
// exchange: every process sends one message of `bytes` to each of the `team` - 1 others:
//   net_messages = team - 1,  net_bytes = (team - 1) bytes   (docs/model.md 2.8)
// Its samples are measured by the team itself, under mpirun (`mpirun -n N dtflop sar --scenario
// FILE --exchange-sweep --store FILE`): `dtflop sweep` cannot start a team, so prepare() and
// plan() say so.
#pragma once

#include "workloads/workload.hpp"

namespace dtflop::sar {

const workload::Workload& net_workload();

}  // namespace dtflop::sar
