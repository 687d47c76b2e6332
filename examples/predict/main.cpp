// Predicts with the DTFLOP model how long your own GPU step takes on a machine, from the
// machine's profile (`dtflop probe -o machine.json`, or share/dtflop/examples/h200.json):
// copy n floats to the device, run one kernel of 20 FLOPs per value over them, copy them back.
//   predict_example PROFILE [n]
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "model/cost_counts.hpp"
#include "model/json_io.hpp"
#include "model/predict.hpp"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: predict_example PROFILE [n]\n");
    return 2;
  }
  try {
    const dtflop::MachineProfile profile = dtflop::load_profile(argv[1]);
    const std::int64_t n = argc > 2 ? std::atoll(argv[2]) : 1 << 20;
    dtflop::CostCounts c;
    c.P = 4;
    c.N_CG = n;            // values host -> device
    c.N_GC = n;            // values device -> host
    c.N_GG = 2 * n;        // the kernel reads and writes each value once
    c.N_G = 20 * n;        // FLOPs on the GPU
    c.transfers_CG = 1;
    c.transfers_GC = 1;
    c.launches = 1;
    c.host_memory = dtflop::HostMemory::pinned;
    const dtflop::Variant v = dtflop::richest_supported_variant(profile, c, dtflop::Variant::latency);
    const dtflop::Prediction p = dtflop::predict(profile, c, v);
    std::printf("n = %lld on %s: host->device %.3g s, device->host %.3g s, kernel %.3g s, total %.3g s (%s variant)\n",
                static_cast<long long>(n), profile.identity.gpu_name.c_str(), p.dt_CG + p.lat_CG, p.dt_GC + p.lat_GC,
                p.dt_G + p.dt_GG, p.total, std::string(dtflop::to_string(v)).c_str());
    return p.total > 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "predict_example: %s\n", e.what());
    return 2;
  }
}
