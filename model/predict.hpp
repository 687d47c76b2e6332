// The DTFLOP prediction: per-component times from a machine profile and cost counts.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "model/cost_counts.hpp"
#include "model/profile.hpp"

namespace dtflop {

// Model variants (docs/model.md derives each), from the simplest:
//  seed     - eqs. 3.2-3.9 exactly: every component P*N/B or N/V, summed.
//  latency  - seed + a latency per transfer, per kernel launch, per round (wave) of thread
//             blocks, per host wait for the device and per CPU thread sync (alpha + bytes/B),
//             the kernels' shared-memory tile fills before they compute, and their FLOPs whose
//             taps read across rows of device memory (N_GR) at K_GR times the others.
//  memory   - latency + the host memory traffic of CPU work, summed with its arithmetic as the
//             seed sums device traffic with device arithmetic (no overlap anywhere), and the
//             CPU's load-bound sliding-window FLOPs (N_CW) at K_CW times the cost of the others.
//  extended - latency + overlap: inside the device, memory traffic and arithmetic overlap
//             (max instead of sum), and on the host, arithmetic (N_CW priced as in memory) and
//             memory traffic overlap.
//
// Each variant but the seed extends one simpler variant: latency the seed, memory and extended
// the latency variant. memory and extended price the same terms with the same parameters and
// differ only in how they combine them (sum or overlap), so neither is simpler than the other:
// the variants form a tree, seed < latency < {memory, extended}, not a chain.
enum class Variant { seed, latency, memory, extended };

std::string_view to_string(Variant v);
std::optional<Variant> variant_from_string(std::string_view s);
const std::vector<Variant>& all_variants();
// "seed, latency, memory or extended": the names, for help texts and messages.
std::string variant_names(std::string_view last_separator = " or ");
// The variant `v` extends (latency for memory and extended), or none for the seed.
std::optional<Variant> simpler_variant(Variant v);

struct Prediction {
  Variant variant = Variant::seed;
  double dt_CG = 0;      // bandwidth part of host->device  [s]
  double dt_GC = 0;      // bandwidth part of device->host  [s]
  double dt_GG = 0;      // device memory traffic           [s]
  double dt_C = 0;       // CPU work: dt_C_arith and dt_CC (added; extended: the larger) + lat_sync [s]
  double dt_C_arith = 0; // CPU arithmetic, N_CW priced K_CW (memory, extended) [s]
  double dt_CC = 0;      // host memory traffic of CPU work (memory, extended) [s]
  double dt_G = 0;       // GPU arithmetic                  [s]
  double lat_CG = 0;     // transfers_CG x per-transfer latency
  double lat_GC = 0;     // transfers_GC x per-transfer latency
  double lat_launch = 0; // launches x launch overhead (those of CUDA graphs apart where the profile has L_graph)
  double lat_graph = 0;  // graph_launches x L_graph: kernels a CUDA graph starts (latency+; device component)
  double lat_sync = 0;   // cpu_syncs x CPU thread sync (part of dt_C)
  double lat_wave = 0;   // waves x per-wave cost of thread blocks
  double lat_atomic = 0;  // atomics x one serialized atomic update (device component)
  double lat_GM = 0;     // N_GM / V_GM: one GPU thread's MLS chain (latency+, where the profile has V_GM; device)
  double lat_GP = 0;     // gpu_pixel_steps x L_GP: per-dot pixel classification (latency+, where the profile has L_GP; device)
  double lat_wait = 0;   // host_waits x host round trip to the device (in the total only)
  double lat_lap_CG = 0; // laps_CG x L_wait: host-timed laps' round trips, in dt_CG's component (latency+)
  double lat_lap_GC = 0; // laps_GC x L_wait: likewise, device->host copies
  double lat_lap_G = 0;  // laps_G x L_wait: likewise, kernels (device component)
  double lat_tree = 0;   // tree_steps x one step of host k-d tree work (CPU component, latency+)
  double lat_match = 0;  // match_steps x one step of the host's grid matching (CPU component, latency+)
  double lat_record = 0; // record_steps x one step of the host's pass over component records (CPU component, latency+)
  double lat_pixel = 0;  // pixel_steps x one step of host scalar pixel work (CPU component, latency+)
  double lat_GF = 0;     // gpu_frame_pixels x L_GF: the device's whole-frame passes (latency+, where the profile has L_GF; device)
  double dt_GS = 0;      // shared-memory tile fills, P N_GS / B_GS (latency+; device component)
  double lat_net = 0;    // net_messages x L_net: messages between processes (latency+; total only)
  double dt_net = 0;     // net_bytes / B_net: their bytes (total only)
  double dt_peer = 0;    // halo messages between partitions: peer_messages L_peer + P N_peer / B_peer
                         // (on one device: L_launch, B_GG_copy) (latency+; device component)
  double dt_allreduce = 0;  // all-reduces: collectives L_allreduce + collective_bytes / B_allreduce
                            // (on one device: L_launch, B_GG) (latency+; device component)
  double total = 0;

  double dt_trans() const { return dt_CG + dt_GC + dt_GG; }  // eq. 3.4
  // What the kernels pay besides their traffic and arithmetic (latency+): launches, rounds of
  // blocks, serialized atomics, tile fills.
  // The kernels' terms that add to their traffic and arithmetic (model/terms.cpp).
  double device_overheads() const;
};

// The parameters predict(profile, counts, variant) reads: required_params() (model/terms.hpp) with
// what the profile
// holds deciding the pricing (its serial rate, all-thread figures, L2, graph and pixel figures).
std::vector<Param> priced_params(const MachineProfile& profile, const CostCounts& counts, Variant variant);
// Does the profile have the three staging figures of pageable device->host copies?
bool has_staging(const MachineProfile& profile);
// Seconds a pageable device->host copy of `bytes` takes past its latency:
//   min(b, S_GC_staged) / B_GC_staged + max(b - S_GC_staged - S_GC_flat, 0) / B_GC_pageable
// (docs/model.md 2.2). The profile must have the staging figures.
double staged_copy_seconds(const MachineProfile& profile, std::int64_t bytes);

// Throws MissingParameter (naming the parameter and what to do) when the profile lacks one.
// The terms and how they add up are the table of model/terms.hpp.
Prediction predict(const MachineProfile& profile, const CostCounts& counts, Variant variant);

// The richest variant at or below `wanted` (walking simpler_variant(): extended or memory, then
// latency, then seed) whose parameters for `counts` the profile holds; it never fails where
// the seed variant can predict. `missing` (when given) receives what the profile lacks for
// `wanted` (empty when it predicts with `wanted`), for a note such as fallback_note(). Throws
// MissingParameter, as predict() would, when even the seed lacks a parameter (e.g. a GPU
// computation and a profile of a machine without a GPU).
Variant richest_supported_variant(const MachineProfile& profile, const CostCounts& counts, Variant wanted,
                                  std::vector<Param>* missing = nullptr);
// One line for stderr when richest_supported_variant() fell back from `wanted` to `used`: what
// was missing and how to get it, e.g. "the machine profile lacks K_CW (...): predicting with
// the latency variant instead of memory; fit it with `dtflop calibrate` (docs/calibration.md)".
std::string fallback_note(Variant wanted, Variant used, const std::vector<Param>& missing);

// The metadata key under which `dtflop calibrate` records the variant its cross-validation chose.
inline constexpr const char* kChosenVariantKey = "model_variant";
// The variant a fitted profile chose (metadata "model_variant"), or none when the profile does
// not name one (a probed profile). Throws InputError when it names an unknown variant.
std::optional<Variant> chosen_variant(const MachineProfile& profile);

// Real-time condition (eq. 3.1): dt <= dt_p.
inline bool meets_deadline(const Prediction& p, double dt_p) { return p.total <= dt_p; }

// The CPU rate that applies to work on `threads` threads at `precision`:
// one thread -> V_C1; threads >= all hardware threads -> V_C (all threads);
// otherwise threads x V_C1, capped at V_C.
double cpu_rate(const MachineProfile& profile, Precision precision, int threads);
// Host memory bandwidth for `threads` threads, same rule as cpu_rate.
double host_bandwidth(const MachineProfile& profile, int threads);
// The share of the CPU work's host memory traffic the last-level cache does not serve:
// min(1, cpu_footprint / LLC); 1 when either is unknown (zero). A working set of a fraction f of
// the cache finds about f of its lines evicted between uses by the other data and by other
// tenants of the cache, and the rest there (docs/model.md).
double llc_share_missed(const MachineProfile& profile, const CostCounts& counts);
// Seconds per byte of the CPU work's host traffic: w / B_host + (1 - w) / B_llc, w =
// llc_share_missed (B_host_1 / B_llc_1 for one thread, scaled as cpu_rate).
double host_seconds_per_byte(const MachineProfile& profile, const CostCounts& counts);

}  // namespace dtflop
