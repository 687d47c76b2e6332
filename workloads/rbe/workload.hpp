// The grid-based RBE workload behind the workload contract (workloads/workload.hpp): its
// parameter space, its four backends (backend.hpp), the seed's sweep plans and random plans.
#pragma once

#include "workloads/workload.hpp"

namespace dtflop::rbe {

const workload::Workload& workload();

}  // namespace dtflop::rbe
