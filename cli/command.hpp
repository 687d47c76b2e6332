// The sub-commands of the `dtflop` executable. Each cli/cmd_*.cpp file adds its command to the
// root; setup_all() (command.cpp) is the one list of them, in the order --help shows.
#pragma once

#include <string>

#include <CLI/CLI.hpp>

namespace dtflop::cli {

void add_probe_command(CLI::App& root);
void add_predict_command(CLI::App& root);
void add_run_command(CLI::App& root);
void add_sweep_command(CLI::App& root);
void add_calibrate_command(CLI::App& root);
void add_validate_command(CLI::App& root);
void add_tune_command(CLI::App& root);
void add_specimen_command(CLI::App& root);
void add_fields_command(CLI::App& root);
void add_density_command(CLI::App& root);
void add_report_command(CLI::App& root);
void add_characterize_command(CLI::App& root);
void add_sar_command(CLI::App& root);
void add_live_command(CLI::App& root);  // cmd_live.cpp (camera and stream input)

// Adds every command to `root`.
void setup_all(CLI::App& root);

}  // namespace dtflop::cli
