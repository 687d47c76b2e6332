// dtflop: characterize a machine, predict and measure computation time, tune parameters.
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "cli/command.hpp"
#include "cli/workload_cli.hpp"
#include "model/errors.hpp"
#include "reports/reports.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "dtflop - predict how long a computation takes on a machine (the DTFLOP model), "
      "measure it, and tune it to a deadline.",
      "dtflop"};
  app.footer(
      "Exit status: 0 done; 1 failed while running (a measurement, a device, a fit that ends on a physical bound); "
      "2 bad input (an option, a file, a profile that cannot predict this); 3 a deadline (predict/run --deadline) or "
      "a target (validate --strict) missed; 4 a predicted deadline neither met nor missed within the prediction's "
      "interval.");
  app.set_version_flag("--version", std::string("dtflop ") + dtflop::reports::version());
  app.require_subcommand(1);
  app.fallthrough();
  // Parse errors on one line, ending with what to do.
  app.failure_message([](const CLI::App* failed, const CLI::Error& e) {
    std::string path;
    for (auto* a = failed; a != nullptr; a = a->get_parent())
      path = a->get_name() + (path.empty() ? "" : " " + path);
    return fmt::format("dtflop: error: {} (see `{} --help`)\n", e.what(), path);
  });
  dtflop::cli::setup_all(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version end here too, with CLI11's exit code 0; every other parse error is bad input.
    const int code = app.exit(e);
    return code == 0 ? 0 : dtflop::cli::kExitBadInput;
  } catch (const dtflop::InputError& e) {
    fmt::print(stderr, "dtflop: error: {}\n", e.what());
    return dtflop::cli::kExitBadInput;
  } catch (const std::exception& e) {
    fmt::print(stderr, "dtflop: failed: {}\n", e.what());
    return dtflop::cli::kExitFailure;
  }
  return dtflop::cli::exit_status();
}
