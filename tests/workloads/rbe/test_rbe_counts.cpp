// The seed pipeline's counts against eqs. 5.10-5.16, and the predicted components against
// eqs. 5.17-5.22, each worked out by hand here.
#include <gtest/gtest.h>

#include "model/errors.hpp"
#include "model/predict.hpp"
#include "workloads/rbe/counts.hpp"

namespace dtflop {
namespace {

TEST(RbeSeedCounts, Equations5_10To5_16) {
  // Grid 1000 x 800, kernel 33 x 21: n_g = 800000, I_x + I_y = 54.
  const auto c = rbe::seed_gpu_counts({1000, 800, 33, 21});
  EXPECT_EQ(c.N_CG, 2 * 800000 + 54 + 1);        // 5.10
  EXPECT_EQ(c.N_GC, 2 * 800000);                 // 5.13
  EXPECT_EQ(c.N_GG, 4 * 800000 + 54 + 1);        // 5.14
  EXPECT_EQ(c.N_C, 800000);                      // 5.15
  EXPECT_EQ(c.N_G, 2LL * 800000 * (54 + 1));     // 5.16
  EXPECT_EQ(c.P, 4);
  EXPECT_EQ(c.transfers_CG, 5);
  EXPECT_EQ(c.transfers_GC, 2);
  // The two device->host copies are one grid each (3.2 MB).
  EXPECT_EQ(c.copies_GC, (std::vector<CopySize>{{4 * 800000, 2}}));
  EXPECT_EQ(c.host_memory, HostMemory::pageable);
  EXPECT_EQ(rbe::seed_gpu_counts({10, 10, 3, 3}, HostMemory::pinned).host_memory, HostMemory::pinned);
}

TEST(RbeSeedCounts, PredictionMatchesEquations5_17To5_22) {
  MachineProfile m;
  m.identity.cpu_threads = 2;
  auto set = [&m](Param p, double v) { m.set(p, Parameter{v, Provenance::user, {}, {}, {}}); };
  set(Param::B_CG_pageable, 8e9);
  set(Param::B_GC_pageable, 16e9);
  set(Param::B_GG, 4e12);
  set(Param::V_C1_fp32, 2e9);
  set(Param::V_G_fp32, 50e12);
  const rbe::Shape s{1000, 1000, 32, 32};
  const auto p = predict(m, rbe::seed_gpu_counts(s), Variant::seed);
  const double ng = 1e6, P = 4, IxIy = 64;
  EXPECT_DOUBLE_EQ(p.dt_CG, P * (2 * ng + IxIy + 1) / 8e9);   // 5.17
  EXPECT_DOUBLE_EQ(p.dt_GC, P * (2 * ng) / 16e9);            // 5.18
  EXPECT_DOUBLE_EQ(p.dt_GG, P * (4 * ng + IxIy + 1) / 4e12);  // 5.19
  EXPECT_DOUBLE_EQ(p.dt_C, ng / 2e9);                        // 5.21
  EXPECT_DOUBLE_EQ(p.dt_G, 2 * ng * (IxIy + 1) / 50e12);     // 5.22
  EXPECT_NEAR(p.dt_trans(), P * ((2 * ng + 65) / 8e9 + 2 * ng / 16e9 + (4 * ng + 65) / 4e12), 1e-15);  // 5.20
  EXPECT_NEAR(p.total, p.dt_trans() + p.dt_C + p.dt_G, 1e-15);
}

TEST(RbeConventionalCounts, FullConvolutionIs2NgIxIy) {
  const auto c = rbe::conventional_cpu_counts({100, 50, 7, 5});
  EXPECT_EQ(c.N_C, 2LL * 5000 * 7 * 5 + 3 * 5000);
  EXPECT_EQ(c.N_CG, 0);
  EXPECT_EQ(c.N_G, 0);
  EXPECT_EQ(c.P, 8);
  EXPECT_EQ(c.precision, Precision::fp64);
}

TEST(RbeShape, RejectsBadSizes) {
  EXPECT_THROW(rbe::validate({0, 10, 3, 3}), InputError);
  EXPECT_THROW(rbe::validate({10, 10, 0, 3}), InputError);
  EXPECT_THROW(rbe::validate({10, 10, 11, 3}), InputError);  // kernel larger than grid
  EXPECT_THROW(rbe::validate({100000, 100000, 3, 3}), InputError);  // absurd
  EXPECT_NO_THROW(rbe::validate({10, 10, 10, 10}));
}

}  // namespace
}  // namespace dtflop
