#include "calibrate/machine.hpp"

#include <fmt/format.h>

#include "probes/gpu.hpp"
#include "probes/identity.hpp"

namespace dtflop::calib {

MachineIdentity this_machine() {
  // The same functions `dtflop probe` uses, so a sample and a profile of one machine agree.
  MachineIdentity id = probes::host_identity();
  id.measured_at.clear();  // a sample has its own time
  const probes::gpu::DeviceInfo d = probes::gpu::device_info();
  if (d.usable) {
    id.gpu_name = d.name;
    id.gpu_sms = d.sm_count;
    id.gpu_l2_bytes = d.l2_bytes;
    id.gpu_driver = d.driver_version;
    id.cuda_version = d.runtime_version;
  }
  return id;
}

}  // namespace dtflop::calib
