// `dtflop sar --scenario FILE ...`: the cooperative search-and-rescue team (docs/sar.md). Run
// under `mpirun -n N`, one process per helicopter; each reads the same scenario.
#include <cstdio>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "calibrate/machine.hpp"
#include "calibrate/sample.hpp"
#include "calibrate/store.hpp"
#include "cli/command.hpp"
#include "cli/model_tables.hpp"
#include "cli/workload_cli.hpp"
#include "model/json_io.hpp"
#include "model/stats.hpp"
#include "model/units.hpp"
#include "sar/counts.hpp"
#include "model/errors.hpp"
#include "sar/fusion.hpp"
#include "sar/scenario.hpp"
#include "sar/team.hpp"
#include "sar/world.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/workload.hpp"

namespace dtflop::cli {
namespace {

// "NXxNY": the grid's cells over the scenario's area. Throws InputError.
void apply_cells(sar::Scenario& s, const std::string& cells) {
  if (cells.empty()) return;
  long long nx = 0, ny = 0;
  char x = 0, extra = 0;
  if (std::sscanf(cells.c_str(), "%lld%c%lld%c", &nx, &x, &ny, &extra) != 3 || x != 'x' || nx < 1 || ny < 1 ||
      nx > 65536 || ny > 65536)
    throw InputError(fmt::format("--cells '{}': give NXxNY, each 1 to 65536, e.g. 200x100", cells));
  s.nx = nx, s.ny = ny;
}

struct SarArgs {
  std::string scenario;
  std::string cells;
  std::string rule;
  std::int64_t interval = 0;
  std::string backend;
  std::int64_t steps = 0;
  std::string seeds;
  std::string link;
  double latency_ms = -1, bandwidth_mbps = -1;
  std::string out = "sar-out";
  std::vector<std::int64_t> snapshots;
  bool no_records = false;
  double peer_timeout = 60;
  int threads = 0;
  std::string fail_at;
  bool quiet = false;
  bool check = false;
  // The exchange sweep (samples of the network term for `dtflop calibrate`).
  bool exchange_sweep = false;
  int round = 1;
  std::vector<std::int64_t> sizes;
  std::string store;
  int exchanges = 20, repetitions = 5;
};

// "S" or "A..B" (at most 100000 seeds).
std::vector<std::uint64_t> parse_seeds(const std::string& text) {
  auto number = [&](const std::string& t) -> std::uint64_t {
    std::size_t used = 0;
    unsigned long long v = 0;
    try {
      v = std::stoull(t, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != t.size() || t[0] == '-' || v > (1ULL << 53))
      throw InputError(fmt::format("--seeds '{}': give a seed S or a range A..B of whole numbers up to 2^53", text));
    return v;
  };
  const auto dots = text.find("..");
  if (dots == std::string::npos) return {number(text)};
  const std::uint64_t a = number(text.substr(0, dots)), b = number(text.substr(dots + 2));
  if (b < a || b - a >= 100000)
    throw InputError(fmt::format("--seeds '{}': give A..B with A <= B and at most 100000 seeds", text));
  std::vector<std::uint64_t> v;
  for (std::uint64_t s = a; s <= b; ++s) v.push_back(s);
  return v;
}

// The team's exchange at each message size (default: an observation, powers of 2 from 64 bytes,
// and a belief of the scenario's grid), each size one sample in the store (workload "sar-net",
// backend "mpi", counts net_messages and net_bytes only): `dtflop calibrate` fits L_net and B_net
// from them and `dtflop validate` checks them held out (docs/sar.md).
void exchange_sweep(const sar::Scenario& s, const SarArgs& a) {
  if (a.store.empty()) throw InputError("--exchange-sweep writes its samples to a sample store; name it with --store FILE");
  std::vector<std::int64_t> sizes = a.sizes;
  const std::int64_t belief = s.nx * s.ny * 4;
  if (sizes.empty()) {
    sizes.push_back(sar::kObservationBytes);
    for (std::int64_t b = 64; b < belief; b *= 2) sizes.push_back(b);
    sizes.push_back(belief);
  }
  for (auto b : sizes)
    if (b < 1 || b > (std::int64_t{1} << 30))
      throw InputError(fmt::format("--sizes: {} bytes is outside 1 .. 1 GiB per message", b));
  sar::ExchangeSweep sw;
  sw.bytes = sizes;
  sw.exchanges = a.exchanges;
  sw.repetitions = a.repetitions;
  sw.peer_timeout = a.peer_timeout;
  auto writer = std::make_shared<std::unique_ptr<calib::StoreWriter>>();
  auto keys = std::make_shared<std::set<std::string>>();
  auto here = std::make_shared<MachineIdentity>();
  const std::string store = a.store;
  const bool quiet = a.quiet;
  const workload::Workload& net = workload::find("sar-net");
  const workload::Backend& mpi = net.backend("mpi");
  auto config = [&net, &mpi](int team, std::int64_t bytes, int exchanges) {
    return net.validate({{"team", team}, {"bytes", bytes}, {"exchanges", exchanges}}, mpi);
  };
  auto key = [&net, &mpi, config](int team, std::int64_t bytes, int exchanges) {
    return net.key(mpi, config(team, bytes, exchanges));
  };
  auto begin = [=, &net, &mpi](int team) {
    *here = calib::this_machine();
    const calib::StoreContents c = calib::read_store(store);
    for (const auto& smp : c.samples) {
      std::string why;
      if (!same_machine(smp.machine, *here, &why))
        throw InputError(fmt::format("sample store '{}' holds samples measured on another machine ({}); use another "
                                     "--store here", store, why));
      keys->insert(smp.key);
    }
    std::vector<std::string> warnings;
    *writer = std::make_unique<calib::StoreWriter>(store, warnings);
    for (const auto& w : warnings) fmt::print(stderr, "dtflop: warning: {}\n", w);
    std::size_t already = 0;
    for (auto b : sw.bytes) already += keys->count(key(team, b, sw.exchanges));
    if (already > 0)
      fmt::print(stderr, "dtflop sar: {} of {} sizes are in '{}' already; each is measured again as another "
                         "sample\n", already, sw.bytes.size(), store);
  };
  const int round = a.round;
  auto sink = [=, &net, &mpi](const sar::ExchangeSample& x) {
    calib::Sample smp;
    smp.key = key(x.team, x.bytes, x.exchanges);
    smp.machine = *here;
    smp.workload = std::string(net.name());
    smp.backend = mpi.name();
    smp.plan = "exchange-sweep";
    smp.parameters = config(x.team, x.bytes, x.exchanges);
    smp.counts = mpi.counts(smp.parameters, nullptr).scaled(x.exchanges);  // declared per exchange
    smp.steps = x.exchanges;
    smp.round = round;
    smp.warmup = 1;
    smp.source = calib::TimingSource::host;
    smp.timing_note = "host clock: the slowest rank's wall time of the exchanges (each rank sends one message to "
                      "every other over the team's MPI transport and receives theirs), after a barrier";
    smp.components[calib::Component::total] = summarize(x.seconds);
    smp.measured_at = calib::utc_now();
    (*writer)->append(smp);
    if (!quiet)
      fmt::print(stderr, "dtflop sar: exchange of {} bytes among {}: {} per exchange (median of {})\n", x.bytes, x.team,
                 format_quantity(smp.components[calib::Component::total].median / x.exchanges, "s"), x.seconds.size());
  };
  set_exit_status(sar::run_exchange_sweep(sw, begin, sink));
}

void run_sar(const SarArgs& a) {
  sar::Scenario s = sar::load_scenario(a.scenario);
  if (!a.rule.empty()) s.rule = sar::parse_rule(a.rule);
  if (a.interval != 0) s.interval = a.interval;
  if (!a.backend.empty()) {
    (void)rbe::make_backend(a.backend);  // names the known backends when unknown
    s.backend = a.backend;
  }
  if (a.steps != 0) s.steps = a.steps;
  apply_cells(s, a.cells);
  if (!a.link.empty()) {
    if (a.link == "off") s.link_enabled = false, s.link_sleep = false;
    else if (a.link == "model") s.link_enabled = true, s.link_sleep = false;
    else if (a.link == "sleep") s.link_enabled = true, s.link_sleep = true;
  }
  if (a.latency_ms >= 0) s.latency_ms = a.latency_ms;
  if (a.bandwidth_mbps >= 0) s.bandwidth_mbps = a.bandwidth_mbps;
  sar::validate(s);
  sar::TeamOptions o;
  o.out = a.out;
  if (!a.seeds.empty()) o.seeds = parse_seeds(a.seeds);
  o.records = !a.no_records;
  o.snapshots = a.snapshots;
  for (auto k : o.snapshots)
    if (k < 0 || k > s.steps)
      throw InputError(fmt::format("--snapshots: step {} is outside 0..{} (the run's steps)", k, s.steps));
  o.peer_timeout = a.peer_timeout;
  o.quiet = a.quiet;
  o.threads = a.threads;
  if (!a.fail_at.empty()) {
    const auto colon = a.fail_at.find(':');
    try {
      if (colon == std::string::npos) throw std::invalid_argument("no colon");
      o.fail_rank = std::stoi(a.fail_at.substr(0, colon));
      o.fail_step = std::stoll(a.fail_at.substr(colon + 1));
    } catch (const std::exception&) {
      throw InputError(fmt::format("--fail-at '{}': give RANK:STEP, e.g. 2:10", a.fail_at));
    }
  }
  if (a.check) {
    const sar::MeanTraffic t = sar::mean_traffic(s, std::int64_t(s.helicopters.size()));
    fmt::print("scenario '{}': {} helicopters, grid {}x{} over [{}, {}] x [{}, {}] km, {} steps of {} s, {} fusion{}, "
               "backend {}; per helicopter and step {:.3g} messages, {:.4g} bytes\n",
               s.name, s.helicopters.size(), s.nx, s.ny, s.x_min, s.x_max, s.y_min, s.y_max, s.steps, s.step_time,
               sar::to_string(s.rule), s.rule == sar::Rule::belief || s.rule == sar::Rule::loglinear
                                           ? fmt::format(" every {} steps", s.interval) : "",
               s.backend, t.messages, t.bytes);
    return;
  }
  if (a.exchange_sweep) {
    exchange_sweep(s, a);
    return;
  }
  if (!a.store.empty() || !a.sizes.empty())
    throw InputError("--store and --sizes belong to --exchange-sweep; add it, or leave them out for a team run");
  set_exit_status(sar::run_team(s, o));
}

struct PredictSarArgs {
  std::string scenario, rule, backend, cells;
  std::int64_t interval = 0;
  PredictArgs predict;
  ResultArgs result;
};

// `dtflop predict sar`: the model's time of one team step (one helicopter's share; all do the same).
void predict_sar(const PredictSarArgs& a) {
  sar::Scenario s = sar::load_scenario(a.scenario);
  if (!a.rule.empty()) s.rule = sar::parse_rule(a.rule);
  if (a.interval != 0) s.interval = a.interval;
  if (!a.backend.empty()) s.backend = a.backend;
  apply_cells(s, a.cells);
  sar::validate(s);
  check_output(a.result.output, {a.scenario, a.predict.machine});
  const std::int64_t team = std::int64_t(s.helicopters.size());
  const sar::TeamCounts t = sar::team_counts(s, team);
  const double steps = double(t.steps);
  const double link = [&] {
    double d = 0;
    for (std::int64_t j = 1; j <= t.steps; ++j) d += sar::link_delay(s, sar::traffic(s, team, t.steps > 1 ? j : 1));
    return d / steps;
  }();
  nlohmann::json out = {{"scenario", a.scenario},
                        {"rule", sar::to_string(s.rule)},
                        {"interval", s.interval},
                        {"helicopters", team},
                        {"backend", s.backend},
                        {"grid", {t.shape.nx, t.shape.ny}},
                        {"kernel", {t.shape.Ix, t.shape.Iy}},
                        {"steps_per_period", t.steps},
                        {"counts_per_period",
                         {{"rbe", to_json(t.rbe)},
                          {"host", to_json(t.host)},
                          {"summary", to_json(t.summary)},
                          {"net", to_json(t.net)}}},
                        {"link_delay_per_step", link}};
  std::optional<double> total;
  nlohmann::json parts = nlohmann::json::object();
  if (!a.predict.machine.empty()) {
    const MachineProfile m = load_profile(a.predict.machine);
    const Variant want = wanted_variant(a.predict, m);
    double sum = 0;
    for (const auto& [name, counts] : {std::pair<const char*, const CostCounts*>{"rbe", &t.rbe}, {"host", &t.host},
                                       {"summary", &t.summary}, {"net", &t.net}}) {
      if (std::string(name) == "net" && (!m.has(Param::B_net) || !m.has(Param::L_net))) {
        parts[name] = {{"missing", "the profile has no L_net and B_net: run `dtflop probe` (net-mpi) where dtflop has MPI"},
                       {"per_step", 0.0}};
        fmt::print(stderr, "dtflop: note: the profile has no L_net and B_net, so the messages are not priced; run "
                           "`dtflop probe --only net-mpi` on this machine\n");
        continue;
      }
      const Predicted p = predict_with_fallback(m, *counts, want);
      if (!p.fallback.empty()) fmt::print(stderr, "dtflop: note: {}: {}\n", name, p.fallback);
      parts[name] = {{"variant", std::string(to_string(p.variant))}, {"per_step", p.prediction.total / steps},
                     {"prediction_per_period", to_json(p.prediction)}};
      sum += p.prediction.total / steps;
    }
    total = sum;
    out["machine"] = machine_json(a.predict.machine, m);
    out["prediction_per_step"] = parts;
    out["total_per_step"] = sum;
    out["total_with_link_per_step"] = sum + link;
  }
  if (!a.result.output.empty()) write_file_atomically(a.result.output, out.dump(2) + "\n");
  if (a.result.json) {
    fmt::print("{}\n", out.dump(2));
    return;
  }
  fmt::print("team step of '{}': {} helicopters, {} fusion{}, backend {}, grid {}x{}, kernel {}x{}\n", s.name, team,
             sar::to_string(s.rule),
             t.steps > 1 ? fmt::format(" every {} steps", s.interval) : std::string(), s.backend, t.shape.nx,
             t.shape.ny, t.shape.Ix, t.shape.Iy);
  fmt::print("\nCounts of one helicopter's period of {} step{}:\n  RBE ({}):\n", t.steps, t.steps == 1 ? "" : "s", s.backend);
  print_counts(t.rbe);
  fmt::print("  host work (likelihoods, observation fusion):\n");
  print_counts(t.host);
  fmt::print("  summary (the estimate and the control's sums, where the belief lives):\n");
  print_counts(t.summary);
  fmt::print("  messages: {} messages, {} bytes\n", t.net.net_messages, t.net.net_bytes);
  fmt::print("\nThe link model adds {} per step of physical time (not priced by the machine profile).\n",
             format_duration(link));
  if (!total) {
    fmt::print("(add --machine machine.json for the model's time per team step)\n");
    return;
  }
  fmt::print("\nPredicted per team step on {}:\n", machine_name(load_profile(a.predict.machine)));
  for (const char* name : {"rbe", "host", "summary", "net"})
    fmt::print("  {:7} {}\n", name, format_duration(parts[name]["per_step"].get<double>()));
  fmt::print("  total   {} (with the link model's delay {})\n", format_duration(*total), format_duration(*total + link));
}

}  // namespace

void add_sar_command(CLI::App& root) {
  // `dtflop predict sar`: beside the workloads of `dtflop predict`.
  CLI::App* predict = nullptr;
  for (CLI::App* sub : root.get_subcommands([](CLI::App* a) { return a->get_name() == "predict"; })) predict = sub;
  if (predict) {
    auto* p = predict->add_subcommand(
        "sar", "The model's time of one step of the search-and-rescue team (docs/sar.md): each helicopter's RBE step, "
               "its host work and its messages (the network term), per step, averaged over a fusion period");
    auto pa = std::make_shared<PredictSarArgs>();
    p->add_option("--scenario", pa->scenario, "Scenario YAML")->required()->type_name("FILE");
    p->add_option("--rule", pa->rule, "Fusion rule, overriding the scenario's");
    p->add_option("--interval", pa->interval, "Steps between belief fusions, overriding the scenario's")
        ->check(CLI::Range(std::int64_t{1}, std::int64_t{10'000'000}));
    p->add_option("--backend", pa->backend, "RBE backend, overriding the scenario's");
    p->add_option("--cells", pa->cells, "Grid cells NXxNY over the scenario's area, overriding the scenario's");
    p->add_option("--machine", pa->predict.machine, "Machine profile (dtflop probe: L_net and B_net from net-mpi)")
        ->type_name("FILE");
    p->add_option("--variant", pa->predict.variant, "Model variant (default: the profile's chosen one, else extended)");
    add_result_options(*p, pa->result);
    p->callback([pa] { predict_sar(*pa); });
  }
  auto* app = root.add_subcommand(
      "sar",
      "Cooperative search and rescue (docs/sar.md): a team of helicopters, one MPI process each (`mpirun -n N dtflop "
      "sar --scenario FILE`), each with its own grid RBE of a drifting life raft, sharing observations or beliefs "
      "over a modelled radio link. Writes per-helicopter records, the team's series and a summary line per run.");
  auto a = std::make_shared<SarArgs>();
  app->add_option("--scenario", a->scenario, "Scenario YAML (sar/scenarios/table-5.5.yaml; docs/sar.md lists its fields)")
      ->required()->type_name("FILE");
  app->add_option("--rule", a->rule, "Fusion rule, overriding the scenario's: none, observation, belief, loglinear");
  app->add_option("--interval", a->interval, "Steps between belief (or log-linear) fusions, overriding the scenario's")
      ->check(CLI::Range(std::int64_t{1}, std::int64_t{10'000'000}));
  app->add_option("--backend", a->backend, "RBE backend of every helicopter, overriding the scenario's (cpu-seq, "
                                           "cpu-par, cuda-seed, cuda-resident)");
  app->add_option("--cells", a->cells, "Grid cells NXxNY over the scenario's area, overriding the scenario's");
  app->add_option("--steps", a->steps, "Steps per run, overriding the scenario's")
      ->check(CLI::Range(std::int64_t{1}, std::int64_t{10'000'000}));
  app->add_option("--seeds", a->seeds, "One run per seed: S, or A..B (default: the scenario's seed)");
  app->add_option("--link", a->link, "The link: model (its delay lengthens each step's physical time), sleep (also "
                                     "held back in wall time), off")
      ->check(CLI::IsMember({"model", "sleep", "off"}));
  app->add_option("--latency", a->latency_ms, "Link latency per message, ms (overrides the scenario's)")
      ->check(CLI::Range(0.0, 1e6));
  app->add_option("--bandwidth", a->bandwidth_mbps, "Link bandwidth, Mbit/s (overrides the scenario's)")
      ->check(CLI::Range(1e-6, 1e9));
  app->add_option("--out", a->out, "Output folder (made if missing; files of an earlier run are replaced)")
      ->capture_default_str()->type_name("FOLDER");
  app->add_option("--snapshots", a->snapshots, "Steps at which rank 0 draws its belief and the tracks as PNG "
                                               "(0: the prior), e.g. --snapshots 0,50,200")
      ->delimiter(',');
  app->add_flag("--no-records", a->no_records, "Leave out the per-step records of each helicopter (heli-R.csv)");
  app->add_option("--threads", a->threads,
                  "cpu-par's threads in each process (0: every hardware thread; with more processes than cores, 1)")
      ->capture_default_str()->check(CLI::Range(0, 4096));
  app->add_option("--peer-timeout", a->peer_timeout, "Seconds without a peer's message before it counts as lost")
      ->capture_default_str()->check(CLI::Range(0.01, 86400.0));
  app->add_option("--fail-at", a->fail_at, "Testing: RANK:STEP, that rank kills itself at that step (lost-rank handling)");
  app->add_flag("--quiet", a->quiet, "No progress line per run");
  app->add_flag("--check", a->check, "Validate the scenario and the options, print what would run, and stop (no MPI)");
  app->add_flag("--exchange-sweep", a->exchange_sweep,
                "Instead of a run: time the team's MPI exchange at each of --sizes and append one sample per size to "
                "--store (network term counts only: `dtflop calibrate` fits L_net and B_net from them)");
  app->add_option("--sizes", a->sizes, "Exchange sweep: bytes per message, e.g. 48,4096,57600 (default: an "
                                       "observation, powers of 2 from 64 bytes, a belief of the scenario's grid)")
      ->delimiter(',');
  app->add_option("--store", a->store, "Exchange sweep: the sample store to append to")->type_name("FILE");
  app->add_option("--exchanges", a->exchanges, "Exchange sweep: exchanges per repetition")
      ->capture_default_str()->check(CLI::Range(1, 1000000));
  app->add_option("--repetitions", a->repetitions, "Exchange sweep: timed repetitions per size")
      ->capture_default_str()->check(CLI::Range(1, 10000));
  app->add_option("--round", a->round,
                  "Exchange sweep: the round its samples belong to (sweeps of the same sizes in one store: 1, 2, ...)")
      ->capture_default_str()->check(CLI::Range(1, 1000000));
  app->callback([a] { run_sar(*a); });
}

}  // namespace dtflop::cli
