// The terms of messages between the partitions of one grid (docs/model.md 2.9): dt_peer and
// dt_allreduce priced between GPUs (L_peer, B_peer, L_allreduce, B_allreduce) and inside one
// device (L_launch, B_GG_copy, B_GG), by hand; the parameters they need; their JSON.
#include <gtest/gtest.h>

#include <algorithm>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/predict.hpp"
#include "model/terms.hpp"
#include "tests/model/fixtures.hpp"

namespace dtflop {
namespace {

MachineProfile peer_profile() {
  MachineProfile m = test::round_profile();
  auto set = [&m](Param p, double v) { m.set(p, Parameter{v, Provenance::user, {}, {}, {}}); };
  set(Param::L_peer, 10e-6);
  set(Param::B_peer, 100e9);
  set(Param::L_allreduce, 20e-6);
  set(Param::B_allreduce, 50e9);
  return m;
}

CostCounts halo_counts(PeerPath path) {
  CostCounts c;
  c.P = 4;
  c.N_GG = 3'000'000;  // a kernel's traffic: 12 MB at 4 TB/s = 3 us
  c.peer_messages = 2;
  c.N_peer = 2 * 16 * 1000;
  c.collectives = path == PeerPath::link ? 1 : 2;
  c.collective_bytes = path == PeerPath::link ? 8 : 48;
  c.peer_path = path;
  return c;
}

TEST(PeerTerms, BetweenGpusByHand) {
  const MachineProfile m = peer_profile();
  const CostCounts c = halo_counts(PeerPath::link);
  const Prediction p = predict(m, c, Variant::latency);
  EXPECT_DOUBLE_EQ(p.dt_peer, 2 * 10e-6 + 4.0 * 32000 / 100e9);
  EXPECT_DOUBLE_EQ(p.dt_allreduce, 20e-6 + 8 / 50e9);
  EXPECT_DOUBLE_EQ(p.total, p.dt_GG + p.dt_peer + p.dt_allreduce);
  // Extended: the halo overlaps the kernels' traffic (the larger), the all-reduce adds.
  const Prediction e = predict(m, c, Variant::extended);
  EXPECT_DOUBLE_EQ(e.total, std::max(e.dt_GG, e.dt_peer) + e.dt_allreduce);
  // The seed has no such terms.
  EXPECT_EQ(predict(m, c, Variant::seed).dt_peer, 0.0);
  const auto need = required_params(c, Variant::latency);
  for (Param q : {Param::L_peer, Param::B_peer, Param::L_allreduce, Param::B_allreduce})
    EXPECT_NE(std::find(need.begin(), need.end(), q), need.end()) << info(q).name;
  EXPECT_EQ(std::find(need.begin(), need.end(), Param::L_launch), need.end());
}

TEST(PeerTerms, InsideOneDeviceAreCopiesAndReductionKernels) {
  const MachineProfile m = peer_profile();
  const CostCounts c = halo_counts(PeerPath::device);
  const Prediction p = predict(m, c, Variant::memory);
  EXPECT_DOUBLE_EQ(p.dt_peer, 2 * 3e-6 + 2 * 4.0 * 32000 / 4.2e12);
  EXPECT_DOUBLE_EQ(p.dt_allreduce, 2 * 3e-6 + 48 / 4e12);
  const auto need = required_params(c, Variant::memory);
  for (Param q : {Param::L_peer, Param::B_peer, Param::L_allreduce, Param::B_allreduce})
    EXPECT_EQ(std::find(need.begin(), need.end(), q), need.end()) << info(q).name;
  // A probed one-GPU profile (no peer parameters) predicts it.
  MachineProfile one = test::round_profile();
  EXPECT_NO_THROW((void)predict(one, c, Variant::latency));
  EXPECT_THROW((void)predict(one, halo_counts(PeerPath::link), Variant::latency), MissingParameter);
}

TEST(PeerTerms, CountsAndPathGoThroughJson) {
  const CostCounts c = halo_counts(PeerPath::device);
  const CostCounts back = counts_from_json(to_json(c));
  EXPECT_EQ(back, c);
  EXPECT_EQ(counts_from_json(to_json(halo_counts(PeerPath::link))).peer_path, PeerPath::link);
  auto j = to_json(c);
  j["peer_path"] = "nvlink";
  EXPECT_THROW((void)counts_from_json(j), InputError);
  j.erase("peer_path");
  EXPECT_EQ(counts_from_json(j).peer_path, PeerPath::link);  // counts written before it existed
  // Steps of a computation keep its path.
  EXPECT_EQ(c.scaled(3).peer_path, PeerPath::device);
  CostCounts sum;
  sum += c;
  EXPECT_EQ(sum.peer_path, PeerPath::device);
  EXPECT_EQ(sum.N_peer, c.N_peer);
}

}  // namespace
}  // namespace dtflop
