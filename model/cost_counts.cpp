#include "model/cost_counts.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop {

std::string_view to_string(HostMemory m) { return m == HostMemory::pinned ? "pinned" : "pageable"; }
std::string_view to_string(Precision p) { return p == Precision::fp64 ? "fp64" : "fp32"; }
std::string_view to_string(PeerPath p) { return p == PeerPath::device ? "device" : "link"; }

namespace {
std::int64_t tree_depth(std::int64_t n) {
  std::int64_t d = 1;
  for (std::int64_t cells = kKdTreeLeaf; cells < n; cells *= 2) ++d;
  return d;
}
}  // namespace

std::int64_t tree_build_steps(std::int64_t n) { return n * tree_depth(n); }
std::int64_t tree_search_steps(std::int64_t n, std::int64_t k) { return tree_depth(n) + kKdTreeLeaf + k; }

void add_copies(std::vector<CopySize>& sizes, std::int64_t bytes, std::int64_t count) {
  if (count == 0) return;
  auto it = std::find_if(sizes.begin(), sizes.end(), [bytes](const CopySize& s) { return s.bytes == bytes; });
  if (it != sizes.end()) it->count += count;
  else sizes.push_back({bytes, count});
}

const std::vector<CountField>& count_fields() {
  using C = CostCounts;
  using A = CountField::Accumulate;
  static const std::vector<CountField> table = {
      {"N_CG", &C::N_CG, "values", "host -> device"},
      {"transfers_CG", &C::transfers_CG, "copies", "host -> device"},
      {"N_GC", &C::N_GC, "values", "device -> host"},
      {"transfers_GC", &C::transfers_GC, "copies", "device -> host"},
      {"N_GG", &C::N_GG, "values", "through device memory (reads + writes)"},
      {"N_G", &C::N_G, "FLOPs", "on the GPU"},
      {"N_GR", &C::N_GR, "FLOPs", "of N_G, whose taps each read another row of device memory", A::sum, &C::N_G},
      {"N_GW", &C::N_GW, "FLOPs", "of N_G, whose taps each read device memory along a row (a load per FMA)", A::sum, &C::N_G},
      {"N_GM", &C::N_GM, "FLOPs", "of one GPU thread's moving-least-squares field (a point's chain; its points side by side)"},
      {"N_GS", &C::N_GS, "values", "copied into shared-memory tiles (per busiest-SM round x SMs)"},
      {"gpu_pixel_steps", &C::gpu_pixel_steps, "steps", "of per-dot pixel classification on the device (a window pixel each)"},
      {"gpu_frame_pixels", &C::gpu_frame_pixels, "pixels", "the device's whole-frame passes visit, a thread a pixel each pass"},
      {"N_GG_frame", &C::N_GG_frame, "values", "of N_GG, moved by those passes", A::sum, &C::N_GG},
      {"launches", &C::launches, "launches", "of kernels"},
      {"graph_launches", &C::graph_launches, "launches", "of launches, kernels of a CUDA graph (started by the device)",
       A::sum, &C::launches},
      {"waves", &C::waves, "rounds", "of thread blocks on the busiest GPU multiprocessor"},
      {"atomics", &C::atomics, "updates", "of one device address, one after another"},
      {"host_waits", &C::host_waits, "waits", "of the host for device work it submitted"},
      {"laps_CG", &C::laps_CG, "laps", "host-timed, of host->device copies and the host's wait for them"},
      {"laps_GC", &C::laps_GC, "laps", "host-timed, of device->host copies and the host's wait for them"},
      {"laps_G", &C::laps_G, "laps", "host-timed, of kernels and the host's wait for them"},
      {"N_C", &C::N_C, "FLOPs", "on the CPU"},
      {"N_CW", &C::N_CW, "FLOPs", "of N_C, of sliding-window loops (one unaligned load per FMA)", A::sum, &C::N_C},
      {"N_CD", &C::N_CD, "FLOPs", "of N_C, of chained sliding-window loops (each tap's addition waits for the last)",
       A::sum, &C::N_C},
      {"N_CA", &C::N_CA, "FLOPs", "of N_C, of aligned vector windows (each row loaded once for two FMAs)", A::sum, &C::N_C},
      {"N_CS", &C::N_CS, "FLOPs", "of N_C, of one serial chain of dependent additions (a plain sum)", A::sum, &C::N_C},
      {"N_CM", &C::N_CM, "FLOPs", "of N_C, of moving-least-squares fields (chains of rotations, roots and divisions)",
       A::sum, &C::N_C},
      {"N_CC", &C::N_CC, "values", "through host memory by CPU work"},
      {"N_CC_pixel", &C::N_CC_pixel, "values", "of N_CC, of the passes priced as pixel steps (histogram, threshold, labelling, windows)",
       A::sum, &C::N_CC},
      {"tree_steps", &C::tree_steps, "steps", "of host k-d tree builds and searches"},
      {"match_steps", &C::match_steps, "steps", "of the host's grid matching: points binned, queries answered"},
      {"record_steps", &C::record_steps, "steps", "of the host's pass over component records: tallied, ordered by radix passes, handed on"},
      {"pixel_steps", &C::pixel_steps, "steps", "of host scalar pixel loops: pixels visited, neighbourhood labels read"},
      {"label_steps", &C::label_steps, "steps", "of pixel_steps, pixels labelled (threshold and connected components)",
       A::sum, &C::pixel_steps},
      {"hist_steps", &C::hist_steps, "steps", "of pixel_steps, pixels counted into a histogram", A::sum, &C::pixel_steps},
      {"pixel_passes", &C::pixel_passes, "passes", "of frames through the pixel loops (a fixed cost each on several threads)"},
      {"net_messages", &C::net_messages, "messages", "sent by one process to others (MPI)"},
      {"net_bytes", &C::net_bytes, "bytes", "of those messages' payloads"},
      {"cpu_syncs", &C::cpu_syncs, "syncs", "of the CPU threads: forks, joins, barriers"},
      {"peer_messages", &C::peer_messages, "messages", "of halo rows the busiest device sends to other partitions"},
      {"N_peer", &C::N_peer, "values", "in those messages"},
      {"collectives", &C::collectives, "all-reduces", "across the partitions of one grid"},
      {"collective_bytes", &C::collective_bytes, "bytes", "each device contributes to them"},
      {"gpu_footprint", &C::gpu_footprint, "bytes", "of device memory the kernels touch in one step (0: not counted)",
       A::max},
      {"cpu_footprint", &C::cpu_footprint, "bytes", "of host memory the CPU work touches in one step (0: not counted)",
       A::max},
  };
  return table;
}

const CountField& count_field(std::int64_t CostCounts::*member) {
  const auto& t = count_fields();
  auto it = std::find_if(t.begin(), t.end(), [member](const CountField& f) { return f.member == member; });
  return *it;  // every integer member of CostCounts has a row
}

void check_consistent(const CostCounts& c) {
  if (!c.copies_GC.empty()) {
    std::int64_t bytes = 0, copies = 0;
    for (const CopySize& s : c.copies_GC) bytes += s.bytes * s.count, copies += s.count;
    if (bytes != c.P * c.N_GC || copies != c.transfers_GC)
      throw InputError(fmt::format(
          "the counts list device->host copies of {} bytes in {} copies, but P N_GC is {} bytes in "
          "transfers_GC = {} copies; the workload's counts are inconsistent",
          bytes, copies, c.P * c.N_GC, c.transfers_GC));
  }
  for (const CountField& f : count_fields()) {
    if (!f.part_of) continue;
    const CountField& whole = count_field(f.part_of);
    const std::int64_t n = c.*f.member, total = c.*f.part_of;
    if (n < 0 || n > total)
      throw InputError(fmt::format("the counts give {} = {}, not between 0 and {} = {} ({} counts {} {}): the "
                                   "workload's counts are inconsistent",
                                   f.name, n, whole.name, total, f.name, f.unit, f.meaning));
  }
  if (c.label_steps + c.hist_steps > c.pixel_steps)
    throw InputError(fmt::format("the counts give label_steps = {} and hist_steps = {}, together more than "
                                 "pixel_steps = {} (a pixel step is of one of these kinds at most): the workload's "
                                 "counts are inconsistent",
                                 c.label_steps, c.hist_steps, c.pixel_steps));
  if (c.N_GR + c.N_GW > c.N_G)
    throw InputError(fmt::format("the counts give N_GR = {} and N_GW = {}, together more than N_G = {} (a GPU FLOP's "
                                 "tap reads across rows or along one, not both): the workload's counts are inconsistent",
                                 c.N_GR, c.N_GW, c.N_G));
  // The two kinds of sliding-window FLOPs are priced apart, so none is in both.
  if (c.N_CW + c.N_CD + c.N_CA + c.N_CS + c.N_CM > c.N_C)
    throw InputError(fmt::format("the counts give N_CW = {}, N_CD = {}, N_CA = {}, N_CS = {} and N_CM = {}, together "
                                 "more than N_C = {} (a CPU FLOP is of one of these kinds at most): the workload's "
                                 "counts are inconsistent",
                                 c.N_CW, c.N_CD, c.N_CA, c.N_CS, c.N_CM, c.N_C));
}

CostCounts& CostCounts::operator+=(const CostCounts& o) {
  // The messages between partitions travel one way in a computation: the one that has them says.
  if (o.peer_messages > 0 || o.N_peer > 0 || o.collectives > 0) peer_path = o.peer_path;
  for (const CountField& f : count_fields())
    this->*f.member = f.accumulate == CountField::Accumulate::sum ? this->*f.member + o.*f.member
                                                                  : std::max(this->*f.member, o.*f.member);
  cpu_threads = std::max(cpu_threads, o.cpu_threads);
  for (const CopySize& s : o.copies_GC) add_copies(copies_GC, s.bytes, s.count);
  return *this;
}

CostCounts CostCounts::scaled(std::int64_t steps) const {
  CostCounts c = *this;
  for (const CountField& f : count_fields())
    if (f.accumulate == CountField::Accumulate::sum) c.*f.member *= steps;
  for (CopySize& s : c.copies_GC) s.count *= steps;
  return c;
}

}  // namespace dtflop
