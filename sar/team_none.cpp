// The team runtime where dtflop is built without MPI (DTFLOP_WITH_MPI=OFF).
#include "sar/team.hpp"

#include <fmt/format.h>

namespace dtflop::sar {

bool have_mpi() { return false; }

namespace {
int no_mpi() {
  fmt::print(stderr, "dtflop: error: this dtflop was built without MPI (DTFLOP_WITH_MPI=OFF); install libopenmpi-dev "
                     "openmpi-bin (scripts/setup.sh) and rebuild\n");
  return 2;
}
}  // namespace

int run_team(const Scenario& /*s*/, const TeamOptions& /*o*/) { return no_mpi(); }

int run_exchange_sweep(const ExchangeSweep&, const std::function<void(int)>&,
                       const std::function<void(const ExchangeSample&)>&) {
  return no_mpi();
}

}  // namespace dtflop::sar
