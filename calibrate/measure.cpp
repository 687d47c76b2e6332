#include "calibrate/measure.hpp"

#include <time.h>

#include <algorithm>

#include <fmt/format.h>

#include "calibrate/timeline.hpp"
#include "model/errors.hpp"

namespace dtflop::calib {

using nlohmann::json;

void check(const MeasureSettings& s) {
  if (s.steps < 0) throw InputError(fmt::format("--steps must be positive (0: the default), got {}", s.steps));
  if (s.repetitions < 0 || s.repetitions == 1 || s.repetitions > 100000)
    throw InputError(fmt::format("--reps must be between 2 and 100000 so a sample has a spread (0: the default), "
                                 "got {}",
                                 s.repetitions));
  if (s.warmup < -1 || s.warmup > 100000)
    throw InputError(fmt::format("--warmup must be between 0 and 100000, got {}", s.warmup));
}

MeasureSettings with_defaults(MeasureSettings s, const workload::Workload& w, const workload::Backend& b) {
  const workload::ProtocolDefaults d = w.defaults(b);
  if (s.steps <= 0) s.steps = d.steps;
  if (s.repetitions <= 0) s.repetitions = d.repetitions;
  if (s.warmup < 0) s.warmup = d.warmup;
  return s;
}

Protocol open_protocol(const workload::Workload& w, const workload::Backend& b, MeasureSettings settings,
                       bool no_cupti) {
  check(settings);
  if (const std::string why = b.unavailable(); !why.empty()) throw workload::DeviceUnavailable(why);
  Protocol p;
  p.settings = with_defaults(settings, w, b);
  if (b.needs_gpu()) {
    if (no_cupti) {
      p.no_profiler = "--no-cupti was given";
    } else {
      ProfilerOpen o = open_cupti_profiler();
      p.owned = std::move(o.profiler);
      p.profiler = p.owned.get();
      p.no_profiler = o.why_not;
    }
  }
  return p;
}

Plan sweep_plan(const workload::Workload& w, const workload::Backend& b, const std::string& spec,
                std::uint64_t seed, const json& fixed) {
  const workload::PlanConfigs pc = w.plan(spec, b, seed);
  if (pc.configs.empty())
    throw InputError(fmt::format("plan '{}' of {} holds no configuration; name a plan that holds some", spec,
                                 w.name()));
  // A fixed parameter must not be one the plan varies: the plan would collapse onto one value.
  if (!fixed.empty()) {
    (void)w.validate(fixed, b);  // names and values checked once, with a message naming the option
    for (auto it = fixed.begin(); it != fixed.end(); ++it)
      for (const auto& c : pc.configs)
        if (c.at(it.key()) != pc.configs.front().at(it.key()))
          throw InputError(fmt::format("--{} is what plan '{}' varies; drop it, or write a plan file with the "
                                       "values you want",
                                       it.key(), spec));
  }
  Plan p;
  p.name = pc.name;
  p.description = pc.description;
  for (const auto& planned : pc.configs) {
    workload::Config c = planned;
    for (auto it = fixed.begin(); it != fixed.end(); ++it) c[it.key()] = it.value();
    if (!fixed.empty()) c = w.validate(c, b);
    p.items.push_back({w.key(b, c), w.label(c), c});
  }
  return p;
}

namespace {

// CPU time this process has used (all threads), seconds: the scheduler's own clock (ns
// resolution); getrusage() counts in scheduler ticks, too coarse for a run of a millisecond.
double process_cpu_seconds() {
  timespec t{};
  ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

bool measured(const std::vector<double>& v) {
  return !v.empty() && std::any_of(v.begin(), v.end(), [](double x) { return x != 0; });
}
double med(const std::vector<double>& v) { return measured(v) ? summarize(v).median : 0.0; }

// Declared counts against what CUPTI saw: one line per difference (empty: they agree). Counts are
// in values of P bytes and a copy of b bytes moves ceil(b / P) of them, so the declared bytes P N
// may exceed the bytes copied by less than P per copy, never more, and never fall short.
std::string counts_mismatch(const CostCounts& k, const DeviceActivity& a) {
  std::string out;
  auto cmp = [&out](const char* what, std::int64_t declared, std::int64_t seen) {
    if (declared != seen) out += fmt::format("{}{}: declared {}, CUPTI saw {}", out.empty() ? "" : "; ", what, declared, seen);
  };
  auto bytes = [&out, &k](const char* what, std::int64_t values, std::int64_t copies, std::uint64_t seen_bytes) {
    const auto seen = static_cast<std::int64_t>(seen_bytes);
    const std::int64_t declared = k.P * values;
    if (declared < seen || declared - seen >= k.P * std::max<std::int64_t>(copies, 1))
      out += fmt::format("{}{}: declared {} values of {} bytes, CUPTI saw {} bytes", out.empty() ? "" : "; ", what,
                         values, k.P, seen);
  };
  cmp("host->device copies", k.transfers_CG, a.to_device.count);
  bytes("host->device", k.N_CG, k.transfers_CG, a.to_device.bytes);
  cmp("device->host copies", k.transfers_GC, a.to_host.count);
  bytes("device->host", k.N_GC, k.transfers_GC, a.to_host.bytes);
  cmp("kernels", k.launches, a.kernels);
  return out;
}

}  // namespace

Sample measure(const workload::Workload& w, const workload::Backend& b, const workload::Config& config,
               Protocol& protocol, const MachineIdentity& machine, const std::string& key, const std::string& plan,
               nlohmann::json* timeline) {
  const MeasureSettings& st = protocol.settings;
  auto run = b.prepare(config, st.steps);
  const bool device = b.needs_gpu();
  ActivityProfiler* profiler = device ? protocol.profiler : nullptr;

  Sample s;
  s.key = key;
  s.machine = machine;
  s.workload = std::string(w.name());
  s.backend = b.name();
  s.plan = plan;
  s.parameters = config;
  s.steps = st.steps;
  s.warmup = st.warmup;
  s.counts = run->counts();

  // A repetition whose work differs from the declared counts makes the sample wrong: say so.
  std::string work_mismatch;
  auto repeat = [&run, &work_mismatch] {
    workload::PhaseTimes t = run->repeat();
    if (work_mismatch.empty()) work_mismatch = run->check();
    return t;
  };
  for (int i = 0; i < st.warmup; ++i) {
    if (profiler) profiler->begin();
    repeat();
    if (profiler) profiler->end();
  }

  // Traced repetitions: CUPTI's device-side durations (and the runtime API's host-side ones).
  std::vector<double> dev_cg, dev_gc, dev_g, api_launch, api_copy, total_traced;
  std::string cupti_mismatch;
  json activity;
  if (profiler) {
    for (int r = 0; r < st.repetitions; ++r) {
      profiler->begin();
      const workload::PhaseTimes t = repeat();
      const DeviceActivity a = profiler->end();
      dev_cg.push_back(a.to_device.seconds);
      dev_gc.push_back(a.to_host.seconds);
      dev_g.push_back(a.kernel_seconds);
      api_launch.push_back(a.launch_api_seconds);
      api_copy.push_back(a.copy_api_seconds);
      total_traced.push_back(t.wall);
      if (cupti_mismatch.empty()) cupti_mismatch = counts_mismatch(s.counts, a);
      if (r == st.repetitions - 1) {
        activity = a.to_json();
        if (timeline)
          *timeline = timeline_json(a.records, a.begin_ns, a.end_ns,
                                    fmt::format("{}: the last CUPTI-traced repetition ({} steps)", key, st.steps));
      }
    }
  }
  // Untraced repetitions: the total, and the backend's host-clock time of each phase.
  std::vector<double> total, host_cg, host_gc, host_g, host_c, events_g, utilization;
  for (int r = 0; r < st.repetitions; ++r) {
    const double cpu0 = process_cpu_seconds();
    const workload::PhaseTimes t = repeat();
    const double cpu = process_cpu_seconds() - cpu0;
    total.push_back(t.wall);
    host_cg.push_back(t.CG);
    host_gc.push_back(t.GC);
    host_g.push_back(t.G);
    host_c.push_back(t.C);
    events_g.push_back(t.G_events);
    if (!device && t.wall > 0) utilization.push_back(cpu / (t.wall * std::max(1, s.counts.cpu_threads)));
  }

  auto put = [&s](Component comp, const std::vector<double>& v) {
    if (measured(v)) s.components[comp] = summarize(v);
  };
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
    choose(Component::G, host_g, measured(dev_g) ? dev_g : events_g);
  }
  put(Component::C, host_c);
  if (!s.find(Component::total))
    throw std::runtime_error(fmt::format("{}: the backend reported no wall time", key));

  if (!utilization.empty()) s.detail["cpu_utilization"] = summarize(utilization).median;
  if (device)
    s.detail["host_phases"] = {{"to_device", med(host_cg)}, {"to_host", med(host_gc)}, {"kernels", med(host_g)},
                               {"host", med(host_c)}, {"device_events", med(events_g)}};
  if (const json d = run->detail(); !d.empty()) s.detail["workload"] = d;
  if (!work_mismatch.empty()) s.detail["work_mismatch"] = work_mismatch;
  s.source = profiler ? TimingSource::cupti : TimingSource::host;
  if (device && !profiler) s.timing_note = "CUPTI unavailable (" + protocol.no_profiler + "): " + sources;
  if (profiler) {
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
    if (!cupti_mismatch.empty()) s.detail["counts_mismatch"] = cupti_mismatch;
    s.timing_note = "CUPTI traced repetitions give the device-side durations and check the counts; " + sources +
                    "; C: host clock; total: host clock over untraced repetitions";
  }
  s.measured_at = utc_now();
  return s;
}

}  // namespace dtflop::calib
