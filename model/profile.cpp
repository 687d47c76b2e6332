#include "model/profile.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "model/errors.hpp"

namespace dtflop {

std::string_view to_string(Provenance p) {
  switch (p) {
    case Provenance::probed: return "probed";
    case Provenance::fitted: return "fitted";
    case Provenance::user: return "user";
  }
  return "?";
}

std::optional<Provenance> provenance_from_string(std::string_view s) {
  for (auto p : {Provenance::probed, Provenance::fitted, Provenance::user})
    if (to_string(p) == s) return p;
  return std::nullopt;
}

const std::vector<ParamInfo>& all_params() {
  static const std::vector<ParamInfo> table = {
      {Param::B_CG_pinned, "B_CG_pinned", "B/s", "host->device bandwidth, pinned host memory"},
      {Param::B_GC_pinned, "B_GC_pinned", "B/s", "device->host bandwidth, pinned host memory"},
      {Param::B_CG_pageable, "B_CG_pageable", "B/s", "host->device bandwidth, pageable host memory"},
      {Param::B_GC_pageable, "B_GC_pageable", "B/s", "device->host bandwidth, pageable host memory"},
      {Param::L_CG_pinned, "L_CG_pinned", "s", "latency per host->device copy, pinned"},
      {Param::L_GC_pinned, "L_GC_pinned", "s", "latency per device->host copy, pinned"},
      {Param::L_CG_pageable, "L_CG_pageable", "s", "latency per host->device copy, pageable"},
      {Param::L_GC_pageable, "L_GC_pageable", "s", "latency per device->host copy, pageable"},
      {Param::B_GG, "B_GG", "B/s", "device memory bandwidth seen by a kernel (read+write)"},
      {Param::B_GG_copy, "B_GG_copy", "B/s", "device->device cudaMemcpy bandwidth (read+write)"},
      {Param::B_host_1, "B_host_1", "B/s", "host memory bandwidth, one thread (read+write)"},
      {Param::B_host, "B_host", "B/s", "host memory bandwidth, all threads (read+write)"},
      {Param::V_C1_fp32, "V_C1_fp32", "FLOP/s", "CPU FP32 rate, one thread"},
      {Param::V_C_fp32, "V_C_fp32", "FLOP/s", "CPU FP32 rate, all threads"},
      {Param::V_C1_fp64, "V_C1_fp64", "FLOP/s", "CPU FP64 rate, one thread"},
      {Param::V_C_fp64, "V_C_fp64", "FLOP/s", "CPU FP64 rate, all threads"},
      {Param::V_G_fp32, "V_G_fp32", "FLOP/s", "GPU FP32 rate"},
      {Param::V_G_fp64, "V_G_fp64", "FLOP/s", "GPU FP64 rate"},
      {Param::L_launch, "L_launch", "s", "kernel launch overhead"},
      {Param::L_sync, "L_sync", "s", "CPU threads' fork/join or barrier (all threads)"},
      {Param::L_wave, "L_wave", "s", "fixed cost of one round of thread blocks on a GPU multiprocessor"},
      {Param::L_wait, "L_wait", "s", "host round trip to the GPU: submit work and wait for it to finish"},
      {Param::B_GS, "B_GS", "B/s", "kernels' tile fills, device memory -> shared memory, all multiprocessors"},
      {Param::B_llc_1, "B_llc_1", "B/s", "host bandwidth with the working set in the last-level cache, one thread"},
      {Param::B_llc, "B_llc", "B/s", "host bandwidth with the working set in the last-level cache, all threads"},
      {Param::L_atomic, "L_atomic", "s", "one of a series of atomic updates of one device address (they serialize)"},
      {Param::B_GC_staged, "B_GC_staged", "B/s", "device->host pageable: rate of a copy's first S_GC_staged bytes"},
      {Param::S_GC_staged, "S_GC_staged", "B", "device->host pageable: bytes of a copy that pass at B_GC_staged"},
      {Param::S_GC_flat, "S_GC_flat", "B", "device->host pageable: bytes after S_GC_staged that cost nothing more"},
      {Param::K_CW, "K_CW", "x", "cost of a sliding-window CPU FLOP (one unaligned load per FMA) relative to one at the CPU rate"},
      {Param::K_CD, "K_CD", "x", "cost of a chained sliding-window CPU FLOP (few outputs in flight, each tap's addition waits for the one before) relative to one at the CPU rate"},
      {Param::K_CA, "K_CA", "x", "cost of an aligned-window CPU FLOP (vectorized, each row segment loaded once for two FMAs) relative to one at the CPU rate"},
      {Param::K_CW_all, "K_CW_all", "x", "K_CW with every hardware thread at work (its rate against the all-thread FMA rate)"},
      {Param::K_CA_all, "K_CA_all", "x", "K_CA with every hardware thread at work (its rate against the all-thread FMA rate)"},
      {Param::V_CS, "V_CS", "FLOP/s", "CPU rate of one chain of dependent additions (a plain sum: each addition waits for the one before), one thread"},
      {Param::K_GR, "K_GR", "x", "cost of a GPU FLOP whose tap reads another row of device memory relative to one at V_G"},
      {Param::L_tree, "L_tree", "s", "one step of host k-d tree work: a point placed at one level, a level descended or a leaf point examined"},
      {Param::L_net, "L_net", "s", "one message between two processes (MPI ping-pong, half a round trip of a small message)"},
      {Param::B_net, "B_net", "B/s", "bandwidth of a message between two processes (MPI ping-pong of large messages)"},
      {Param::L_peer, "L_peer", "s", "one point-to-point message between two GPUs (NCCL send/recv of a small message)"},
      {Param::B_peer, "B_peer", "B/s", "bandwidth of a point-to-point message between two GPUs (NCCL send/recv of large messages)"},
      {Param::L_allreduce, "L_allreduce", "s", "one all-reduce across the GPUs (NCCL, a small message)"},
      {Param::B_allreduce, "B_allreduce", "B/s", "bytes per GPU per second of an all-reduce across the GPUs (NCCL, large messages)"},
      {Param::B_L2, "B_L2", "B/s", "device bandwidth seen by a kernel whose working set stays in the GPU's L2 cache (read+write)"},
      {Param::L_graph, "L_graph", "s", "one kernel of a CUDA graph, device side: what a kernel launched from a graph costs beside its work"},
      {Param::L_pixel, "L_pixel", "s", "one step of host scalar pixel work: a pixel counted into a histogram, labelled, classified, or a label of its neighbourhood read"},
      {Param::L_pixel_all, "L_pixel_all", "s", "L_pixel with every hardware thread at work: the wall time of a step of pixel work the threads share"},
      {Param::V_CM, "V_CM", "FLOP/s", "CPU rate of moving-least-squares field arithmetic (a support dot's chain of rotations, square roots and divisions), one thread"},
      {Param::V_CM_all, "V_CM_all", "FLOP/s", "V_CM with every hardware thread at work: the FLOPs of all threads per second of wall time"},
      {Param::V_GM, "V_GM", "FLOP/s", "rate of one GPU thread's moving-least-squares field (a point's chain of rotations, square roots and divisions), the points' threads side by side"},
      {Param::L_label, "L_label", "s", "one pixel of host labelling (a threshold and an 8-connected labelling with statistics, as OpenCV does it), one thread"},
      {Param::L_label_all, "L_label_all", "s", "L_label with every hardware thread at work: the wall time of a labelled pixel the threads share"},
      {Param::L_hist, "L_hist", "s", "one pixel counted into a 256-bin histogram on the host (Otsu's threshold), one thread"},
      {Param::L_hist_all, "L_hist_all", "s", "L_hist with every hardware thread at work: what a histogram's count costs while the threads share the analysis"},
      {Param::L_scan, "L_scan", "s", "one step of host scalar pixel work other than a labelling's or a histogram's: a window pixel classified, or a label of its neighbourhood read, one thread"},
      {Param::L_scan_all, "L_scan_all", "s", "L_scan with every hardware thread at work: the wall time of such a step the threads share"},
      {Param::L_pass_all, "L_pass_all", "s", "the fixed cost of a frame's pixel passes with every hardware thread at work, beside their steps at L_label_all, L_hist_all and L_scan_all: threads started, stripes merged, the parallel labelling's set-up"},
      {Param::K_GW, "K_GW", "x", "cost of a GPU FLOP whose tap reads device memory along a row (the line the tap before read, or the next) relative to one at V_G"},
      {Param::L_match, "L_match", "s", "one step of the host's grid matching: a point binned into the grid or a query answered from it"},
      {Param::L_record, "L_record", "s", "one step of the host's pass over a GPU labelling's component records: a record tallied, placed by one radix pass of its root, or handed on"},
      {Param::L_GF, "L_GF", "s", "one pixel of a device pass over a whole frame, a thread a pixel (a threshold, a labelling's union or relabelling, a histogram's count), its reads and writes included"},
      {Param::L_GP, "L_GP", "s", "one step of the device's per-dot pixel classification: a window pixel of a dot classified (its own, ring, or ignored, from its neighbourhood's labels), the dots' blocks side by side"},
  };
  return table;
}

const ParamInfo& info(Param p) {
  const auto& t = all_params();
  auto it = std::find_if(t.begin(), t.end(), [p](const ParamInfo& i) { return i.id == p; });
  return *it;  // every enumerator is in the table (checked by a unit test)
}

std::optional<Param> param_from_name(std::string_view name) {
  for (const auto& i : all_params())
    if (i.name == name) return i.id;
  return std::nullopt;
}

const Parameter* MachineProfile::find(Param p) const {
  auto it = params_.find(p);
  return it == params_.end() ? nullptr : &it->second;
}

const Parameter& MachineProfile::get(Param p) const {
  if (const auto* v = find(p)) return *v;
  const auto& i = info(p);
  throw MissingParameter(fmt::format(
      "the machine profile has no {} ({}); measure it with `dtflop probe` on a machine that "
      "has it, or set it in the profile by hand",
      i.name, i.what));
}

void MachineProfile::set(Param p, Parameter value) { params_[p] = std::move(value); }

bool device_param(Param p) {
  switch (p) {
    case Param::B_host_1:
    case Param::B_host:
    case Param::V_C1_fp32:
    case Param::V_C_fp32:
    case Param::V_C1_fp64:
    case Param::V_C_fp64:
    case Param::L_sync:
    case Param::B_llc_1:
    case Param::B_llc:
    case Param::K_CW:
    case Param::K_CD:
    case Param::V_CS:
    case Param::K_CA:
    case Param::K_CW_all:
    case Param::K_CA_all:
    case Param::L_tree:
    case Param::L_match:
    case Param::L_record:
    case Param::L_pixel:
    case Param::L_pixel_all:
    case Param::L_label:
    case Param::L_label_all:
    case Param::L_hist:
    case Param::L_hist_all:
    case Param::L_scan:
    case Param::L_scan_all:
    case Param::L_pass_all:
    case Param::V_CM:
    case Param::V_CM_all:
    case Param::L_net:
    case Param::B_net:
      return false;
    default:
      return true;
  }
}

namespace {

std::string trim(std::string s) {
  const auto b = s.find_first_not_of(" \t");
  const auto e = s.find_last_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  s = s.substr(b, e - b + 1);
  // Collapse runs of spaces ("Intel(R) Xeon(R)  CPU" -> one space).
  std::string out;
  for (char c : s)
    if (!(c == ' ' && !out.empty() && out.back() == ' ')) out += c;
  return out;
}

std::string normalized(const std::string& s) { return trim(s); }

}  // namespace

bool same_machine(const MachineIdentity& a, const MachineIdentity& b, std::string* why) {
  std::string diff;
  auto add = [&diff](std::string s) { diff += (diff.empty() ? "" : "; ") + s; };
  if (normalized(a.cpu_model) != normalized(b.cpu_model))
    add(fmt::format("CPU '{}' vs '{}'", a.cpu_model, b.cpu_model));
  if (a.cpu_threads != b.cpu_threads)
    add(fmt::format("{} vs {} hardware threads", a.cpu_threads, b.cpu_threads));
  if (normalized(a.gpu_name) != normalized(b.gpu_name))
    add(fmt::format("GPU '{}' vs '{}'", a.gpu_name.empty() ? "none" : a.gpu_name,
                    b.gpu_name.empty() ? "none" : b.gpu_name));
  if (why) *why = diff;
  return diff.empty();
}

std::int64_t model_llc_bytes(const MachineIdentity& id) {
  return id.cpu_llc_effective_bytes > 0 ? id.cpu_llc_effective_bytes : id.cpu_llc_bytes;
}

std::string describe(const MachineIdentity& id) {
  std::string s = fmt::format("{} ({} threads)", id.cpu_model.empty() ? "unknown CPU" : id.cpu_model,
                              id.cpu_threads);
  if (!id.gpu_name.empty()) s += " + " + id.gpu_name;
  if (!id.hostname.empty()) s += " on host " + id.hostname;
  return s;
}

}  // namespace dtflop
