#include "cli/command.hpp"

namespace dtflop::cli {

void setup_all(CLI::App& root) {
  add_probe_command(root);
  add_predict_command(root);
  add_run_command(root);
  add_sweep_command(root);
  add_calibrate_command(root);
  add_validate_command(root);
  add_specimen_command(root);
  add_fields_command(root);
  add_density_command(root);
}

}  // namespace dtflop::cli
