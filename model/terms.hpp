// The terms of the DTFLOP model: one row per term of a prediction (dt_CG, lat_CG, ..., lat_wait),
// each saying what it counts, which parameters price it, which phase of a step it belongs to,
// in which variants it applies and how it adds up with the others.
//
// Everything that knows about terms derives from this table: predict() and required_params()
// (model/predict.cpp), the JSON of a Prediction (model/json_io.cpp), the calibration's measured
// components and the parameters a sample exercises (calibrate/), the printed prediction table
// (cli/model_tables.cpp) and the table in docs/model.md, section 5 (checked against
// terms_markdown() by tests/model/test_terms.cpp). Adding a term is a row here, a field of
// Prediction, and its count (a member of CostCounts with its row in count_fields()); section 5
// of docs/model.md walks through it.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

#include "model/cost_counts.hpp"
#include "model/predict.hpp"
#include "model/profile.hpp"

namespace dtflop {

// The part of a step a term's time belongs to: what a measurement times apart (a sample's
// components CG, GC, G and C, calibrate/sample.hpp), plus what no measured part holds.
enum class Phase {
  CG,    // host->device copies
  GC,    // device->host copies
  G,     // kernels: device memory traffic, arithmetic and their fixed costs
  C,     // CPU work
  wait,  // the host waiting for the device: in the total only
  net,   // messages between processes (a team of MPI processes): in the total only
};
std::string_view to_string(Phase p);
// What the phase is, for printed tables: "host->device copies", ..., "CPU work (dt_C)".
std::string_view describe(Phase p);
const std::vector<Phase>& all_phases();

// How a term adds up with the other terms of its phase.
enum class Combine {
  sum,      // added
  overlap,  // the phase's overlapping terms proceed at once: in the extended variant they take
            // their max (a kernel streams memory while it computes); elsewhere they are added
};
// The variant where overlapping terms take their max.
inline constexpr Variant kOverlapVariant = Variant::extended;

// A set of variants.
class Variants {
 public:
  constexpr Variants(std::initializer_list<Variant> vs) {
    for (Variant v : vs) bits_ |= 1u << static_cast<unsigned>(v);
  }
  constexpr bool contains(Variant v) const { return (bits_ >> static_cast<unsigned>(v)) & 1u; }
  // "every variant", or the names: "latency, memory, extended".
  std::string str() const;

 private:
  unsigned bits_ = 0;
};
inline constexpr Variants kEveryVariant{Variant::seed, Variant::latency, Variant::memory, Variant::extended};
inline constexpr Variants kLatencyVariants{Variant::latency, Variant::memory, Variant::extended};  // "latency+"
inline constexpr Variants kHostMemoryVariants{Variant::memory, Variant::extended};

// What pricing a term depends on besides the counts and the variant: facts of the profile.
struct Pricing {
  std::int64_t llc_bytes = 0;  // the machine's last-level cache (0: unknown)
  bool staging = false;        // price sized pageable device->host copies with the staging figures
                               // (the profile has them, has_staging(), or a fit is to find them)
  bool all_threads = false;    // price windows on cpu_threads > 1 with K_CW_all, K_CA_all (the
                               // profile has them, or a fit is to find them); else K_CW, K_CA
  bool serial = false;         // price serial chains (N_CS) at V_CS (the profile has it, or a fit is
                               // to find it); else at the CPU rate, as profiles made before it did
  std::int64_t gpu_l2_bytes = 0;  // the GPU's L2 cache where its share of N_GG is priced at B_L2 (the
                                  // profile has B_L2, or a fit is to find it); 0: all of it at B_GG
  bool graph = false;          // price a CUDA graph's kernels (graph_launches) at L_graph (the profile
                               // has it, or a fit is to find it); else at L_launch like the others
  bool pixel_all = false;      // price pixel steps on cpu_threads > 1 at L_pixel_all (the profile has
                               // it, or a fit is to find it); else at L_pixel, as profiles made before
                               // the probe measured it were fitted
  bool mls = false;            // price MLS field FLOPs (N_CM) at V_CM (the profile has it, or a fit is to
                               // find it); else at the CPU rate, as profiles made before the probe were
  bool mls_all = false;        // price them on cpu_threads > 1 at V_CM_all (likewise); else at V_CM
  bool gpu_mls = false;        // price a GPU thread's MLS chain (N_GM) at V_GM (the profile has it, or a fit
                               // is to find it); else not at all: its FLOPs are in N_G at the GPU's rate,
                               // as profiles made before the probe were fitted
  bool gpu_pixel = false;      // price the device's per-dot pixel classification (gpu_pixel_steps) at L_GP
                               // (the profile has it, or a fit is to find it); else not at all: its bytes
                               // are in N_GG at the device's bandwidth, as profiles made before it were fitted
  bool pixel_kinds = false;    // price pixel steps by kind: a labelling's (label_steps) at L_label, a
                               // histogram's (hist_steps) at L_hist, the rest at L_scan (the profile has the
                               // three, or a fit is to find them); else every pixel step at L_pixel, as
                               // profiles made before the probe timed them apart
  bool pixel_kinds_all = false;  // price them on cpu_threads > 1 at L_label_all, L_hist_all and L_scan_all
  bool pixel_pass_all = false;   // and, so priced, a frame's passes (pixel_passes) at L_pass_all each
  bool along_row = false;        // price the GPU's along-row window FLOPs (N_GW) at K_GW times the others (the
                                 // profile has K_GW, or a fit is to find it); else at the GPU's rate, as
                                 // profiles made before the probe measured it were fitted
  bool grid_match = false;       // price the grid matching's steps (match_steps) at L_match (the profile has
                                 // it, or a fit is to find it); else at L_tree, as profiles made before the
                                 // cpu-match probe priced the matching (then a k-d tree's)
  bool gpu_frame = false;        // price the device's whole-frame passes (gpu_frame_pixels) at L_GF and leave
                                 // their values (N_GG_frame) out of dt_GG (the profile has L_GF, or a fit is to
                                 // find it); else their bytes at the device's bandwidth, as profiles made before
                                 // the gpu-frame-pass probe were fitted
  bool records = false;          // price the host's pass over component records (record_steps) at L_record
                                 // (the profile has it, or a fit is to find it); else not at all, as
                                 // profiles made before the cpu-records probe were fitted
  static Pricing of(const MachineProfile& profile);
};

// Which parameters a prediction of `counts` with `variant` needs (only those whose counts are
// non-zero), priced as `pricing` says; useful to report everything missing at once. A default
// Pricing prices as a profile with none of the optional figures would; Pricing::of(profile) as
// predict() does.
std::vector<Param> required_params(const CostCounts& counts, Variant variant, const Pricing& pricing = {});

// How a term is priced: three functions of the counts.
struct Price {
  // Do the counts have any of the term? (No: it needs no parameter and costs nothing.)
  bool (*counted)(const CostCounts& counts);
  // The parameters it needs for counted `counts` in `variant` (one of its variants).
  std::vector<Param> (*needs)(const CostCounts& counts, Variant variant, const Pricing& pricing);
  // Its seconds for counted `counts` in `variant`; the profile holds what needs() names.
  double (*seconds)(const MachineProfile& profile, const CostCounts& counts, Variant variant,
                    const Pricing& pricing);
};

struct Term {
  std::string_view name;      // its Prediction field and JSON key
  double Prediction::*field;
  Phase phase;
  Variants variants;          // where it applies; elsewhere it is zero and needs nothing
  Combine combine;
  std::string_view count;     // what it prices, as a formula of CostCounts fields
  std::string_view params;    // the parameters that price it, and which ones apply when
  std::string_view label;     // what it is, for printed tables
  Price price;

  bool applies(Variant v) const { return variants.contains(v); }
};

// The terms, by phase (CG, GC, G, C, wait); inside a phase, in the order they add up.
const std::vector<Term>& terms();

// Seconds of `phase` in `p`: its overlapping terms (added, or in the extended variant the
// largest) plus the others. predict() makes dt_C and the total of these.
double phase_seconds(const Prediction& p, Phase phase);
// Do the counts have some term of `phase`, in any variant?
bool counts_phase(const CostCounts& counts, Phase phase);

// The Markdown tables of docs/model.md, section 5: the terms, and the counts (count_fields()).
std::string terms_markdown();
std::string counts_markdown();

}  // namespace dtflop
