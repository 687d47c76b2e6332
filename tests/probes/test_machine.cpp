// The whole probe run at smoke effort and the profile made from it.
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "probes/gpu.hpp"
#include "probes/machine.hpp"
#include "probes/team.hpp"

namespace dtflop::probes {
namespace {

const std::vector<Param> kGpuParams = {
    Param::B_CG_pinned,   Param::B_GC_pinned,   Param::B_CG_pageable, Param::B_GC_pageable,
    Param::L_CG_pinned,   Param::L_GC_pinned,   Param::L_CG_pageable, Param::L_GC_pageable,
    Param::B_GG,          Param::B_GG_copy,     Param::V_G_fp32,      Param::V_G_fp64,
    Param::L_launch,      Param::L_wait,        Param::L_wave,        Param::B_L2};
const std::vector<Param> kCpuParams = {Param::B_host_1,  Param::B_host,    Param::V_C1_fp32,
                                       Param::V_C_fp32,  Param::V_C1_fp64, Param::V_C_fp64};

TEST(Registry, HoldsEveryProbeOnceInOrder) {
  std::set<std::string> names;
  int last = -1;
  for (const auto& p : all_probes()) {
    EXPECT_TRUE(names.insert(p.name).second) << p.name;
    EXPECT_GE(p.order, last);
    last = p.order;
  }
  for (const char* n : {"cpu-memory", "cpu-fma", "gpu-transfers", "gpu-memory", "gpu-fma", "gpu-launch"})
    EXPECT_TRUE(names.count(n)) << n << " is not registered";
}

TEST(Registry, RefusesDuplicates) {
  Registry r;
  r.add({"x", "a probe", false, 0, [](const ProbeOptions&) { return ProbeReport{}; }});
  EXPECT_THROW(r.add({"x", "again", false, 0, [](const ProbeOptions&) { return ProbeReport{}; }}),
               std::logic_error);
}

TEST(ProbeMachine, UnknownProbeNameIsAnInputError) {
  ProbeOptions o;
  o.effort = Effort::smoke;
  const std::vector<std::string> only = {"cpu-fma", "warp-drive"};
  try {
    probe_machine(o, only);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("warp-drive"), std::string::npos) << msg;
    EXPECT_NE(msg.find("cpu-memory"), std::string::npos) << "should list the probes: " << msg;
  }
}

TEST(ProbeMachine, ProfileHoldsWhatWasMeasuredAndNothingElse) {
  ProbeOptions o;
  o.effort = Effort::smoke;
  std::vector<std::string> lines;
  o.progress = [&lines](const std::string& l) { lines.push_back(l); };
  const MachineReport rep = probe_machine(o);
  EXPECT_FALSE(rep.failed());
  EXPECT_FALSE(lines.empty());
  const MachineProfile prof = make_profile(rep);

  EXPECT_FALSE(prof.identity.cpu_model.empty());
  EXPECT_GE(prof.identity.cpu_cores, 1);
  EXPECT_GE(prof.identity.cpu_threads, prof.identity.cpu_cores);
  EXPECT_FALSE(prof.identity.measured_at.empty());
  for (Param p : kCpuParams) {
    ASSERT_TRUE(prof.has(p)) << info(p).name;
    EXPECT_EQ(prof.get(p).provenance, Provenance::probed);
    EXPECT_TRUE(prof.get(p).spread.has_value()) << info(p).name;
    EXPECT_FALSE(prof.get(p).note.empty());
  }
  // Thread syncs are measured wherever two threads can wait for each other.
  if (usable_cpus() >= 2) {
    ASSERT_TRUE(prof.has(Param::L_sync));
    EXPECT_GT(prof.get(Param::L_sync).value, 1e-9);
    EXPECT_LT(prof.get(Param::L_sync).value, 1e-2);
    EXPECT_TRUE(prof.get(Param::L_sync).spread.has_value());
  } else {
    EXPECT_FALSE(prof.has(Param::L_sync));
  }
  const bool gpu = gpu::device_info().usable;
  if (gpu) {
    EXPECT_FALSE(prof.identity.gpu_name.empty());
    EXPECT_FALSE(prof.identity.cuda_version.empty());
    EXPECT_EQ(prof.identity.gpu_sms, gpu::device_info().sm_count);
    EXPECT_GT(prof.identity.gpu_sms, 0);
    EXPECT_EQ(prof.identity.gpu_l2_bytes, gpu::device_info().l2_bytes);
    EXPECT_GT(prof.identity.gpu_l2_bytes, 0);
    for (Param p : kGpuParams) EXPECT_TRUE(prof.has(p)) << info(p).name;
  } else {
    // No device: the GPU parameters are absent (never zero), and the reason is recorded.
    EXPECT_TRUE(prof.identity.gpu_name.empty());
    EXPECT_EQ(prof.identity.gpu_sms, 0);
    for (Param p : kGpuParams) EXPECT_FALSE(prof.has(p)) << info(p).name;
    EXPECT_EQ(prof.metadata.count("probe.gpu"), 1u);
    bool said = false;
    for (const auto& l : lines) said = said || l.find("GPU probes skipped") != std::string::npos;
    EXPECT_TRUE(said) << "no message that the GPU probes were skipped";
  }

  // Round trip through the file format.
  const auto path = std::filesystem::temp_directory_path() / "dtflop_test_probe_profile.json";
  save_profile(prof, path);
  const MachineProfile back = load_profile(path);
  std::filesystem::remove(path);
  EXPECT_EQ(back.params().size(), prof.params().size());
  for (const auto& [p, v] : prof.params()) {
    ASSERT_TRUE(back.has(p));
    EXPECT_DOUBLE_EQ(back.get(p).value, v.value);
  }
  EXPECT_EQ(back.identity.cpu_model, prof.identity.cpu_model);
  EXPECT_EQ(back.identity.measured_at, prof.identity.measured_at);
  EXPECT_EQ(back.identity.cpu_llc_bytes, prof.identity.cpu_llc_bytes);
  EXPECT_EQ(back.identity.cpu_llc_effective_bytes, prof.identity.cpu_llc_effective_bytes);
  EXPECT_EQ(prof.metadata.count("probe.cpu_llc_effective"), 1u);
}

TEST(ProbeMachine, TheCacheLaddersKneeIsTheEffectiveCacheBesideTheSystemsFigure) {
  MachineReport rep;
  rep.identity.cpu_llc_bytes = std::int64_t{480} << 20;
  ProbeReport mem;
  mem.probe = "cpu-memory";
  Measurement k;
  k.key = "llc_effective";
  k.unit = "B";
  k.value = 24 << 20;
  mem.measurements.push_back(k);
  mem.metadata["cpu_llc_effective"] = "read ladder of 12 sizes: ...";
  mem.metadata["cpu_llc_ladder"] = "4194304:3e10 8388608:1e10";
  rep.reports.push_back(mem);
  MachineProfile prof = make_profile(rep);
  EXPECT_EQ(prof.identity.cpu_llc_bytes, std::int64_t{480} << 20);
  EXPECT_EQ(prof.identity.cpu_llc_effective_bytes, 24 << 20);
  EXPECT_EQ(prof.metadata.at("probe.cpu_llc_effective"), "read ladder of 12 sizes: ...");
  EXPECT_EQ(prof.metadata.at("probe.cpu_llc_ladder"), "4194304:3e10 8388608:1e10");
  // No knee: the field stays unmeasured, the note says so, and the model uses the system's figure.
  rep.reports[0].measurements[0].key = "llc_no_knee";
  rep.reports[0].measurements[0].value = static_cast<double>(rep.identity.cpu_llc_bytes);
  rep.reports[0].metadata["cpu_llc_effective"] = "none: no knee (...)";
  prof = make_profile(rep);
  EXPECT_EQ(prof.identity.cpu_llc_effective_bytes, 0);
  EXPECT_EQ(model_llc_bytes(prof.identity), std::int64_t{480} << 20);
  EXPECT_EQ(prof.metadata.at("probe.cpu_llc_effective"), "none: no knee (...)");
  // A failed cpu-memory leaves nothing of it.
  rep.reports[0].measurements[0].key = "llc_effective";
  rep.reports[0].error = "host copy differed";
  prof = make_profile(rep);
  EXPECT_EQ(prof.identity.cpu_llc_effective_bytes, 0);
  EXPECT_EQ(prof.metadata.count("probe.cpu_llc_ladder"), 0u);
}

TEST(ProbeMachine, CostRatiosAreRebasedOnTheProfilesOwnRate) {
  // cpu-fma measured V_C1_fp32 = 100 GFLOP/s; cpu-window's loop ran at 50 GFLOP/s against its own
  // rerun of the FMA loop at 150: K_CW = 3 there, 2 against the profile's rate, so that the
  // prediction N_CW x K_CW / V_C1 is the loop's own 50 GFLOP/s.
  MachineReport rep;
  ProbeReport fma, window;
  fma.probe = "cpu-fma";
  Measurement rate;
  rate.key = "fp32_1";
  rate.unit = "FLOP/s";
  rate.value = 100e9;
  rate.param = Param::V_C1_fp32;
  fma.measurements.push_back(rate);
  window.probe = "cpu-window";
  Measurement k;
  k.key = "K_CW";
  k.unit = "x";
  k.value = 3.0;
  k.param = Param::K_CW;
  k.reference_param = Param::V_C1_fp32;
  k.reference = 150e9;
  window.measurements.push_back(k);
  k.param = Param::K_CA;  // against a rate the profile lacks: left as measured
  k.reference_param = Param::V_C1_fp64;
  window.measurements.push_back(k);
  rep.reports = {window, fma};  // the order of the probes does not matter
  const MachineProfile prof = make_profile(rep);
  EXPECT_DOUBLE_EQ(prof.get(Param::K_CW).value, 2.0);
  EXPECT_NE(prof.get(Param::K_CW).note.find("rebased on V_C1_fp32"), std::string::npos);
  EXPECT_DOUBLE_EQ(prof.get(Param::K_CA).value, 3.0);
}

TEST(ProbeMachine, AFailingProbeLeavesItsParametersOut) {
  // make_profile takes measurements from sound reports only.
  MachineReport rep;
  ProbeReport ok, bad;
  ok.probe = "a";
  Measurement m;
  m.key = "x";
  m.unit = "B/s";
  m.value = 1e10;
  m.param = Param::B_host;
  ok.measurements.push_back(m);
  bad.probe = "b";
  m.param = Param::B_host_1;
  bad.measurements.push_back(m);
  bad.error = "result did not validate";
  rep.reports = {ok, bad};
  EXPECT_TRUE(rep.failed());
  const MachineProfile prof = make_profile(rep);
  EXPECT_TRUE(prof.has(Param::B_host));
  EXPECT_FALSE(prof.has(Param::B_host_1));
  EXPECT_NE(prof.metadata.at("probe.failed").find("did not validate"), std::string::npos);
}

}  // namespace
}  // namespace dtflop::probes
