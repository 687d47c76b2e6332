// The MPI team runtime (team.hpp).
#include <mpi.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "sar/platform.hpp"
#include "sar/snapshot.hpp"
#include "sar/team.hpp"

namespace dtflop::sar {
namespace {

std::atomic<int> g_stop{0};
extern "C" void on_stop(int) { g_stop.store(1); }

double wall() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// Between polls of a pending message: the first kSpin seconds of an exchange give the core away
// and come straight back (a message of a peer on this host arrives in microseconds: a sleep would
// add its own tens of microseconds to every exchange, which the network term would then price),
// then sleep 20 us at a time (a peer that computes does not compete with a spinning waiter).
constexpr double kSpin = 2e-3;
void pause(double start) {
  if (wall() - start < kSpin) std::this_thread::yield();
  else std::this_thread::sleep_for(std::chrono::microseconds(20));
}

class MpiTransport final : public Transport {
 public:
  explicit MpiTransport(double timeout) : timeout_(timeout) {
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  std::vector<std::vector<std::byte>> exchange(std::span<const std::byte> mine, std::int64_t step) override {
    const int n = size_;
    const int count = static_cast<int>(mine.size());
    const int tag = static_cast<int>(step % 30000);
    std::vector<std::vector<std::byte>> got(static_cast<std::size_t>(n));
    std::vector<MPI_Request> recv(std::size_t(n), MPI_REQUEST_NULL), send(std::size_t(n), MPI_REQUEST_NULL);
    for (int p = 0; p < n; ++p) {
      if (p == rank_) continue;
      got[std::size_t(p)].resize(mine.size());
      MPI_Irecv(got[std::size_t(p)].data(), count, MPI_BYTE, p, tag, MPI_COMM_WORLD, &recv[std::size_t(p)]);
    }
    for (int p = 0; p < n; ++p) {
      if (p == rank_) continue;
      MPI_Isend(mine.data(), count, MPI_BYTE, p, tag, MPI_COMM_WORLD, &send[std::size_t(p)]);
    }
    const double start = wall(), deadline = start + timeout_;
    std::vector<char> done(std::size_t(n), 0);
    done[std::size_t(rank_)] = 1;
    int left = n - 1;
    while (left > 0) {
      for (int p = 0; p < n; ++p) {
        if (done[std::size_t(p)]) continue;
        int flag = 0;
        MPI_Status st;
        const int rc = MPI_Test(&recv[std::size_t(p)], &flag, &st);
        if (rc != MPI_SUCCESS) throw RankLost(p, step, fmt::format("receiving from rank {} failed (MPI error {})", p, rc));
        if (flag) {
          int c = 0;
          MPI_Get_count(&st, MPI_BYTE, &c);
          if (c != count)
            throw std::runtime_error(fmt::format("rank {} sent {} bytes at step {}, expected {}", p, c, step, count));
          done[std::size_t(p)] = 1;
          --left;
        }
      }
      if (left == 0) break;
      const bool stopped = g_stop.load() != 0;
      if (stopped || wall() > deadline) {
        std::string missing;
        int first = -1;
        for (int p = 0; p < n; ++p)
          if (!done[std::size_t(p)]) {
            missing += (missing.empty() ? "" : ", ") + std::to_string(p);
            if (first < 0) first = p;
          }
        // One rank missing: that is the lost one. Several (the launcher stopped the others too
        // before they sent): name them all; mpirun's own message names the one that ended.
        const bool one = missing.find(',') == std::string::npos;
        throw RankLost(one ? first : -1, step,
                       stopped ? fmt::format("the launcher stopped this process while it waited for rank{} {}",
                                             one ? "" : "s", missing)
                               : fmt::format("no message from rank{} {} in {} s", one ? "" : "s", missing, timeout_));
      }
      pause(start);
    }
    // Our sends complete once their receivers took them (every receiver is past its receive).
    const double send_deadline = wall() + timeout_;
    for (int p = 0; p < n; ++p) {
      if (p == rank_) continue;
      for (;;) {
        int flag = 0;
        MPI_Test(&send[std::size_t(p)], &flag, MPI_STATUS_IGNORE);
        if (flag) break;
        if (g_stop.load() != 0 || wall() > send_deadline)
          throw RankLost(p, step, fmt::format("rank {} did not take this rank's message", p));
        pause(start);
      }
    }
    got[std::size_t(rank_)].assign(mine.begin(), mine.end());
    return got;
  }

 private:
  double timeout_;
  int rank_ = 0, size_ = 1;
};

std::string record_header() {
  return "step,time,dt,link_delay,heli_x,heli_y,heli_heading,raft_x,raft_y,distance,detected,fused,restarted,"
         "mean_x,mean_y,cov_xx,cov_xy,cov_yy,map_x,map_y,entropy,wall_compute,wall_exchange,wall_rbe,wall_summary,"
         "wall_reset\n";
}
std::string record_line(const Record& r) {
  const auto& e = r.estimate;
  return fmt::format("{},{:.6f},{:.9g},{:.9g},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{},{},{},{:.6f},{:.6f},{:.9g},{:.9g},"
                     "{:.9g},{:.6f},{:.6f},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n",
                     e.step, e.time, r.dt, r.link_delay, r.heli.x, r.heli.y, r.heli.heading, r.raft.x, r.raft.y,
                     r.distance, e.detected, r.fused, r.restarted, e.mean_x, e.mean_y, e.cov_xx, e.cov_xy, e.cov_yy,
                     e.map_x, e.map_y, e.entropy, r.wall_compute, r.wall_exchange, r.wall_rbe, r.wall_summary,
                     r.wall_reset);
}

// A new file for appending, never over a link or a non-regular file.
std::ofstream open_new(const std::filesystem::path& p) {
  if (std::filesystem::is_symlink(p) || (std::filesystem::exists(p) && !std::filesystem::is_regular_file(p)))
    throw InputError(fmt::format("'{}' is not a regular file; give another --out folder", p.string()));
  std::ofstream f(p, std::ios::trunc);
  if (!f) throw InputError(fmt::format("cannot write '{}'; check the --out folder", p.string()));
  return f;
}

// Per-step series every rank contributes to rank 0: distance, entropy, detected, x, y, time,
constexpr int kSeries = 9;  // + raft x, y, and the estimate's error |mean - raft|
constexpr int kWalls = 5;   // per step: compute, exchange, and of the compute rbe, summary, reset

int finish(int status) {
  MPI_Finalize();
  return status;
}

// MPI started for one process of a team: errors returned (not fatal), SIGTERM and SIGINT stop the
// run between steps, and this process's rank and the team's size.
void start_mpi(int* rank, int* size) {
  int provided = 0;
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SINGLE, &provided);
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  std::signal(SIGTERM, on_stop);
  std::signal(SIGINT, on_stop);
  MPI_Comm_rank(MPI_COMM_WORLD, rank);
  MPI_Comm_size(MPI_COMM_WORLD, size);
}

}  // namespace

bool have_mpi() { return true; }

int run_team(const Scenario& scenario, const TeamOptions& o) {
  int rank = 0, size = 1;
  start_mpi(&rank, &size);

  // Every process must hold the same team: compare digests (and the grid, for the message).
  std::uint64_t mine[3] = {team_digest(scenario), std::uint64_t(scenario.nx), std::uint64_t(scenario.ny)};
  std::vector<std::uint64_t> all(std::size_t(3 * size));
  MPI_Allgather(mine, 3, MPI_UINT64_T, all.data(), 3, MPI_UINT64_T, MPI_COMM_WORLD);
  for (int p = 1; p < size; ++p) {
    const std::uint64_t* q = &all[std::size_t(3 * p)];
    if (q[0] != all[0]) {
      if (rank == 0) {
        const std::string what = (q[1] != all[1] || q[2] != all[2])
                                     ? fmt::format("rank {} has a {}x{} grid, rank 0 a {}x{} grid", p, q[1], q[2], all[1], all[2])
                                     : fmt::format("rank {} holds another scenario than rank 0 (motion, sensor, fusion, "
                                                   "helicopters or seed differ)",
                                                   p);
        fmt::print(stderr, "dtflop: error: the processes disagree on the scenario: {}; start every process with the same "
                           "--scenario and options\n", what);
      }
      return finish(2);
    }
  }
  if (static_cast<int>(scenario.helicopters.size()) != size) {
    if (rank == 0)
      fmt::print(stderr,
                 "dtflop: error: scenario '{}' has {} helicopters but {} process{} started; run `mpirun -n {} dtflop sar "
                 "...` (one process per helicopter)\n",
                 scenario.name, scenario.helicopters.size(), size, size == 1 ? " was" : "es were",
                 scenario.helicopters.size());
    return finish(2);
  }
  const std::filesystem::path out(o.out);
  try {
    make_output_folder(out, fmt::format("--out '{}'", o.out));
  } catch (const InputError& e) {
    fmt::print(stderr, "dtflop: error: {}\n", e.what());
    return finish(2);
  }

  std::vector<std::uint64_t> seeds = o.seeds.empty() ? std::vector<std::uint64_t>{scenario.seed} : o.seeds;
  MpiTransport transport(o.peer_timeout);
  std::ofstream summary;
  if (rank == 0) summary = open_new(out / "summary.jsonl");
  for (std::uint64_t seed : seeds) {
    Scenario s = scenario;
    s.seed = seed;
    const std::string tag = seeds.size() > 1 || !o.seeds.empty() ? fmt::format("seed-{}-", seed) : std::string();
    std::ofstream rec;
    const std::filesystem::path rec_path = out / fmt::format("{}heli-{}.csv", tag, rank);
    if (o.records) {
      rec = open_new(rec_path);
      rec << record_header();
      rec.flush();
    }
    std::vector<double> series(std::size_t(s.steps * kSeries));
    std::vector<double> walls(std::size_t(s.steps * kWalls));
    std::vector<std::vector<double>> snap_beliefs;
    std::int64_t first_detection = -1, detections = 0, fusions = 0, restarts = 0;
    double first_detection_time = -1, entropy_sum = 0;
    std::int64_t k = 0;
    try {
      rbe::BackendOptions backend_options;
      backend_options.threads = o.threads;
      Platform platform(s, rank, size, backend_options);
      const double run_start = wall();
      if (std::find(o.snapshots.begin(), o.snapshots.end(), 0) != o.snapshots.end() && rank == 0)
        snap_beliefs.push_back(platform.belief());
      for (k = 1; k <= s.steps; ++k) {
        if (g_stop.load() != 0)
          throw RankLost(-1, k, "the launcher stopped this process between exchanges (another process of the team ended)");
        if (rank == o.fail_rank && k == o.fail_step) {
          std::fflush(nullptr);
          std::raise(SIGKILL);  // testing: this helicopter is lost
        }
        const Record r = platform.step(k, transport);
        if (o.records) {
          rec << record_line(r);
          rec.flush();
        }
        double* row = &series[std::size_t((k - 1) * kSeries)];
        row[0] = r.distance, row[1] = r.estimate.entropy, row[2] = r.estimate.detected, row[3] = r.heli.x,
        row[4] = r.heli.y, row[5] = r.estimate.time, row[6] = r.raft.x, row[7] = r.raft.y;
        row[8] = std::hypot(r.estimate.mean_x - r.raft.x, r.estimate.mean_y - r.raft.y);
        double* w = &walls[std::size_t(kWalls * (k - 1))];
        w[0] = r.wall_compute, w[1] = r.wall_exchange, w[2] = r.wall_rbe, w[3] = r.wall_summary, w[4] = r.wall_reset;
        if (r.estimate.detected == 1) {
          ++detections;
          if (first_detection < 0) first_detection = k, first_detection_time = r.estimate.time;
        }
        fusions += r.fused;
        restarts += r.restarted;
        entropy_sum += r.estimate.entropy;
        if (rank == 0 && std::find(o.snapshots.begin(), o.snapshots.end(), k) != o.snapshots.end())
          snap_beliefs.push_back(platform.belief());
      }
      const double run_wall = wall() - run_start;
      // The team's series and summary on rank 0.
      std::vector<double> team_series(rank == 0 ? series.size() * std::size_t(size) : 0);
      std::vector<double> team_walls(rank == 0 ? walls.size() * std::size_t(size) : 0);
      double stats[6] = {double(first_detection), first_detection_time, double(detections), double(fusions),
                         double(restarts), entropy_sum / double(s.steps)};
      std::vector<double> team_stats(rank == 0 ? std::size_t(6 * size) : 0);
      MPI_Gather(series.data(), int(series.size()), MPI_DOUBLE, team_series.data(), int(series.size()), MPI_DOUBLE, 0,
                 MPI_COMM_WORLD);
      MPI_Gather(walls.data(), int(walls.size()), MPI_DOUBLE, team_walls.data(), int(walls.size()), MPI_DOUBLE, 0,
                 MPI_COMM_WORLD);
      MPI_Gather(stats, 6, MPI_DOUBLE, team_stats.data(), 6, MPI_DOUBLE, 0, MPI_COMM_WORLD);
      if (rank == 0) {
        // series CSV: step, time, then per helicopter distance, entropy, detected.
        std::string csv = "step,time";
        for (int p = 0; p < size; ++p) csv += fmt::format(",distance_{0},entropy_{0},detected_{0},error_{0}", p);
        csv += "\n";
        for (std::int64_t j = 0; j < s.steps; ++j) {
          csv += fmt::format("{},{:.6f}", j + 1, series[std::size_t(j * kSeries + 5)]);
          for (int p = 0; p < size; ++p) {
            const double* q = &team_series[std::size_t(p) * series.size() + std::size_t(j * kSeries)];
            csv += fmt::format(",{:.6f},{:.9g},{},{:.6f}", q[0], q[1], int(q[2]), q[8]);
          }
          csv += "\n";
        }
        write_file_atomically(out / fmt::format("{}series.csv", tag), csv);
        // Wall time of a team step: the slowest rank's compute and exchange each step, median over steps.
        // The parts (rbe, summary, reset: of the compute) are the slowest rank's each, step by step.
        std::vector<double> step_total, step_compute, step_exchange, step_rbe, step_summary, step_reset;
        for (std::int64_t j = 0; j < s.steps; ++j) {
          double c = 0, e = 0, rb = 0, su = 0, re = 0;
          for (int p = 0; p < size; ++p) {
            const double* w = &team_walls[std::size_t(p) * walls.size() + std::size_t(kWalls * j)];
            c = std::max(c, w[0]), e = std::max(e, w[1]), rb = std::max(rb, w[2]), su = std::max(su, w[3]),
            re = std::max(re, w[4]);
          }
          step_compute.push_back(c), step_exchange.push_back(e), step_total.push_back(c + e);
          step_rbe.push_back(rb), step_summary.push_back(su), step_reset.push_back(re);
        }
        auto median = [](std::vector<double> v) {
          std::sort(v.begin(), v.end());
          return v.empty() ? 0.0 : v[v.size() / 2];
        };
        auto mean = [](const std::vector<double>& v) {
          double a = 0;
          for (double x : v) a += x;
          return v.empty() ? 0.0 : a / double(v.size());
        };
        nlohmann::json per = nlohmann::json::array();
        std::int64_t team_first = -1;
        double team_first_time = -1, ent = 0;
        for (int p = 0; p < size; ++p) {
          const double* q = &team_stats[std::size_t(6 * p)];
          per.push_back({{"first_detection_step", std::int64_t(q[0])}, {"first_detection_time", q[1]},
                         {"detections", std::int64_t(q[2])}, {"fusions", std::int64_t(q[3])},
                         {"restarts", std::int64_t(q[4])}, {"mean_entropy", q[5]}});
          if (q[0] >= 0 && (team_first < 0 || q[0] < double(team_first))) team_first = std::int64_t(q[0]), team_first_time = q[1];
          ent += q[5] / double(size);
        }
        const MeanTraffic mt = mean_traffic(s, size);
        const nlohmann::json line = {
            {"scenario", s.name}, {"seed", seed}, {"rule", to_string(s.rule)}, {"interval", s.interval},
            {"helicopters", size}, {"steps", s.steps}, {"grid", {s.nx, s.ny}}, {"backend", s.backend},
            {"link", {{"enabled", s.link_enabled}, {"bandwidth_mbps", s.bandwidth_mbps}, {"latency_ms", s.latency_ms},
                      {"sleep", s.link_sleep}}},
            {"first_detection_step", team_first}, {"first_detection_time", team_first_time},
            {"mean_entropy", ent}, {"physical_time", series[std::size_t((s.steps - 1) * kSeries + 5)]},
            {"messages_per_step", mt.messages}, {"bytes_per_step", mt.bytes},
            {"wall_step_median", median(step_total)}, {"wall_step_mean", mean(step_total)},
            {"wall_compute_mean", mean(step_compute)}, {"wall_exchange_mean", mean(step_exchange)},
            {"wall_rbe_median", median(step_rbe)}, {"wall_summary_median", median(step_summary)},
            {"wall_reset_mean", mean(step_reset)}, {"wall_compute_median", median(step_compute)},
            {"wall_exchange_median", median(step_exchange)},
            {"wall_run", run_wall}, {"per_helicopter", per}};
        summary << line.dump() << "\n";
        summary.flush();
        if (!o.quiet)
          fmt::print(stderr, "dtflop sar: seed {}: {} fusion{}: first detection {}, mean entropy {:.3f} nats, {:.3g} ms per team step\n",
                     seed, to_string(s.rule),
                     s.rule == Rule::belief || s.rule == Rule::loglinear ? fmt::format(" every {}", s.interval) : "",
                     team_first < 0 ? std::string("none") : fmt::format("at step {} ({:.1f} s)", team_first, team_first_time),
                     ent, 1e3 * median(step_total));
        // Snapshots: rank 0's belief, every helicopter's track up to that step, the raft's.
        for (std::size_t i = 0; i < snap_beliefs.size(); ++i) {
          std::vector<std::int64_t> steps = o.snapshots;
          std::sort(steps.begin(), steps.end());
          steps.erase(std::unique(steps.begin(), steps.end()), steps.end());
          steps.erase(std::remove_if(steps.begin(), steps.end(), [&](std::int64_t x) { return x < 0 || x > s.steps; }),
                      steps.end());
          if (i >= steps.size()) break;
          const std::int64_t at = steps[i];
          std::vector<Track> helis(static_cast<std::size_t>(size));
          for (int p = 0; p < size; ++p) {
            helis[std::size_t(p)].points.push_back({s.helicopters[std::size_t(p)].x, s.helicopters[std::size_t(p)].y});
            for (std::int64_t j = 0; j < at; ++j) {
              const double* q = &team_series[std::size_t(p) * series.size() + std::size_t(j * kSeries)];
              helis[std::size_t(p)].points.push_back({q[3], q[4]});
            }
          }
          Track raft;
          for (std::int64_t j = 0; j < at; ++j)
            raft.points.push_back({series[std::size_t(j * kSeries + 6)], series[std::size_t(j * kSeries + 7)]});
          write_snapshot((out / fmt::format("{}snapshot-{:06d}.png", tag, at)).string(), platform.grid(),
                         snap_beliefs[i], raft, helis);
        }
      }
    } catch (const RankLost& e) {
      const std::string who = e.rank() >= 0 ? fmt::format("helicopter {} (rank {}) was lost", e.rank(), e.rank())
                                            : std::string("the team lost a process (mpirun names it; see below)");
      fmt::print(stderr, "dtflop: failed: {} at step {}: {}; rank {} stops here and keeps its results{}; restart the team\n",
                 who, e.step(), e.what(), rank, o.records ? fmt::format(" in {}", rec_path.string()) : std::string());
      if (rec.is_open()) rec.close();
      std::fflush(nullptr);
      std::_Exit(1);  // MPI_Finalize would wait for the lost rank
    } catch (const InputError& e) {
      fmt::print(stderr, "dtflop: error: rank {}: {}\n", rank, e.what());
      std::fflush(nullptr);
      MPI_Abort(MPI_COMM_WORLD, 2);
    } catch (const std::exception& e) {
      fmt::print(stderr, "dtflop: failed: rank {} at step {}: {}\n", rank, k, e.what());
      std::fflush(nullptr);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
  }
  return finish(0);
}

int run_exchange_sweep(const ExchangeSweep& sweep, const std::function<void(int team)>& begin,
                       const std::function<void(const ExchangeSample&)>& sink) {
  int rank = 0, size = 1;
  start_mpi(&rank, &size);
  if (size < 2) {
    fmt::print(stderr, "dtflop: error: an exchange sweep needs a team: run it under `mpirun -n N dtflop sar ...` with "
                       "N >= 2\n");
    return finish(2);
  }
  // Rank 0 opens what it writes to before anything is measured; the others wait for its word.
  int ok = 1;
  if (rank == 0) {
    try {
      begin(size);
    } catch (const InputError& e) {
      fmt::print(stderr, "dtflop: error: {}\n", e.what());
      ok = 0;
    }
  }
  MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (!ok) return finish(2);
  MpiTransport transport(sweep.peer_timeout);
  std::int64_t tag = 0;
  try {
    for (const std::int64_t bytes : sweep.bytes) {
      std::vector<std::byte> mine(static_cast<std::size_t>(bytes), std::byte{0x5a});
      ExchangeSample sample;
      sample.bytes = bytes;
      sample.team = size;
      sample.exchanges = sweep.exchanges;
      for (int r = -sweep.warmup; r < sweep.repetitions; ++r) {
        MPI_Barrier(MPI_COMM_WORLD);
        const double t0 = wall();
        for (int e = 0; e < sweep.exchanges; ++e) (void)transport.exchange(mine, ++tag);
        double t = wall() - t0, slowest = 0;
        MPI_Reduce(&t, &slowest, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
        if (r >= 0) sample.seconds.push_back(slowest);
      }
      if (rank == 0) sink(sample);
    }
  } catch (const RankLost& e) {
    fmt::print(stderr, "dtflop: failed: the exchange sweep lost a process: {}; rank {} stops here\n", e.what(), rank);
    std::fflush(nullptr);
    std::_Exit(1);
  } catch (const InputError& e) {
    fmt::print(stderr, "dtflop: error: rank {}: {}\n", rank, e.what());
    std::fflush(nullptr);
    MPI_Abort(MPI_COMM_WORLD, 2);
  } catch (const std::exception& e) {
    fmt::print(stderr, "dtflop: failed: rank {}: {}\n", rank, e.what());
    std::fflush(nullptr);
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  return finish(0);
}

}  // namespace dtflop::sar
