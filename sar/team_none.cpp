// The team runtime where dtflop is built without MPI (DTFLOP_WITH_MPI=OFF).
#include "sar/team.hpp"

#include <fmt/format.h>

namespace dtflop::sar {

bool have_mpi() { return false; }

int run_team(const Scenario& /*s*/, const TeamOptions& /*o*/) {
  fmt::print(stderr, "dtflop: error: this dtflop was built without MPI (DTFLOP_WITH_MPI=OFF); install libopenmpi-dev "
                     "openmpi-bin (scripts/setup.sh) and rebuild\n");
  return 2;
}

}  // namespace dtflop::sar
