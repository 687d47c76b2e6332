// Messages between processes (L_net, B_net): an MPI ping-pong between two processes of this
// machine, run as `mpirun -n 2 dtflop-pingpong` (probes/net_pingpong.cpp, built beside dtflop
// where dtflop has MPI). L_net is half the round trip of an 8-byte message; B_net is a 4 MiB
// message over half its round trip. Skipped where dtflop was built without MPI or mpirun or
// dtflop-pingpong is not found.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "probes/measure.hpp"
#include "probes/probe.hpp"

namespace dtflop::probes {
namespace {

std::filesystem::path beside_self(const char* name) {
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path() : self.parent_path() / name;
}

ProbeReport run(const ProbeOptions& o) {
  ProbeReport r;
  r.probe = "net-mpi";
#ifndef DTFLOP_MPIEXEC
  r.skipped = "dtflop was built without MPI (DTFLOP_WITH_MPI=OFF)";
  (void)o;
  return r;
#else
  const auto helper = beside_self("dtflop-pingpong");
  if (helper.empty() || !std::filesystem::exists(helper)) {
    r.skipped = "dtflop-pingpong is not beside dtflop; build it (cmake --build build)";
    return r;
  }
  if (!std::filesystem::exists(DTFLOP_MPIEXEC)) {
    r.skipped = fmt::format("{} is not there; install openmpi-bin (scripts/setup.sh)", DTFLOP_MPIEXEC);
    return r;
  }
  const int reps = o.effort == Effort::full ? 201 : o.effort == Effort::quick ? 51 : 5;
  constexpr long kSmall = 8, kLarge = 4L << 20;
  // As root (CI) OpenMPI needs the two variables; under the sanitizers OpenMPI's own allocations
  // outlive MPI_Finalize, so the helper's leak check is off.
  const std::string root = std::string(::geteuid() == 0 ? "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 " : "") +
                           "ASAN_OPTIONS=\"${ASAN_OPTIONS:-}:detect_leaks=0\" ";
  const std::string cmd = fmt::format("{}'{}' --oversubscribe -n 2 '{}' {} {} {} 2>&1", root, DTFLOP_MPIEXEC,
                                      helper.string(), reps, kSmall, kLarge);
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(::popen(cmd.c_str(), "r"), ::pclose);
  if (!pipe) throw std::runtime_error("could not start mpirun for the ping-pong");
  std::string text;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, pipe.get())) text += buf;
  const int status = ::pclose(pipe.release());
  if (status != 0) throw ValidationError(fmt::format("the MPI ping-pong failed (status {}): {}", status, text.substr(0, 300)));
  std::istringstream in(text);
  std::vector<double> small, large;
  for (std::string line; std::getline(in, line);) {
    std::istringstream l(line);
    long bytes = 0;
    if (!(l >> bytes)) continue;
    std::vector<double>& v = bytes == kSmall ? small : large;
    for (double t; l >> t;) v.push_back(t);
  }
  if (small.size() != std::size_t(reps) || large.size() != std::size_t(reps))
    throw ValidationError(fmt::format("the MPI ping-pong printed {} and {} times, expected {} each", small.size(),
                                      large.size(), reps));
  r.measurements.push_back(time_measurement("latency", "MPI message, 8 B (half a round trip)", small, Param::L_net,
                                            fmt::format("mpirun -n 2 ping-pong on this machine, median of {}", reps)));
  r.measurements.push_back(rate_measurement("bandwidth_4MiB", "MPI message, 4 MiB", "B/s", double(kLarge), large,
                                            Param::B_net,
                                            fmt::format("4 MiB over half a round trip, median of {}", reps)));
  o.say(fmt::format("  MPI message: {:.2f} us latency, {:.2f} GB/s", r.measurements[0].value * 1e6,
                    r.measurements[1].value / 1e9));
  return r;
#endif
}

}  // namespace
}  // namespace dtflop::probes

DTFLOP_PROBE_UNIT(probe_net_mpi) {
  registry.add({"net-mpi", "messages between two processes: MPI ping-pong latency and bandwidth (mpirun -n 2)", false,
                60, dtflop::probes::run});
}
