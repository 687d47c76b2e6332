// A machine profile with round numbers so expected times can be worked out by hand.
#pragma once

#include "model/profile.hpp"

namespace dtflop::test {

inline MachineProfile round_profile() {
  MachineProfile m;
  m.identity.cpu_model = "Test CPU";
  m.identity.cpu_cores = 4;
  m.identity.cpu_threads = 8;
  m.identity.gpu_name = "Test GPU";
  auto set = [&m](Param p, double v) { m.set(p, Parameter{v, Provenance::user, {}, {}, {}}); };
  set(Param::B_CG_pinned, 50e9);
  set(Param::B_GC_pinned, 40e9);
  set(Param::B_CG_pageable, 10e9);
  set(Param::B_GC_pageable, 8e9);
  set(Param::L_CG_pinned, 10e-6);
  set(Param::L_GC_pinned, 12e-6);
  set(Param::L_CG_pageable, 20e-6);
  set(Param::L_GC_pageable, 25e-6);
  set(Param::B_GG, 4e12);
  set(Param::B_GG_copy, 4.2e12);
  set(Param::B_host_1, 20e9);
  set(Param::B_host, 60e9);
  set(Param::V_C1_fp32, 100e9);
  set(Param::V_C_fp32, 600e9);
  set(Param::V_C1_fp64, 50e9);
  set(Param::V_C_fp64, 300e9);
  set(Param::V_G_fp32, 50e12);
  set(Param::V_G_fp64, 25e12);
  set(Param::L_launch, 3e-6);
  set(Param::L_wave, 2e-6);
  set(Param::L_sync, 5e-6);
  set(Param::L_wait, 20e-6);
  set(Param::B_GS, 8e12);
  set(Param::L_atomic, 5e-9);
  // Pageable device->host staging: the first 400 kB of a copy at 5 GB/s, the next 200 kB free.
  set(Param::B_GC_staged, 5e9);
  set(Param::S_GC_staged, 400e3);
  set(Param::S_GC_flat, 200e3);
  set(Param::K_CW, 1.5);  // a sliding-window FLOP costs half as much again
  set(Param::K_GR, 2.0);  // an across-row GPU FLOP twice as much
  return m;
}

}  // namespace dtflop::test
