// `dtflop characterize`: the main job. Probes this machine, sweeps every reference workload on
// every backend the machine can run (a training plan and a held-out plan), fits the model to
// the training samples, validates it on the held-out ones, and writes the reports, all into one
// folder. Each step is the dtflop command a user would type (run as a child of this process,
// its output kept in the folder), so the folder shows how every figure was made and any step can
// be rerun by hand. Rerunning after an interruption resumes: a finished step's output is kept,
// and a sweep measures only what its store lacks.
#include <spawn.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/command.hpp"
#include "cli/workload_cli.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/units.hpp"
#include "workloads/workload.hpp"

extern char** environ;

namespace dtflop::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct CharacterizeOptions {
  std::string output = "report";
  bool quick = false;
  bool full = false;
  int rounds = 0;  // 0: the mode's
};

// The training and held-out plans of the quick mode: small configurations that span the
// workload's costs in a few seconds each on a 2-core machine (plan files, written into the
// folder), and on a GPU somewhat larger ones. A workload without a row here sweeps random plans.
json quick_plan(const std::string& workload, bool held, bool gpu) {
  json configs = json::array();
  if (workload == "rbe") {
    const std::vector<int> grids = gpu ? std::vector<int>{200, 360, 520, 700, 880, 1000}
                                       : std::vector<int>{100, 150, 220, 300, 400, 500};
    const std::vector<int> kernels = held ? std::vector<int>{5, 13, 27, 41} : std::vector<int>{3, 9, 17, 33, 49};
    for (std::size_t i = 0; i < grids.size(); ++i)
      for (std::size_t k = 0; k < kernels.size(); ++k) {
        if ((i + k) % 2 != (held ? 1u : 0u)) continue;
        const int nx = grids[i], ny = grids[(i + 2) % grids.size()];
        configs.push_back({{"grid", fmt::format("{}x{}", nx, ny)},
                           {"kernel", fmt::format("{}x{}", kernels[k], kernels[(k + 1) % kernels.size()])}});
      }
  } else if (workload == "dct") {
    const std::vector<std::string> sizes = gpu ? std::vector<std::string>{"1600x1200", "2400x1600", "3200x2400"}
                                               : std::vector<std::string>{"640x480", "800x600", "1024x768"};
    const std::vector<int> dots = held ? std::vector<int>{80, 150} : std::vector<int>{60, 120, 200};
    const std::vector<std::string> points = held ? std::vector<std::string>{"20x20", "28x28"}
                                                 : std::vector<std::string>{"16x16", "32x32"};
    const std::vector<int> supports = held ? std::vector<int>{18, 30} : std::vector<int>{12, 25, 40};
    int n = 0;
    for (const auto& s : sizes)
      for (int d : dots)
        for (const auto& p : points) {
          const int sup = supports[static_cast<std::size_t>(n++) % supports.size()];
          if (sup > d) continue;
          configs.push_back({{"size", s}, {"dots", d}, {"radius", 6}, {"points", p}, {"support", sup}});
        }
  } else {
    return nullptr;
  }
  return {{"description", fmt::format("dtflop characterize: small {} plan of {}", held ? "held-out" : "training", workload)},
          {"configs", configs}};
}

std::string now_hms() {
  const auto t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[16];
  std::strftime(buf, sizeof buf, "%H:%M:%S", &tm);
  return buf;
}

// Runs this dtflop with `args`, its stdout into `out_file` (empty: our stdout), its stderr on
// ours. Returns its exit status.
int run_self(const std::vector<std::string>& args, const fs::path& out_file) {
  const std::string self = fs::read_symlink("/proc/self/exe").string();
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(self.c_str()));
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  const fs::path tmp = out_file.string() + ".part";
  if (!out_file.empty())
    posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::fflush(stdout);
  std::fflush(stderr);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, self.c_str(), &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) throw std::runtime_error(fmt::format("cannot start {}: {}", self, std::strerror(rc)));
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) throw std::runtime_error("waitpid failed");
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 1;
  if (!out_file.empty()) {
    std::error_code ec;
    if (code == 0) fs::rename(tmp, out_file, ec);
    else fs::rename(tmp, out_file.string() + ".failed", ec);
  }
  return code;
}

std::string join(const std::vector<std::string>& a) {
  std::string s = "dtflop";
  for (const auto& x : a) s += " " + x;
  return s;
}

struct Step {
  std::vector<std::string> args;
  fs::path output;       // its stdout; also the mark that it is done (unless `always`)
  fs::path done_when;    // the step is done when this exists (default: output)
  bool always = false;   // run even when done (sweeps: they resume by themselves)
};

class Runner {
 public:
  explicit Runner(int total) : total_(total) {}
  // Runs the step unless it is done; throws on failure, naming the step and its output.
  void run(const Step& s) {
    ++n_;
    const fs::path mark = s.done_when.empty() ? s.output : s.done_when;
    std::error_code ec;
    if (!s.always && !mark.empty() && fs::exists(mark, ec)) {
      fmt::print(stderr, "[{}/{}] {} (done earlier: {})\n", n_, total_, join(s.args), mark.string());
      return;
    }
    fmt::print(stderr, "[{}/{}] {} {}\n", n_, total_, now_hms(), join(s.args));
    const int code = run_self(s.args, s.output);
    if (code != 0)
      throw std::runtime_error(fmt::format("step {} of {} failed (exit {}): {}{}; rerun `dtflop characterize` to resume "
                                           "after fixing it",
                                           n_, total_, code, join(s.args),
                                           s.output.empty() ? "" : "; its output is in " + s.output.string() + ".failed"));
  }

 private:
  int total_, n_ = 0;
};

void run(const CharacterizeOptions& o) {
  if (o.quick && o.full) throw InputError("--quick and --full exclude each other; give one (or neither: the small plans with the full probe)");
  const fs::path out = o.output;
  std::error_code ec;
  make_output_folder(out, fmt::format("-o '{}'", o.output));
  const auto t0 = std::chrono::steady_clock::now();

  // 1. The probe: everything after depends on what it found (a GPU or not).
  const fs::path machine = out / "machine.json";
  Runner first(1);
  std::vector<std::string> probe = {"probe", "-o", machine.string()};
  if (o.quick) probe.insert(probe.begin() + 1, "--quick");
  first.run({probe, out / "probe.txt", machine});
  const MachineProfile profile = load_profile(machine);
  const bool gpu = profile.has(Param::V_G_fp32);
  if (!gpu)
    fmt::print(stderr, "characterize: no GPU was probed: the GPU backends are left out\n");

  // 2-5. Per workload and backend: sweeps, fit, validation, report.
  struct Job {
    std::string workload, backend;
    fs::path dir;
  };
  std::vector<Job> jobs;
  for (const workload::Workload* w : workload::all())
    for (const auto& b : w->backends()) {
      if (b->needs_gpu() && !gpu) continue;
      // A backend the in-process protocol cannot run (sar-net's mpi: its samples come from an MPI team).
      if (!b->needs_gpu() && !b->unavailable().empty()) continue;
      jobs.push_back({std::string(w->name()), b->name(), out / fmt::format("{}-{}", w->name(), b->name())});
    }
  // Rounds: the fastest of them stands for a configuration, which shields the fit from a
  // co-tenant's burst on a shared machine (docs/calibration.md, "Combining the rounds").
  const int rounds = o.rounds > 0 ? o.rounds : (o.quick ? 2 : 3);
  Runner r(static_cast<int>(jobs.size()) * 5 + 1);
  for (const auto& j : jobs) {
    fs::create_directories(j.dir, ec);
    std::string fit_plan, held_plan;
    const json qf = quick_plan(j.workload, false, gpu && j.backend.rfind("cuda", 0) == 0);
    if (o.full || qf.is_null()) {
      const workload::Workload& w = workload::find(j.workload);
      const auto names = w.plan_names();
      fit_plan = o.full && !names.empty() && names.front().first.rfind("random", 0) != 0 ? names.front().first : "random:24";
      held_plan = o.full ? "random:50" : "random:12";
    } else {
      fit_plan = (j.dir / "plan-fit.json").string();
      held_plan = (j.dir / "plan-held.json").string();
      if (!fs::exists(fit_plan)) write_file_atomically(fit_plan, qf.dump(2) + "\n");
      if (!fs::exists(held_plan))
        write_file_atomically(held_plan, quick_plan(j.workload, true, gpu && j.backend.rfind("cuda", 0) == 0).dump(2) + "\n");
    }
    const std::string fit = (j.dir / "fit.jsonl").string(), held = (j.dir / "held.jsonl").string();
    const fs::path fitted = j.dir / "fitted.json";
    // Sweeps always run: a finished one finds every sample in its store and measures nothing.
    r.run({{"sweep", j.workload, "--backend", j.backend, "--plan", fit_plan, "--store", fit, "--rounds",
            std::to_string(rounds), "--seed", "1"},
           j.dir / "sweep-fit.txt", {}, true});
    r.run({{"sweep", j.workload, "--backend", j.backend, "--plan", held_plan, "--store", held, "--rounds",
            std::to_string(rounds), "--seed", "2"},
           j.dir / "sweep-held.txt", {}, true});
    // A fit that ends on a physical bound is a finding about this backend here, not a reason to
    // stop the other backends: it is written, and the headline points at it.
    r.run({{"calibrate", "--store", fit, "--machine", machine.string(), "-o", fitted.string(), "--accept-bounds"},
           j.dir / "calibrate.txt", fitted});
    r.run({{"validate", "--store", held, "--machine", fitted.string(), "--json"}, j.dir / "validate.json"});
    r.run({{"report", "predicted", "--store", held, "--machine", fitted.string(), "-o", (j.dir / "report").string()},
           j.dir / "report.txt", j.dir / "report" / "report.html"});
  }
  r.run({{"report", "machine", "--machine", machine.string(), "-o", (out / "machine-report").string()},
         out / "machine-report.txt", out / "machine-report" / "report.html"});

  // The headline numbers.
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  fmt::print("Characterized {} in {:.0f} s; everything is in {}/\n", profile.identity.cpu_model +
             (gpu ? " + " + profile.identity.gpu_name : ""), secs, out.string());
  fmt::print("Machine report: {}\n", (out / "machine-report" / "report.html").string());
  auto param = [&](Param p) { return profile.has(p) ? format_quantity(profile.get(p).value, info(p).unit) : "-"; };
  fmt::print("  CPU FP32 {} (1 thread {}), host memory {}", param(Param::V_C_fp32), param(Param::V_C1_fp32),
             param(Param::B_host));
  if (gpu)
    fmt::print(", GPU FP32 {}, device memory {}, host->device pinned {}", param(Param::V_G_fp32), param(Param::B_GG),
               param(Param::B_CG_pinned));
  fmt::print("\nHeld-out error of the total per step (mean / max), and each backend's report:\n");
  for (const auto& j : jobs) {
    std::string errors = "-";
    try {
      const json v = read_json_file(j.dir / "validate.json", "validation", "rerun dtflop characterize");
      const auto& t = v.at("groups").at("all").at("total");
      errors = fmt::format("{:.1f}% / {:.1f}% over {} configurations, variant {}", 100 * t.at("mean_rel").get<double>(),
                           100 * t.at("max_rel").get<double>(), t.at("n").get<int>(), v.at("variant").get<std::string>());
    } catch (const std::exception&) {
    }
    try {
      if (read_file_limited(j.dir / "calibrate.txt", "calibrate.txt", kMaxJsonFileBytes).find("at a physical bound") !=
          std::string::npos)
        errors += " (a fitted parameter at a physical bound: see calibrate.txt)";
    } catch (const std::exception&) {
    }
    fmt::print("  {:<4} {:<14} {}  {}\n", j.workload, j.backend, errors, (j.dir / "report" / "report.html").string());
  }
}

}  // namespace

void add_characterize_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "characterize",
      "The main job: probe this machine, sweep both reference workloads on every backend it can run, fit the model, "
      "validate it on held-out runs, and write the reports, into one folder (resumable: rerun to continue).");
  auto o = std::make_shared<CharacterizeOptions>();
  app->add_option("-o,--output", o->output, "Folder for everything (created; a rerun resumes in it)")->capture_default_str();
  app->add_flag("--quick", o->quick, "Quick probe, small plans, 2 rounds (the test suite's mode; under a minute on 2 cores)");
  app->add_flag("--full", o->full,
                "The workloads' first seed plan for the fit and random:50 held out (the dissertation's tests; long)");
  app->add_option("--rounds", o->rounds, "Replicate rounds of every sweep (default: 3, --quick 2)")->check(CLI::Range(1, 50));
  app->callback([o] { run(*o); });
}

}  // namespace dtflop::cli
