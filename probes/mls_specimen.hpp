// The specimen both MLS probes run on (cpu-mls on the host, gpu-mls on the device): a jittered
// grid of dots with a quadratic displacement field, 1024 interpolation points over its middle, and
// their support tables of 12, 30 and 80 dots (the nearest, as the DCT workload's support by dot
// count takes them). MLS with a quadratic basis reproduces a quadratic field exactly, so every
// point's field can be checked against the field's own.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "kernels/point_fields.hpp"

namespace dtflop::probes::mls {

struct Xy {
  double x = 0, y = 0;
};

inline constexpr int kGrid = 64;          // dots a side: 4096 dots
inline constexpr double kPitch = 16;      // px between dots
inline constexpr double kJitter = 3;      // px, either way
inline constexpr int kPointsSide = 32;    // 1024 points
inline constexpr std::array<int, 3> kSupports = {12, 30, 80};  // dots a support (the workload's 10..100)

// The displacement field, px, and its gradient (du_x/dx, du_x/dy, du_y/dx, du_y/dy).
Xy displacement(double x, double y);
std::array<double, 4> gradient(double x, double y);

struct Table {
  int support = 0;
  std::vector<std::int32_t> offsets, dots;  // compressed rows, nearest first
  std::vector<double> rho;                  // midway between the n-th and the (n + 1)-th dot
  std::vector<kernels::PointStatus> geometry;
  double flops = 0;                         // of the table's fields, as the DCT counts give them
};

struct Specimen {
  std::vector<Xy> reference, disp, points;
  std::vector<std::uint8_t> tracked;
  std::vector<Table> tables;
  double flops = 0;  // of one evaluation of every table
};

Specimen make_specimen();

// Throws ValidationError unless every point of `t` has status ok, its whole support, and the
// quadratic field's displacement and strain within `du` px and `de`.
template <class T>
void check(const Specimen& s, const Table& t, const std::vector<kernels::FieldValue<T>>& out, double du,
           double de, const char* who);

}  // namespace dtflop::probes::mls
