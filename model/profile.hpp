// MachineProfile: who the machine is and the DTFLOP parameters measured or fitted on it.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace dtflop {

// Where a parameter's value came from.
enum class Provenance { probed, fitted, user };

std::string_view to_string(Provenance p);
std::optional<Provenance> provenance_from_string(std::string_view s);

// Every model parameter dtflop knows. A profile holds a subset: a parameter that was not
// measured (e.g. no GPU) is absent, never zero.
enum class Param {
  B_CG_pinned,     // host->device bandwidth, pinned host memory            [B/s]
  B_GC_pinned,     // device->host bandwidth, pinned host memory            [B/s]
  B_CG_pageable,   // host->device bandwidth, pageable host memory          [B/s]
  B_GC_pageable,   // device->host bandwidth, pageable host memory          [B/s]
  L_CG_pinned,     // per-transfer latency host->device, pinned             [s]
  L_GC_pinned,     // per-transfer latency device->host, pinned             [s]
  L_CG_pageable,   // per-transfer latency host->device, pageable           [s]
  L_GC_pageable,   // per-transfer latency device->host, pageable           [s]
  B_GG,            // device memory bandwidth seen by a kernel, read+write  [B/s]
  B_GG_copy,       // cudaMemcpy device->device, read+write counted         [B/s]
  B_host_1,        // host memory bandwidth, one thread (triad, r+w)        [B/s]
  B_host,          // host memory bandwidth, all threads (triad, r+w)       [B/s]
  V_C1_fp32,       // CPU FP32 rate, one thread                             [FLOP/s]
  V_C_fp32,        // CPU FP32 rate, all threads                            [FLOP/s]
  V_C1_fp64,       // CPU FP64 rate, one thread                             [FLOP/s]
  V_C_fp64,        // CPU FP64 rate, all threads                            [FLOP/s]
  V_G_fp32,        // GPU FP32 rate                                         [FLOP/s]
  V_G_fp64,        // GPU FP64 rate                                         [FLOP/s]
  L_launch,        // kernel launch overhead                                [s]
  L_sync,          // CPU threads' fork/join or barrier, all threads         [s]
  L_wave,          // fixed cost of one round of thread blocks on a GPU SM   [s]
  L_wait,          // host submits device work and waits for it (round trip) [s]
  B_GS,            // device memory -> shared-memory tile fills, all SMs    [B/s]
  B_llc_1,         // host bandwidth, working set in the last-level cache, 1 thread   [B/s]
  B_llc,           // host bandwidth, working set in the last-level cache, all threads [B/s]
  L_atomic,        // one of a series of atomic updates of one device address [s]
  // Pageable device->host copies go through the driver's pinned staging memory (docs/model.md):
  B_GC_staged,     // rate of the first S_GC_staged bytes of a copy (not overlapped)   [B/s]
  S_GC_staged,     // bytes of a copy that pass at B_GC_staged                         [B]
  S_GC_flat,       // bytes after those that cost nothing more; the rest at B_GC_pageable [B]
  K_CW,            // cost of a sliding-window FLOP (N_CW) relative to one at the CPU rate [x]
  K_CD,            // cost of a chained sliding-window FLOP (N_CD) relative to one at the CPU rate [x]
  K_CA,            // cost of an aligned-window FLOP (N_CA) relative to one at the CPU rate     [x]
  K_CW_all,        // K_CW with every hardware thread at work (cpu_threads > 1)          [x]
  K_CA_all,        // K_CA with every hardware thread at work (cpu_threads > 1)          [x]
  V_CS,            // rate of one chain of dependent additions (a plain sum, N_CS), one thread [FLOP/s]
  K_GR,            // cost of an across-rows GPU FLOP (N_GR) relative to one at V_G         [x]
  L_tree,          // one step of host k-d tree work (tree_steps)                          [s]
  L_net,           // one message between processes (MPI ping-pong: half a round trip)     [s]
  B_net,           // bytes per second of a message between processes (MPI ping-pong)      [B/s]
  L_peer,          // one point-to-point message between two GPUs (NCCL send/recv)          [s]
  B_peer,          // bandwidth of a point-to-point message between two GPUs (NCCL)         [B/s]
  L_allreduce,     // one all-reduce across the GPUs (NCCL, a small message)                 [s]
  B_allreduce,     // bytes per second an all-reduce moves per GPU (NCCL, large messages)    [B/s]
  L_pixel,         // one step of host scalar pixel work (pixel_steps)                      [s]
  B_L2,            // device bandwidth seen by a kernel, working set in the L2 cache (r+w)  [B/s]
  L_graph,         // one kernel of a CUDA graph, device side (graph_launches)              [s]
  L_pixel_all,     // L_pixel with every hardware thread at work (cpu_threads > 1)          [s]
  V_CM,            // rate of moving-least-squares field FLOPs (N_CM), one thread            [FLOP/s]
  V_CM_all,        // V_CM with every hardware thread at work (cpu_threads > 1)             [FLOP/s]
  V_GM,            // rate of one GPU thread's moving-least-squares chain (N_GM)          [FLOP/s]
  L_GP,            // one device step of per-dot pixel classification (gpu_pixel_steps)    [s]
  L_label,         // one labelled pixel of host pixel work (label_steps), one thread       [s]
  L_label_all,     // L_label with every hardware thread at work (cpu_threads > 1)          [s]
  L_hist,          // one pixel counted into a host histogram (hist_steps), one thread       [s]
  L_hist_all,      // L_hist with every hardware thread at work (cpu_threads > 1)           [s]
  L_scan,          // one other step of host pixel work (the rest of pixel_steps)           [s]
  L_scan_all,      // L_scan with every hardware thread at work (cpu_threads > 1)           [s]
  L_pass_all,      // a frame's pixel passes' fixed cost on every hardware thread (pixel_passes) [s]
  K_GW,            // cost of an along-row GPU window FLOP (N_GW) relative to one at V_G     [x]
  L_match,         // one step of the host's grid matching (match_steps)                    [s]
  L_record,        // one step of the host's pass over component records (record_steps)     [s]
  L_GF,            // one pixel of a device pass over a whole frame, a thread a pixel (gpu_frame_pixels) [s]
};

struct ParamInfo {
  Param id;
  std::string_view name;   // JSON key, e.g. "B_CG_pinned"
  std::string_view unit;   // "B/s", "s" or "FLOP/s"
  std::string_view what;   // human description
};

const std::vector<ParamInfo>& all_params();
const ParamInfo& info(Param p);
std::optional<Param> param_from_name(std::string_view name);
// Does `p` describe the GPU or the link to it (copies, kernels, device waits), rather than the host?
bool device_param(Param p);

struct Parameter {
  double value = 0;                    // in the unit of ParamInfo
  Provenance provenance = Provenance::probed;
  std::optional<double> uncertainty;   // half-width of a 95% interval, same unit
  std::optional<double> spread;        // relative spread of repeated measurements (e.g. IQR/median)
  std::string note;                    // how it was obtained (probe name, fit id...)
};

struct MachineIdentity {
  std::string hostname;
  std::string cpu_model;
  int cpu_cores = 0;       // physical cores
  int cpu_threads = 0;     // hardware threads
  std::int64_t cpu_llc_bytes = 0;       // last-level cache the system reports (sysfs); 0 = unknown
  // The last-level cache a process was measured to get (dtflop probe's cache ladder, docs/probe.md
  // cpu-memory); 0 = not measured, or the ladder showed no knee: the model then uses cpu_llc_bytes.
  std::int64_t cpu_llc_effective_bytes = 0;
  std::optional<double> cpu_clock_ghz;  // nominal clock when known
  std::string gpu_name;                 // empty when no GPU
  int gpu_sms = 0;                      // the GPU's multiprocessors; 0 = unknown or no GPU
  std::int64_t gpu_l2_bytes = 0;        // the GPU's L2 cache; 0 = unknown or no GPU
  std::string gpu_driver;
  std::string cuda_version;
  std::string measured_at;              // ISO 8601 UTC
};

// Same machine: the same CPU model and hardware thread count, and the same GPU (or none on
// both). The hostname is not compared: lent machines of one kind get a new name each time.
// When they differ, `why` (if given) says what differs, in words.
bool same_machine(const MachineIdentity& a, const MachineIdentity& b, std::string* why = nullptr);

// The last-level cache the model prices working sets against (docs/model.md 2.4): the measured
// one (cpu_llc_effective_bytes) when there is one, else what the system reports; 0 = unknown.
std::int64_t model_llc_bytes(const MachineIdentity& id);

// One line for people: "AMD EPYC 7B13 (2 threads) + NVIDIA H200 on host x".
std::string describe(const MachineIdentity& id);


class MachineProfile {
 public:
  MachineIdentity identity;
  std::map<std::string, std::string> metadata;  // free-form notes (e.g. chosen model variant)

  bool has(Param p) const { return params_.count(p) != 0; }
  const Parameter* find(Param p) const;
  // Throws MissingParameter when absent.
  const Parameter& get(Param p) const;
  void set(Param p, Parameter value);
  void erase(Param p) { params_.erase(p); }
  const std::map<Param, Parameter>& params() const { return params_; }

 private:
  std::map<Param, Parameter> params_;
};

}  // namespace dtflop
