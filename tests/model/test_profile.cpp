#include <set>

#include <gtest/gtest.h>

#include "model/errors.hpp"
#include "model/profile.hpp"

namespace dtflop {
namespace {

TEST(Params, EveryParameterHasUniqueNameAndKnownUnit) {
  std::set<std::string_view> names;
  for (const auto& i : all_params()) {
    EXPECT_TRUE(names.insert(i.name).second) << i.name;
    EXPECT_TRUE(i.unit == "B/s" || i.unit == "s" || i.unit == "FLOP/s" || i.unit == "B" || i.unit == "x") << i.name;
    EXPECT_EQ(param_from_name(i.name), i.id);
    EXPECT_EQ(info(i.id).name, i.name);
  }
  // The table covers every enumerator, first to last.
  EXPECT_EQ(all_params().size(), static_cast<size_t>(Param::L_GF) + 1);  // L_GF is the last
  EXPECT_FALSE(param_from_name("B_XY").has_value());
}

TEST(Profile, AbsentParameterIsAbsentNotZero) {
  MachineProfile m;
  EXPECT_FALSE(m.has(Param::V_G_fp32));
  EXPECT_EQ(m.find(Param::V_G_fp32), nullptr);
  try {
    m.get(Param::V_G_fp32);
    FAIL() << "expected MissingParameter";
  } catch (const MissingParameter& e) {
    EXPECT_NE(std::string(e.what()).find("V_G_fp32"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("dtflop probe"), std::string::npos) << e.what();
  }
  m.set(Param::V_G_fp32, {5e13, Provenance::probed, {}, {}, "fma"});
  EXPECT_TRUE(m.has(Param::V_G_fp32));
  EXPECT_DOUBLE_EQ(m.get(Param::V_G_fp32).value, 5e13);
  m.erase(Param::V_G_fp32);
  EXPECT_FALSE(m.has(Param::V_G_fp32));
}

TEST(Profile, ProvenanceRoundTrips) {
  for (auto p : {Provenance::probed, Provenance::fitted, Provenance::user})
    EXPECT_EQ(provenance_from_string(to_string(p)), p);
  EXPECT_FALSE(provenance_from_string("guessed").has_value());
}

}  // namespace
}  // namespace dtflop
