// dtflop: characterize a machine, predict and measure computation time, tune parameters.
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "cli/command.hpp"
#include "model/errors.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "dtflop - predict how long a computation takes on a machine (the DTFLOP model), "
      "measure it, and tune it to a deadline.",
      "dtflop"};
  app.set_version_flag("--version", "dtflop 0.1.0");
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
    return app.exit(e);
  } catch (const dtflop::InputError& e) {
    fmt::print(stderr, "dtflop: error: {}\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    fmt::print(stderr, "dtflop: internal error: {}\n", e.what());
    return 1;
  }
  return 0;
}
