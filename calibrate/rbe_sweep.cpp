#include "calibrate/rbe_sweep.hpp"

#include <time.h>

#include <algorithm>
#include <fstream>
#include <random>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/json_io.hpp"

namespace dtflop::calib {

using nlohmann::json;

RbeSweepSettings with_defaults(RbeSweepSettings s, bool device) {
  if (s.steps <= 0) s.steps = device ? 10 : 1;
  if (s.repetitions <= 0) s.repetitions = device ? 7 : 5;
  if (s.warmup < 0) s.warmup = device ? 2 : 1;
  return s;
}

std::string rbe_key(const std::string& backend, const rbe::Shape& sh, const rbe::BackendOptions& o) {
  std::string pred = "auto";
  if (o.prediction) pred = *o.prediction == rbe::Prediction::separable ? "separable" : "full";
  return fmt::format("rbe/{}/{}x{}/k{}x{}/{}/threads={}/layout={}/graph={}/prediction={}", backend, sh.nx,
                     sh.ny, sh.Ix, sh.Iy, to_string(o.host_memory), o.threads, rbe::to_string(o.layout),
                     o.graph ? 1 : 0, pred);
}

namespace {

PlanItem item_for(const rbe::Shape& sh, const RbeSweepSettings& st) {
  rbe::validate(sh);
  PlanItem it;
  it.key = rbe_key(st.backend, sh, st.options);
  it.label = fmt::format("{} {}x{} k{}x{}", st.backend, sh.nx, sh.ny, sh.Ix, sh.Iy);
  it.parameters = {{"nx", sh.nx}, {"ny", sh.ny}, {"Ix", sh.Ix}, {"Iy", sh.Iy},
                   {"host_memory", to_string(st.options.host_memory)},
                   {"threads", st.options.threads},
                   {"layout", rbe::to_string(st.options.layout)},
                   {"graph", st.options.graph},
                   {"problem_seed", st.seed}};
  return it;
}

// Uniform integer in [lo, hi] from a 64-bit generator, the same on every platform.
std::int64_t uniform(std::mt19937_64& rng, std::int64_t lo, std::int64_t hi) {
  const auto span = static_cast<std::uint64_t>(hi - lo + 1);
  const std::uint64_t limit = UINT64_MAX - UINT64_MAX % span;
  std::uint64_t x;
  do x = rng();
  while (x >= limit);
  return lo + static_cast<std::int64_t>(x % span);
}

std::int64_t get_size(const json& c, const char* key, std::size_t index, const std::string& file) {
  auto it = c.find(key);
  if (it == c.end() || !it->is_number_integer() || it->get<long long>() < 1)
    throw InputError(fmt::format("plan '{}': configs[{}].{} is {}, expected a positive integer", file,
                                 index, key, it == c.end() ? "missing" : it->dump()));
  return it->get<std::int64_t>();
}

Plan plan_from_file(const std::string& path, const RbeSweepSettings& st) {
  std::ifstream in(path);
  if (!in)
    throw InputError(fmt::format("--plan '{}' is neither seed-test1, seed-test2, random:N nor a readable "
                                 "plan file",
                                 path));
  json j;
  try {
    j = json::parse(in);
  } catch (const json::parse_error& e) {
    throw InputError(fmt::format("plan '{}' is not valid JSON (byte {})", path, e.byte));
  }
  if (!j.is_object() || !j.contains("configs") || !j["configs"].is_array() || j["configs"].empty())
    throw InputError(fmt::format("plan '{}' needs a non-empty \"configs\" array of {{\"nx\", \"ny\", \"Ix\", "
                                 "\"Iy\"}} objects",
                                 path));
  Plan p;
  p.name = std::filesystem::path(path).filename().string();
  p.description = j.value("description", fmt::format("configurations listed in {}", path));
  for (std::size_t i = 0; i < j["configs"].size(); ++i) {
    const json& c = j["configs"][i];
    if (!c.is_object()) throw InputError(fmt::format("plan '{}': configs[{}] is not an object", path, i));
    rbe::Shape sh{get_size(c, "nx", i, path), get_size(c, "ny", i, path), get_size(c, "Ix", i, path),
                  get_size(c, "Iy", i, path)};
    try {
      p.items.push_back(item_for(sh, st));
    } catch (const InputError& e) {
      throw InputError(fmt::format("plan '{}': configs[{}]: {}", path, i, e.what()));
    }
  }
  return p;
}

}  // namespace

Plan rbe_plan(const std::string& spec, const RbeSweepSettings& st, bool device) {
  Plan p;
  p.name = spec;
  if (spec == "seed-test1") {
    std::vector<std::int64_t> sizes;
    if (device) {
      for (std::int64_t i = 1; i <= 200; ++i) sizes.push_back(i);
      p.description = "seed Test 1 (5.3.5.1): grid 1000x1000, kernel IxI for I = 1..200";
    } else {
      sizes.push_back(1);
      for (std::int64_t i = 10; i <= 200; i += 10) sizes.push_back(i);
      p.description =
          "seed Test 1 (5.3.5.1), subsampled for a host backend: grid 1000x1000, kernel IxI for "
          "I = 1, 10, 20, ..., 200 (a step at I = 200 costs ~1 GFLOP on the CPU)";
    }
    for (auto i : sizes) p.items.push_back(item_for({1000, 1000, i, i}, st));
  } else if (spec == "seed-test2") {
    const std::int64_t step = device ? 50 : 100;
    for (std::int64_t k : {16, 32})
      for (std::int64_t n = 100; n <= 1000; n += step) p.items.push_back(item_for({n, n, k, k}, st));
    p.description = fmt::format("seed Test 2 (5.3.5.2): kernel 16x16 and 32x32, grid nxn for n = 100..1000 "
                                "in steps of {}",
                                step);
  } else if (spec.rfind("random:", 0) == 0) {
    const std::string n_text = spec.substr(7);
    long long n = 0;
    try {
      std::size_t used = 0;
      n = std::stoll(n_text, &used);
      if (used != n_text.size()) n = 0;
    } catch (...) {
      n = 0;
    }
    if (n < 1 || n > 100000)
      throw InputError(fmt::format("--plan '{}': the count after random: must be an integer in [1, 100000]", spec));
    std::mt19937_64 rng(st.seed);
    for (long long i = 0; i < n; ++i) {
      rbe::Shape sh;
      sh.nx = uniform(rng, 100, 1000);
      sh.ny = uniform(rng, 100, 1000);
      sh.Ix = uniform(rng, 1, std::min<std::int64_t>(200, sh.nx));
      sh.Iy = uniform(rng, 1, std::min<std::int64_t>(200, sh.ny));
      p.items.push_back(item_for(sh, st));
    }
    p.description = fmt::format("{} random configurations (seed {}) for held-out validation: n_x, n_y uniform in "
                                "[100, 1000], I_x, I_y uniform in [1, min(200, n)]",
                                n, st.seed);
  } else {
    p = plan_from_file(spec, st);
  }
  return p;
}

namespace {

double host_parts(const rbe::RunResult& r, std::initializer_list<rbe::Component> parts) {
  double s = 0;
  for (const auto& st : r.samples)
    for (auto c : parts) s += st.part(c);
  return s * static_cast<double>(r.steps_per_sample);
}

rbe::RunResult run_checked(rbe::Backend& b, const rbe::Problem& problem, std::int64_t steps, const std::string& key) {
  try {
    return b.run(steps);
  } catch (const rbe::NumericalError&) {
    // The belief can lose all mass after many corrections with one likelihood; start over once.
    b.init(problem);
    try {
      return b.run(steps);
    } catch (const rbe::NumericalError& e) {
      throw std::runtime_error(fmt::format("{}: {} (after a fresh start)", key, e.what()));
    }
  }
}

// CPU time this process has used (all threads), seconds. The scheduler's own clock (ns
// resolution); getrusage() counts in scheduler ticks, too coarse for a run of a millisecond.
double process_cpu_seconds() {
  timespec t{};
  ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace

Sample measure_rbe(const PlanItem& item, const RbeSweepSettings& st, const Plan& plan,
                   const MachineIdentity& machine, ActivityProfiler* profiler, const std::string& no_profiler) {
  const json& pj = item.parameters;
  const rbe::Shape sh{pj.at("nx").get<std::int64_t>(), pj.at("ny").get<std::int64_t>(),
                      pj.at("Ix").get<std::int64_t>(), pj.at("Iy").get<std::int64_t>()};
  auto backend = rbe::make_backend(st.backend, st.options);
  const bool device = backend->needs_gpu();
  const rbe::Problem problem = rbe::synthetic_problem(sh, st.seed);
  backend->init(problem);

  Sample s;
  s.key = item.key;
  s.machine = machine;
  s.workload = "rbe";
  s.backend = st.backend;
  s.plan = plan.name;
  s.parameters = pj;
  s.steps = st.steps;
  s.warmup = st.warmup;
  s.counts = backend->run_counts(sh, backend->options(), st.steps);

  const bool traced = device && profiler != nullptr;
  for (int w = 0; w < st.warmup; ++w) {
    if (traced) profiler->begin();
    run_checked(*backend, problem, st.steps, item.key);
    if (traced) profiler->end();
  }

  using C = rbe::Component;
  // Traced repetitions: CUPTI's device-side durations (and the runtime API's host-side ones).
  std::vector<double> dev_cg, dev_gc, dev_g, api_launch, api_copy, total_traced;
  json activity;
  if (traced) {
    for (int r = 0; r < st.repetitions; ++r) {
      profiler->begin();
      const rbe::RunResult rr = run_checked(*backend, problem, st.steps, item.key);
      const DeviceActivity a = profiler->end();
      dev_cg.push_back(a.to_device.seconds);
      dev_gc.push_back(a.to_host.seconds);
      dev_g.push_back(a.kernel_seconds);
      api_launch.push_back(a.launch_api_seconds);
      api_copy.push_back(a.copy_api_seconds);
      total_traced.push_back(rr.wall_seconds);
      if (r == st.repetitions - 1) activity = a.to_json();
    }
  }
  // Untraced repetitions: the total, and the backend's host-clock time of each phase.
  std::vector<double> total, host_cg, host_gc, host_g, host_c, device_step;
  std::vector<double> utilization;  // CPU time / (wall time x threads) of host backends
  for (int r = 0; r < st.repetitions; ++r) {
    const double cpu0 = process_cpu_seconds();
    const rbe::RunResult rr = run_checked(*backend, problem, st.steps, item.key);
    const double cpu = process_cpu_seconds() - cpu0;
    total.push_back(rr.wall_seconds);
    if (!device) {
      if (rr.wall_seconds > 0) utilization.push_back(cpu / (rr.wall_seconds * std::max(1, s.counts.cpu_threads)));
      host_c.push_back(host_parts(rr, {C::predict, C::correct, C::normalize, C::host_sum}));
      continue;
    }
    host_cg.push_back(host_parts(rr, {C::to_device}));
    host_gc.push_back(host_parts(rr, {C::to_host}));
    host_g.push_back(host_parts(rr, {C::predict, C::correct, C::normalize}));
    host_c.push_back(host_parts(rr, {C::host_sum}));
    device_step.push_back(host_parts(rr, {C::device_step}));
  }

  auto measured = [](const std::vector<double>& v) {
    return !v.empty() && std::any_of(v.begin(), v.end(), [](double x) { return x != 0; });
  };
  auto put = [&s, &measured](Component comp, const std::vector<double>& v) {
    if (measured(v)) s.components[comp] = summarize(v);
  };
  // A phase the backend brackets with host clocks (issue .. completion) is what the step pays
  // for it: the device-side part CUPTI sees plus the latency part (API calls, host staging of
  // pageable memory, synchronization). Where the backend has no such phase (cuda-resident runs a
  // CUDA graph), the component is CUPTI's device-side time.
  std::string sources;
  auto choose = [&](Component comp, const std::vector<double>& host, const std::vector<double>& dev) {
    if (measured(host)) {
      put(comp, host);
      sources += fmt::format("{}{}: host clock around the phase", sources.empty() ? "" : "; ", to_string(comp));
    } else if (measured(dev)) {
      put(comp, dev);
      sources += fmt::format("{}{}: CUPTI device-side durations", sources.empty() ? "" : "; ", to_string(comp));
    }
  };
  put(Component::total, total);
  if (device) {
    choose(Component::CG, host_cg, dev_cg);
    choose(Component::GC, host_gc, dev_gc);
    choose(Component::G, host_g, measured(dev_g) ? dev_g : device_step);
  }
  put(Component::C, host_c);
  if (!s.find(Component::total))
    throw std::runtime_error(fmt::format("{}: the backend reported no wall time", item.key));

  // Below ~0.9 the process waited for the CPU: another process shared the machine while this
  // sample was measured (its time is then the machine's, not the workload's alone).
  if (!utilization.empty()) s.detail["cpu_utilization"] = summarize(utilization).median;
  auto med = [&measured](const std::vector<double>& v) { return measured(v) ? summarize(v).median : 0.0; };
  if (device)
    s.detail["host_phases"] = {{"to_device", med(host_cg)}, {"to_host", med(host_gc)}, {"kernels", med(host_g)},
                               {"host_sum", med(host_c)}, {"device_step", med(device_step)}};
  s.source = traced ? TimingSource::cupti : TimingSource::host;
  if (device && !traced)
    s.timing_note = "CUPTI unavailable (" + no_profiler + "): " + sources;
  if (traced) {
    s.detail["device"] = {{"to_device", med(dev_cg)}, {"to_host", med(dev_gc)}, {"kernels", med(dev_g)},
                          {"launch_api", med(api_launch)}, {"copy_api", med(api_copy)}};
    // The latency parts: what a phase costs beyond its device-side duration.
    json lat = json::object();
    if (measured(host_cg) && measured(dev_cg)) lat["to_device"] = med(host_cg) - med(dev_cg);
    if (measured(host_gc) && measured(dev_gc)) lat["to_host"] = med(host_gc) - med(dev_gc);
    if (measured(host_g) && measured(dev_g)) lat["kernels"] = med(host_g) - med(dev_g);
    s.detail["latency_parts"] = lat;
    const Stats tt = summarize(total_traced);
    s.detail["total_traced"] = {{"median", tt.median}, {"p25", tt.p25}, {"p75", tt.p75}};
    s.detail["activity_last_repetition"] = activity;
    // Declared counts against what CUPTI saw: a mismatch means the counts are wrong.
    const auto& k = s.counts;
    const json& to_dev = activity["to_device"];
    const json& to_host = activity["to_host"];
    std::string mismatch;
    auto check = [&mismatch](const char* what, std::int64_t declared, std::int64_t seen) {
      if (declared != seen)
        mismatch += fmt::format("{}{}: declared {}, CUPTI saw {}", mismatch.empty() ? "" : "; ", what, declared, seen);
    };
    check("host->device copies", k.transfers_CG, to_dev["count"].get<std::int64_t>());
    check("host->device bytes", k.P * k.N_CG, to_dev["bytes"].get<std::int64_t>());
    check("device->host copies", k.transfers_GC, to_host["count"].get<std::int64_t>());
    check("device->host bytes", k.P * k.N_GC, to_host["bytes"].get<std::int64_t>());
    check("kernels", k.launches, activity["kernels"].get<std::int64_t>());
    if (!mismatch.empty()) s.detail["counts_mismatch"] = mismatch;
    s.timing_note = "CUPTI traced repetitions give the device-side durations and check the counts; " + sources +
                    "; C: host clock; total: host clock over untraced repetitions";
  }
  s.measured_at = utc_now();
  return s;
}

}  // namespace dtflop::calib
