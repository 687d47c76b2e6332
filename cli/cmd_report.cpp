// `dtflop report`: readable reports (HTML with inline SVG charts, Markdown, CSV) made from
// machine profiles and sample stores alone (reports/reports.hpp, docs/reports.md).
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli/command.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "reports/reports.hpp"

namespace dtflop::cli {
namespace {

namespace fs = std::filesystem;

struct ReportOptions {
  std::vector<std::string> machines;
  std::vector<std::string> stores;
  std::vector<std::string> stores_b;  // compare: run B (stores: run A)
  std::vector<std::string> backends;
  std::vector<std::string> match;
  std::vector<std::string> names;
  std::string variant;
  std::string rounds_combine;
  std::string output;
  int worst = 10;
  std::string tuned;                // tuning: the `dtflop tune -o` result
  std::vector<std::string> peers;   // tuning: peers' replays on the same space
};

// The command line as given, for the report's header (words with spaces quoted).
std::string quoted(const std::string& w) {
  return w.find_first_of(" \t\"'") == std::string::npos ? w : "'" + w + "'";
}

// Writes the report and prints where it is, then its headline lines.
void finish(const reports::Document& doc, const std::string& output) {
  const fs::path html = reports::write_report(doc, output);
  fmt::print(stderr, "dtflop report: wrote {} (and report.md, {} CSV files)\n", html.string(), reports::charts(doc).size());
  fmt::print("{}\n", html.string());
  for (const auto& s : doc.summary) fmt::print("  {}\n", s);
}

// An existing output is refused before any input is read.
void check_report_folder(const std::string& output) {
  std::error_code ec;
  if (fs::symlink_status(output, ec).type() != fs::file_type::not_found)
    throw InputError(fmt::format("'{}' already exists; a report is written into a new folder: name one that does not exist",
                                 output));
}

std::string join_cmd(const std::string& verb, const std::vector<std::pair<std::string, std::string>>& opts) {
  std::string c = "dtflop report " + verb;
  for (const auto& [k, v] : opts) c += " " + k + (v.empty() ? "" : " " + quoted(v));
  return c;
}

}  // namespace

void add_report_command(CLI::App& root) {
  auto* app = root.add_subcommand(
      "report",
      "Make a readable report (one self-contained HTML file with SVG charts, a Markdown summary and a CSV file per "
      "chart) from machine profiles, sample stores and tuning results: `machine`, `predicted`, `compare` or "
      "`tuning`.");
  app->require_subcommand(1);
  auto o = std::make_shared<ReportOptions>();

  auto* m = app->add_subcommand("machine",
                                "One machine: transfer bandwidth against size with the fitted latency + bandwidth curve, "
                                "rates and bandwidths against known peaks, every parameter");
  m->add_option("--machine,-m", o->machines, "Machine profile (`dtflop probe -o` or `dtflop calibrate -o`)")
      ->required()
      ->expected(1)
      ->check(CLI::ExistingFile);
  m->add_option("-o,--output", o->output, "Folder to write the report into (must not exist)")->required();
  m->callback([o] {
    check_report_folder(o->output);
    const MachineProfile p = load_profile(o->machines.at(0));
    reports::Context ctx{join_cmd("machine", {{"--machine", o->machines[0]}, {"-o", o->output}}), {o->machines[0]}};
    finish(reports::machine_report(p, ctx), o->output);
  });

  auto* p = app->add_subcommand(
      "predicted",
      "Predicted against measured for sample stores of one machine and the profile fitted for it: per component "
      "predicted lines and measured points, mean/max errors, fitted parameters, chosen variant, worst configurations");
  p->add_option("--store,-s", o->stores, "Sample store(s) (repeatable; held-out stores give held-out errors)")->required();
  p->add_option("--machine,-m", o->machines, "Fitted machine profile (`dtflop calibrate -o`)")
      ->required()
      ->expected(1)
      ->check(CLI::ExistingFile);
  p->add_option("--backend", o->backends, "Only samples of these backends (repeatable)");
  p->add_option("--match", o->match,
                "Only samples whose key contains this text, e.g. host-memory=pinned (repeatable: all must match)");
  p->add_option("--variant", o->variant, "Model variant (default: the one the fit chose)");
  p->add_option("--rounds-combine", o->rounds_combine,
                "How the rounds of a configuration give its time: fastest, p25 or median (default: the fit's)");
  p->add_option("--worst", o->worst, "Name this many worst configurations")->capture_default_str()->check(CLI::Range(0, 1000));
  p->add_option("-o,--output", o->output, "Folder to write the report into (must not exist)")->required();
  p->callback([o] {
    check_report_folder(o->output);
    reports::PredictedInput in;
    in.stores = o->stores;
    in.profile_path = o->machines.at(0);
    if (!o->variant.empty()) {
      in.variant = variant_from_string(o->variant);
      if (!in.variant) throw InputError(fmt::format("--variant '{}' is unknown; use {}", o->variant, variant_names()));
    }
    in.rounds_combine = o->rounds_combine;
    in.backends = o->backends;
    in.match = o->match;
    in.worst = o->worst;
    std::vector<std::pair<std::string, std::string>> args;
    for (const auto& s : o->stores) args.push_back({"--store", s});
    args.push_back({"--machine", in.profile_path});
    for (const auto& b : o->backends) args.push_back({"--backend", b});
    for (const auto& t : o->match) args.push_back({"--match", t});
    if (!o->variant.empty()) args.push_back({"--variant", o->variant});
    if (!o->rounds_combine.empty()) args.push_back({"--rounds-combine", o->rounds_combine});
    args.push_back({"-o", o->output});
    reports::Context ctx{join_cmd("predicted", args), o->stores};
    ctx.inputs.push_back(in.profile_path);
    finish(reports::predicted_report(in, ctx), o->output);
  });

  auto* c = app->add_subcommand("compare",
                                "Two profiles (two machines, or two runs of one) parameter by parameter, or two runs' "
                                "sample stores configuration by configuration, with ratios");
  c->add_option("--machine,-m", o->machines, "Two profiles to compare, A then B (give --machine twice)")
      ->expected(2)
      ->check(CLI::ExistingFile);
  c->add_option("--store-a", o->stores, "Sample store(s) of run A (repeatable), instead of profiles");
  c->add_option("--store-b", o->stores_b, "Sample store(s) of run B (repeatable)");
  c->add_option("--names", o->names, "Names for A and B in the report (default: the file names)")
      ->expected(2)
      ->delimiter(',');
  c->add_option("-o,--output", o->output, "Folder to write the report into (must not exist)")->required();
  c->callback([o] {
    check_report_folder(o->output);
    const bool runs = !o->stores.empty() || !o->stores_b.empty();
    if (runs) {
      if (!o->machines.empty())
        throw InputError("compare two runs (--store-a, --store-b) or two profiles (--machine twice), not both");
      if (o->stores.empty() || o->stores_b.empty())
        throw InputError("a comparison of two runs needs both --store-a and --store-b");
      const std::string na = o->names.size() == 2 ? o->names[0] : fs::path(o->stores[0]).filename().string();
      const std::string nb = o->names.size() == 2 ? o->names[1] : fs::path(o->stores_b[0]).filename().string();
      std::vector<std::pair<std::string, std::string>> args;
      for (const auto& s : o->stores) args.push_back({"--store-a", s});
      for (const auto& s : o->stores_b) args.push_back({"--store-b", s});
      if (o->names.size() == 2) args.push_back({"--names", o->names[0] + "," + o->names[1]});
      args.push_back({"-o", o->output});
      reports::Context ctx{join_cmd("compare", args), o->stores};
      ctx.inputs.insert(ctx.inputs.end(), o->stores_b.begin(), o->stores_b.end());
      finish(reports::compare_runs_report(o->stores, na, o->stores_b, nb, ctx), o->output);
      return;
    }
    if (o->machines.size() != 2)
      throw InputError("give two profiles (--machine A.json --machine B.json) or two runs (--store-a, --store-b) to compare");
    const MachineProfile a = load_profile(o->machines[0]);
    const MachineProfile b = load_profile(o->machines[1]);
    const std::string na = o->names.size() == 2 ? o->names[0] : fs::path(o->machines[0]).filename().string();
    const std::string nb = o->names.size() == 2 ? o->names[1] : fs::path(o->machines[1]).filename().string();
    std::vector<std::pair<std::string, std::string>> args = {{"--machine", o->machines[0]}, {"--machine", o->machines[1]}};
    if (o->names.size() == 2) args.push_back({"--names", o->names[0] + "," + o->names[1]});
    args.push_back({"-o", o->output});
    reports::Context ctx{join_cmd("compare", args), {o->machines[0], o->machines[1]}};
    finish(reports::compare_report(a, na, b, nb, ctx), o->output);
  });

  auto* t = app->add_subcommand("tuning",
                                "A tuning (`dtflop tune -o`): the choice, time against accuracy with the Pareto front and "
                                "the deadline, predicted against measured, and how each search approached the optimum");
  t->add_option("--result,-r", o->tuned, "The result `dtflop tune -o` wrote")->required()->check(CLI::ExistingFile);
  t->add_option("--peer", o->peers,
                "A peer's replay on the same measured space (benchmarks/tune/peer_botorch.py's JSON; repeatable)")
      ->check(CLI::ExistingFile);
  t->add_option("-o,--output", o->output, "Folder to write the report into (must not exist)")->required();
  t->callback([o] {
    check_report_folder(o->output);
    auto read = [](const std::string& f) {
      const std::string what = fmt::format("'{}'", f);
      return parse_json_limited(read_file_limited(f, what, kMaxJsonFileBytes), what);
    };
    std::vector<nlohmann::json> peers;
    std::vector<std::pair<std::string, std::string>> args = {{"--result", o->tuned}};
    for (const auto& peer : o->peers) {
      peers.push_back(read(peer));
      args.push_back({"--peer", peer});
    }
    args.push_back({"-o", o->output});
    reports::Context ctx{join_cmd("tuning", args), {o->tuned}};
    ctx.inputs.insert(ctx.inputs.end(), o->peers.begin(), o->peers.end());
    finish(reports::tuning_report(read(o->tuned), o->tuned, peers, ctx), o->output);
  });
}

}  // namespace dtflop::cli
