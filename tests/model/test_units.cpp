#include <gtest/gtest.h>

#include "model/errors.hpp"
#include "model/units.hpp"

namespace dtflop {
namespace {

TEST(Units, Durations) {
  EXPECT_DOUBLE_EQ(parse_duration("1ms", "d"), 1e-3);
  EXPECT_DOUBLE_EQ(parse_duration("250us", "d"), 250e-6);
  EXPECT_DOUBLE_EQ(parse_duration("0.5s", "d"), 0.5);
  EXPECT_DOUBLE_EQ(parse_duration("2", "d"), 2.0);
  EXPECT_DOUBLE_EQ(parse_duration("30ns", "d"), 30e-9);
  EXPECT_THROW(parse_duration("fast", "d"), InputError);
  EXPECT_THROW(parse_duration("1 fortnight", "d"), InputError);
  EXPECT_THROW(parse_duration("-1ms", "d"), InputError);
  EXPECT_THROW(parse_duration("0ms", "d"), InputError);
}

TEST(Units, Bytes) {
  EXPECT_EQ(parse_bytes("4KiB", "s"), 4096);
  EXPECT_EQ(parse_bytes("16MiB", "s"), 16 << 20);
  EXPECT_EQ(parse_bytes("1GiB", "s"), 1 << 30);
  EXPECT_EQ(parse_bytes("2MB", "s"), 2'000'000);
  EXPECT_THROW(parse_bytes("1 parsec", "s"), InputError);
}

TEST(Units, Size2) {
  auto s = parse_size2("1000x800", "--grid", 100000);
  EXPECT_EQ(s.x, 1000);
  EXPECT_EQ(s.y, 800);
  s = parse_size2("33", "--kernel", 100000);
  EXPECT_EQ(s.x, 33);
  EXPECT_EQ(s.y, 33);
  EXPECT_THROW(parse_size2("0x10", "--grid", 100), InputError);
  EXPECT_THROW(parse_size2("-5x10", "--grid", 100), InputError);
  EXPECT_THROW(parse_size2("10x", "--grid", 100), InputError);
  EXPECT_THROW(parse_size2("10x10x10", "--grid", 100), InputError);
  EXPECT_THROW(parse_size2("101x10", "--grid", 100), InputError);
  EXPECT_THROW(parse_size2("1.5x10", "--grid", 100), InputError);
}

TEST(Units, Formatting) {
  EXPECT_EQ(format_duration(12.3e-6), "12.3 us");
  EXPECT_EQ(format_duration(4.56e-3), "4.56 ms");
  EXPECT_EQ(format_bandwidth(54.2e9), "54.2 GB/s");
  EXPECT_EQ(format_bandwidth(4.19e12), "4.19 TB/s");
  EXPECT_EQ(format_rate(55.1e12), "55.1 TFLOP/s");
  EXPECT_EQ(format_bytes(16.0 * 1024 * 1024), "16 MiB");
}

}  // namespace
}  // namespace dtflop
