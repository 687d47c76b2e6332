#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include <limits>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "tests/model/fixtures.hpp"

namespace dtflop {
namespace {

using nlohmann::json;

std::string error_of(const json& j) {
  try {
    profile_from_json(j);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ProfileJson, RoundTripKeepsEverything) {
  auto m = test::round_profile();
  m.identity.measured_at = "2026-11-21T10:00:00Z";
  m.identity.cpu_clock_ghz = 2.45;
  m.set(Param::B_GG, {4.1e12, Provenance::fitted, 0.05e12, 0.01, "ceres"});
  m.metadata["variant"] = "extended";
  const auto back = profile_from_json(json::parse(to_json(m).dump()));
  EXPECT_EQ(back.identity.cpu_model, "Test CPU");
  EXPECT_EQ(back.identity.cpu_threads, 8);
  EXPECT_EQ(back.identity.cpu_clock_ghz, 2.45);
  EXPECT_EQ(back.identity.measured_at, "2026-11-21T10:00:00Z");
  ASSERT_EQ(back.params().size(), m.params().size());
  const auto& g = back.get(Param::B_GG);
  EXPECT_DOUBLE_EQ(g.value, 4.1e12);
  EXPECT_EQ(g.provenance, Provenance::fitted);
  EXPECT_DOUBLE_EQ(*g.uncertainty, 0.05e12);
  EXPECT_DOUBLE_EQ(*g.spread, 0.01);
  EXPECT_EQ(g.note, "ceres");
  EXPECT_EQ(back.metadata.at("variant"), "extended");
}

TEST(ProfileJson, GpuMultiprocessorsRoundTripAndMayBeAbsent) {
  auto m = test::round_profile();
  m.identity.gpu_sms = 132;
  const json j = to_json(m);
  EXPECT_EQ(j["identity"]["gpu_sms"], 132);
  EXPECT_EQ(profile_from_json(json::parse(j.dump())).identity.gpu_sms, 132);
  // Profiles written before the field existed read as unknown (0).
  json old = j;
  old["identity"].erase("gpu_sms");
  EXPECT_EQ(profile_from_json(old).identity.gpu_sms, 0);
  old["identity"]["gpu_sms"] = -1;
  EXPECT_NE(error_of(old).find("identity.gpu_sms"), std::string::npos);
}

TEST(ProfileJson, GpuL2RoundTripsAndMayBeAbsent) {
  auto m = test::round_profile();
  m.identity.gpu_l2_bytes = 52'428'800;
  const json j = to_json(m);
  EXPECT_EQ(profile_from_json(json::parse(j.dump())).identity.gpu_l2_bytes, 52'428'800);
  json old = j;
  old["identity"].erase("gpu_l2_bytes");
  EXPECT_EQ(profile_from_json(old).identity.gpu_l2_bytes, 0);
  old["identity"]["gpu_l2_bytes"] = -1;
  EXPECT_NE(error_of(old).find("identity.gpu_l2_bytes"), std::string::npos);
}

TEST(ProfileJson, AFigureThatIsNotFiniteIsLeftOutSoTheProfileReadsBack) {
  // A fit whose covariance overflowed gave a parameter an infinite uncertainty; written as JSON
  // null it made the fitted profile unreadable (the main job's validate step failed on it).
  auto m = test::round_profile();
  Parameter p = m.get(Param::B_GG);
  p.uncertainty = std::numeric_limits<double>::infinity();
  p.spread = std::numeric_limits<double>::quiet_NaN();
  m.set(Param::B_GG, p);
  const MachineProfile back = profile_from_json(json::parse(to_json(m).dump()));
  EXPECT_FALSE(back.get(Param::B_GG).uncertainty.has_value());
  EXPECT_FALSE(back.get(Param::B_GG).spread.has_value());
  EXPECT_EQ(back.get(Param::B_GG).value, p.value);
}

TEST(ProfileJson, EffectiveCacheRoundTripsBesideTheSystemsAndMayBeAbsent) {
  auto m = test::round_profile();
  m.identity.cpu_llc_bytes = std::int64_t{480} << 20;
  m.identity.cpu_llc_effective_bytes = std::int64_t{24} << 20;
  const json j = to_json(m);
  EXPECT_EQ(j["identity"]["cpu_llc_bytes"], std::int64_t{480} << 20);
  EXPECT_EQ(j["identity"]["cpu_llc_effective_bytes"], std::int64_t{24} << 20);
  const auto back = profile_from_json(json::parse(j.dump()));
  EXPECT_EQ(back.identity.cpu_llc_bytes, std::int64_t{480} << 20);
  EXPECT_EQ(back.identity.cpu_llc_effective_bytes, std::int64_t{24} << 20);
  EXPECT_EQ(model_llc_bytes(back.identity), std::int64_t{24} << 20);
  // Profiles probed before the cache ladder read as not measured (0): the model uses the system's.
  json old = j;
  old["identity"].erase("cpu_llc_effective_bytes");
  const auto o = profile_from_json(old);
  EXPECT_EQ(o.identity.cpu_llc_effective_bytes, 0);
  EXPECT_EQ(model_llc_bytes(o.identity), std::int64_t{480} << 20);
  old["identity"]["cpu_llc_effective_bytes"] = -1;
  EXPECT_NE(error_of(old).find("identity.cpu_llc_effective_bytes"), std::string::npos);
  old["identity"]["cpu_llc_effective_bytes"] = 1.5;
  EXPECT_NE(error_of(old).find("identity.cpu_llc_effective_bytes"), std::string::npos);
}

TEST(ProfileJson, BadFilesNameFieldValueAndExpectation) {
  const json good = to_json(test::round_profile());

  auto j = good;
  j["schema_version"] = 99;
  EXPECT_NE(error_of(j).find("schema_version"), std::string::npos);
  EXPECT_NE(error_of(j).find("99"), std::string::npos);

  j = good;
  j["schema"] = "something-else";
  EXPECT_NE(error_of(j).find("'schema'"), std::string::npos);

  j = good;
  j["parameters"]["B_GG"]["value"] = -3;
  std::string e = error_of(j);
  EXPECT_NE(e.find("parameters.B_GG.value"), std::string::npos) << e;
  EXPECT_NE(e.find("-3"), std::string::npos) << e;
  EXPECT_NE(e.find("positive"), std::string::npos) << e;

  j = good;
  j["parameters"]["B_GG"]["value"] = 0;
  EXPECT_NE(error_of(j).find("parameters.B_GG.value"), std::string::npos);

  j = good;
  j["parameters"]["B_GG"]["unit"] = "GB/s";
  e = error_of(j);
  EXPECT_NE(e.find("parameters.B_GG.unit"), std::string::npos) << e;
  EXPECT_NE(e.find("\"B/s\""), std::string::npos) << e;

  j = good;
  j["parameters"]["B_GG"]["provenance"] = "guessed";
  EXPECT_NE(error_of(j).find("parameters.B_GG.provenance"), std::string::npos);

  j = good;
  j["parameters"]["B_XX"] = {{"value", 1}, {"unit", "B/s"}, {"provenance", "user"}};
  e = error_of(j);
  EXPECT_NE(e.find("parameters.B_XX"), std::string::npos) << e;
  EXPECT_NE(e.find("B_CG_pinned"), std::string::npos) << e;  // lists the known ones

  j = good;
  j["identity"]["cpu_threads"] = "eight";
  EXPECT_NE(error_of(j).find("identity.cpu_threads"), std::string::npos);

  j = good;
  j.erase("parameters");
  EXPECT_NE(error_of(j).find("'parameters'"), std::string::npos);

  EXPECT_NE(error_of(json::array()).find("top level"), std::string::npos);
}

TEST(ProfileJson, SaveAndLoadFile) {
  const auto dir = std::filesystem::temp_directory_path() / "dtflop_test_json";
  std::filesystem::create_directories(dir);
  const auto path = dir / "m.json";
  save_profile(test::round_profile(), path);
  EXPECT_FALSE(std::filesystem::exists(dir / "m.json.tmp"));
  const auto back = load_profile(path);
  EXPECT_DOUBLE_EQ(back.get(Param::V_G_fp32).value, 50e12);

  std::ofstream(dir / "torn.json") << "{\"schema\": \"dtflop.machine-profile\", ";
  try {
    load_profile(dir / "torn.json");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not valid JSON"), std::string::npos) << e.what();
  }
  EXPECT_THROW(load_profile(dir / "absent.json"), InputError);
  std::filesystem::remove_all(dir);
}

TEST(CountsJson, RoundTrip) {
  CostCounts c;
  c.P = 8;
  c.precision = Precision::fp64;
  c.N_CG = 1;
  c.N_GC = 2;
  c.N_GG = 3;
  c.N_C = 4;
  c.N_G = 5;
  c.N_CC = 6;
  c.N_CW = 3;
  c.N_GR = 2;
  c.transfers_CG = 7;
  c.transfers_GC = 8;
  c.launches = 9;
  c.waves = 10;
  c.cpu_syncs = 11;
  c.host_waits = 12;
  c.N_GS = 13;
  c.atomics = 17;
  c.copies_GC = {{4096, 3}, {8, 2}};
  c.cpu_footprint = 14;
  c.host_memory = HostMemory::pinned;
  c.cpu_threads = 16;
  EXPECT_EQ(counts_from_json(json::parse(to_json(c).dump())), c);
  // Counts written before waves and cpu_syncs existed read as zero of each.
  auto old = to_json(c);
  old.erase("waves");
  old.erase("cpu_syncs");
  old.erase("host_waits");
  old.erase("N_GS");
  old.erase("atomics");
  old.erase("copies_GC");
  old.erase("N_CW");
  old.erase("N_GR");
  const CostCounts back = counts_from_json(old);
  EXPECT_EQ(back.N_CW, 0);
  EXPECT_EQ(back.N_GR, 0);
  EXPECT_EQ(back.N_GS, 0);
  EXPECT_EQ(back.atomics, 0);
  EXPECT_TRUE(back.copies_GC.empty());
  EXPECT_EQ(back.waves, 0);
  EXPECT_EQ(back.cpu_syncs, 0);
  EXPECT_EQ(back.host_waits, 0);
  EXPECT_EQ(back.launches, 9);
  auto j = to_json(c);
  j["N_G"] = -1;
  EXPECT_THROW(counts_from_json(j), InputError);
  j = to_json(c);
  j["host_memory"] = "managed";
  EXPECT_THROW(counts_from_json(j), InputError);
  j = to_json(c);
  j["N_CW"] = 5;  // more sliding-window FLOPs than the N_C = 4 FLOPs
  EXPECT_THROW(counts_from_json(j), InputError);
  j = to_json(c);
  j["N_GR"] = 6;  // more across-row FLOPs than the N_G = 5 FLOPs
  EXPECT_THROW(counts_from_json(j), InputError);
  for (const char* bad : {R"({"bytes": 0, "count": 1})", R"({"bytes": 8})", R"({"bytes": 8, "count": -2})", "[8, 1]"}) {
    j = to_json(c);
    j["copies_GC"] = json::array({json::parse(bad)});
    EXPECT_THROW(counts_from_json(j), InputError) << bad;
  }
}

}  // namespace
}  // namespace dtflop
