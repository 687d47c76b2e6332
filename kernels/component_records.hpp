// The host's pass over the component records a GPU labelling leaves (the DCT workload's cuda
// backend): each record's status tallied, the records put in the raster order of their roots (as
// OpenCV's labelling numbers components on the host), and the kept ones handed on in that order.
// One source for the workload and for the cpu-records probe that times it (L_record).
//
// Its work is counted in record steps (record_steps): for n records whose roots lie below
// `key_limit`, n to tally, n x radix_passes(key_limit) to order (a counting pass and a scatter
// each, a byte of the key a pass) and n to hand on: n x (2 + radix_passes(key_limit)), whatever
// the records hold.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace dtflop::kernels {

// A byte of the key a pass: as many passes as a key below `key_limit` can need (0 for a limit of
// 0 or 1: every key is 0).
inline int radix_passes(std::int64_t key_limit) {
  int passes = 0;
  for (std::int64_t largest = key_limit - 1; largest > 0; largest >>= 8) ++passes;
  return passes;
}

inline std::int64_t record_steps(std::int64_t records, std::int64_t key_limit) {
  return records * (2 + radix_passes(key_limit));
}

// Puts `items` in the order of key[item], equal keys in the order given: a least-significant-
// digit radix sort of `passes` bytes, with `scratch` as its second buffer. Every key must lie in
// [0, 256^passes); a key outside is a caller's error (std::logic_error).
inline void sort_by_key(std::vector<int>& items, const int* key, int passes, std::vector<int>& scratch) {
  const std::int64_t limit = passes >= 4 ? (std::int64_t{1} << 32) : (std::int64_t{1} << (8 * passes));
  for (int i : items)
    if (key[i] < 0 || key[i] >= limit) throw std::logic_error("sort_by_key: a key outside the passes' range");
  scratch.resize(items.size());
  for (int shift = 0; shift < 8 * passes && shift < 32; shift += 8) {
    std::array<std::size_t, 257> start{};
    for (int i : items) ++start[((key[i] >> shift) & 0xff) + 1];
    for (std::size_t b = 1; b < start.size(); ++b) start[b] += start[b - 1];
    for (int i : items) scratch[start[(key[i] >> shift) & 0xff]++] = i;
    items.swap(scratch);
  }
}

// What the records say about the frame beside the dots: how many of each status, and their pixels.
struct RecordTally {
  std::int64_t records = 0;
  std::int64_t area = 0;               // pixels of every component
  std::int64_t by_status[5] = {};      // 0 kept, 1 area, 2 shape, 3 border, 4 (or more) contrast
  std::int64_t window_pixels = 0, ring_pixels = 0, weighted_pixels = 0;
};

// The records' columns (each `count` long; `pixels` three a record: window, ring, weighted).
struct RecordColumns {
  const int* status = nullptr;
  const int* area = nullptr;
  const int* root = nullptr;
  const int* pixels = nullptr;
  std::size_t count = 0;
};

// Tallies every record, orders them by root (each below `key_limit`) and calls emit(k) for each
// kept record (status 0) in that order. `order` and `scratch` are the caller's, kept from frame to
// frame. Returns the steps it took, record_steps(count, key_limit).
template <class Emit>
std::int64_t order_records(const RecordColumns& r, std::int64_t key_limit, RecordTally& tally, std::vector<int>& order,
                           std::vector<int>& scratch, Emit&& emit) {
  if (key_limit < 0 || key_limit > (std::int64_t{1} << 31))
    throw std::logic_error("order_records: the roots' limit must lie in 0..2^31");
  tally = RecordTally{};
  tally.records = static_cast<std::int64_t>(r.count);
  order.resize(r.count);
  for (std::size_t k = 0; k < r.count; ++k) {
    order[k] = static_cast<int>(k);
    tally.area += r.area[k];
    const int s = r.status[k];
    ++tally.by_status[s < 0 ? 4 : s > 4 ? 4 : s];
    tally.window_pixels += r.pixels[3 * k];
    tally.ring_pixels += r.pixels[3 * k + 1];
    tally.weighted_pixels += r.pixels[3 * k + 2];
  }
  const int passes = radix_passes(key_limit);
  sort_by_key(order, r.root, passes, scratch);
  for (int k : order)
    if (r.status[k] == 0) emit(k);
  return record_steps(static_cast<std::int64_t>(r.count), key_limit);
}

}  // namespace dtflop::kernels
