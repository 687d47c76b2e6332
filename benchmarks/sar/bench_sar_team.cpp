// The team step of the search-and-rescue scenario where no MPI is (a GPU machine's bundle): the
// helicopters' platforms (sar/platform.hpp, the same code as `dtflop sar`) in threads of one
// process, exchanging beliefs and observations through memory instead of MPI messages (the link
// model's delay lengthens each step's physical time as in `dtflop sar --link model`; nothing is
// slept). Per step and platform it times the compute (and of it the RBE backend's step and fusion,
// its summary: the estimate and the control's sums, and a new kernel on the link's longer steps)
// and the exchange; a team step is the slowest platform's. Beside it, the backend's own step
// (Backend::run on the scenario's problem with one likelihood): what the team step is to be
// compared with. One CSV row per backend and grid (medians over the steps after the first
// --warmup):
//   backend,nx,ny,Ix,Iy,team,rule,interval,steps,threads,backend_step_s,team_step_s,compute_s,
//   exchange_s,rbe_s,summary_s,reset_mean_s,host_s
// (host_s: the median of compute - rbe - summary - reset, the host's sensing, likelihood windows
// and control arithmetic.)
//
//   bench_sar_team --scenario sar/scenarios/table-5.5.yaml --cells 1000x1000,4000x4000
//     --backends cuda-resident,cpu-par --steps 60 -o team.csv
#include <algorithm>
#include <atomic>
#include <barrier>
#include <cstdio>
#include <exception>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "model/errors.hpp"
#include "sar/platform.hpp"
#include "sar/scenario.hpp"
#include "sar/world.hpp"
#include "workloads/rbe/backend.hpp"

using namespace dtflop;

namespace {

// Every platform of the team sends the same number of bytes at the same step (Transport).
struct Board {
  explicit Board(int n) : sync(n), slots(std::size_t(n)) {}
  std::barrier<> sync;
  std::vector<std::vector<std::byte>> slots;
  std::atomic<bool> failed{false};
};

class MemoryTransport final : public sar::Transport {
 public:
  MemoryTransport(Board& b, int rank) : b_(b), rank_(rank) {}
  int rank() const override { return rank_; }
  int size() const override { return static_cast<int>(b_.slots.size()); }
  std::vector<std::vector<std::byte>> exchange(std::span<const std::byte> mine, std::int64_t step) override {
    b_.slots[std::size_t(rank_)].assign(mine.begin(), mine.end());
    b_.sync.arrive_and_wait();  // every slot written
    if (b_.failed.load()) throw sar::RankLost(-1, step, "another platform of the team failed");
    std::vector<std::vector<std::byte>> got = b_.slots;
    b_.sync.arrive_and_wait();  // every slot read before the next exchange writes
    return got;
  }

 private:
  Board& b_;
  int rank_;
};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}
double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / double(v.size());
}

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream s(text);
  for (std::string x; std::getline(s, x, ',');)
    if (!x.empty()) out.push_back(x);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The search-and-rescue team step with the platforms in threads (no MPI): compute, exchange through "
               "memory, and the backend's own step beside it (benchmarks/sar/bench_sar_team.cpp)"};
  std::string scenario, cells, backends = "cpu-par", rule, out;
  std::int64_t steps = 60, warmup = 5, interval = 0;
  int threads = 0;
  app.add_option("--scenario", scenario, "Scenario YAML (sar/scenarios/table-5.5.yaml)")->required();
  app.add_option("--cells", cells, "Grids NXxNY, comma-separated (default: the scenario's)");
  app.add_option("--backends", backends, "RBE backends, comma-separated")->capture_default_str();
  app.add_option("--rule", rule, "Fusion rule (default: the scenario's): none, observation, belief, loglinear");
  app.add_option("--interval", interval, "Steps between belief fusions (default: the scenario's)")->check(CLI::Range(1, 1000000));
  app.add_option("--steps", steps, "Steps per run")->check(CLI::Range(2, 100000))->capture_default_str();
  app.add_option("--warmup", warmup, "Steps left out of the medians")->check(CLI::Range(0, 100000))->capture_default_str();
  app.add_option("--threads", threads,
                 "cpu-par's threads per platform (0: the hardware threads divided among the platforms)")
      ->check(CLI::Range(0, 4096))
      ->capture_default_str();
  app.add_option("-o,--out", out, "CSV file (default: stdout)");
  CLI11_PARSE(app, argc, argv);
  try {
    if (warmup >= steps) throw InputError(fmt::format("--warmup {} leaves no step of {}; give fewer", warmup, steps));
    sar::Scenario base = sar::load_scenario(scenario);
    if (!rule.empty()) base.rule = sar::parse_rule(rule);
    if (interval > 0) base.interval = interval;
    base.steps = steps;
    std::vector<std::pair<std::int64_t, std::int64_t>> grids;
    for (const auto& c : split(cells)) {
      long long nx = 0, ny = 0;
      char x = 0, extra = 0;
      if (std::sscanf(c.c_str(), "%lld%c%lld%c", &nx, &x, &ny, &extra) != 3 || x != 'x' || nx < 1 || ny < 1 ||
          nx > 65536 || ny > 65536)
        throw InputError(fmt::format("--cells '{}': give NXxNY, each 1 to 65536, e.g. 1000x1000", c));
      grids.emplace_back(nx, ny);
    }
    if (grids.empty()) grids.emplace_back(base.nx, base.ny);
    const int team = static_cast<int>(base.helicopters.size());
    int failures = 0;
    std::string csv =
        "backend,nx,ny,Ix,Iy,team,rule,interval,steps,threads,backend_step_s,team_step_s,compute_s,exchange_s,rbe_s,"
        "summary_s,reset_mean_s,host_s\n";
    for (const auto& [nx, ny] : grids) {
      for (const auto& name : split(backends)) {
        sar::Scenario s = base;
        s.nx = nx, s.ny = ny;
        s.backend = name;
        sar::validate(s);
        rbe::BackendOptions options;
        options.threads =
            threads > 0 ? threads : std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / team);
        {
          auto probe = rbe::make_backend(name, options);
          const std::string why = probe->needs_gpu() ? rbe::cuda_unavailable_reason() : std::string();
          if (!why.empty()) {
            std::fprintf(stderr, "bench_sar_team: %s skipped: %s\n", name.c_str(), why.c_str());
            continue;
          }
        }
        try {
        // The team: one thread per platform, records per step.
        Board board(team);
        std::vector<std::vector<sar::Record>> records(static_cast<std::size_t>(team));
        std::exception_ptr error;
        std::mutex error_mutex;
        std::vector<std::thread> pool;
        for (int r = 0; r < team; ++r)
          pool.emplace_back([&, r] {
            try {
              sar::Platform platform(s, r, team, options);
              MemoryTransport transport(board, r);
              for (std::int64_t k = 1; k <= steps; ++k) records[std::size_t(r)].push_back(platform.step(k, transport));
            } catch (...) {
              {
                std::lock_guard<std::mutex> lock(error_mutex);
                if (!error) error = std::current_exception();
              }
              board.failed.store(true);
              board.sync.arrive_and_drop();
            }
          });
        for (auto& t : pool) t.join();
        if (error) std::rethrow_exception(error);
        std::vector<double> total, compute, exchange, rbe_part, summary, reset, host;
        for (std::int64_t k = warmup; k < steps; ++k) {
          double c = 0, e = 0, rb = 0, su = 0, re = 0, ho = 0;
          for (int r = 0; r < team; ++r) {
            const sar::Record& x = records[std::size_t(r)][std::size_t(k)];
            c = std::max(c, x.wall_compute), e = std::max(e, x.wall_exchange), rb = std::max(rb, x.wall_rbe);
            su = std::max(su, x.wall_summary), re = std::max(re, x.wall_reset);
            ho = std::max(ho, x.wall_compute - x.wall_rbe - x.wall_summary - x.wall_reset);
          }
          total.push_back(c + e), compute.push_back(c), exchange.push_back(e), rbe_part.push_back(rb);
          summary.push_back(su), reset.push_back(re), host.push_back(ho);
        }
        // The backend alone: its own step on the scenario's grid and kernel (one likelihood).
        const rbe::GaussianMotion m = rbe::moments(s.drift(s.step_time));
        const rbe::Grid g = s.grid();
        const rbe::KernelSize ks = rbe::kernel_size_for_mass(m, g, s.kernel_mass);
        rbe::Problem p;
        p.grid = g;
        p.kernel = rbe::make_kernel(m, g, ks.Ix, ks.Iy);
        p.prior = sar::prior_belief(s, g);
        p.likelihood.assign(std::size_t(g.cells()), 1.0);
        auto alone = rbe::make_backend(name, options);
        alone->init(p);
        (void)alone->run(5);
        const double backend_step = alone->run(std::max<std::int64_t>(steps, 20)).median().total;
        const std::string row = fmt::format(
            "{},{},{},{},{},{},{},{},{},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", name, nx, ny, ks.Ix,
            ks.Iy, team, sar::to_string(s.rule), s.interval, steps, options.threads, backend_step, median(total),
            median(compute), median(exchange), median(rbe_part), median(summary), mean(reset), median(host));
        csv += row;
        std::fprintf(stderr,
                     "bench_sar_team: %s %lldx%lld: team step %.3g ms (compute %.3g, exchange %.3g; rbe %.3g, summary "
                     "%.3g, host %.3g, new kernel %.3g mean), the backend's own step %.3g ms\n",
                     name.c_str(), static_cast<long long>(nx), static_cast<long long>(ny), median(total) * 1e3,
                     median(compute) * 1e3, median(exchange) * 1e3, median(rbe_part) * 1e3, median(summary) * 1e3,
                     median(host) * 1e3, mean(reset) * 1e3, backend_step * 1e3);
        } catch (const std::exception& e) {
          // One backend's failure (a device error, a backend's bug) leaves the others measured.
          ++failures;
          std::fprintf(stderr, "bench_sar_team: %s %lldx%lld failed: %s\n", name.c_str(), static_cast<long long>(nx),
                       static_cast<long long>(ny), e.what());
        }
      }
    }
    if (out.empty()) std::fputs(csv.c_str(), stdout);
    else std::ofstream(out) << csv;
    if (failures > 0) return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_sar_team: %s\n", e.what());
    return 2;
  }
  return 0;
}
