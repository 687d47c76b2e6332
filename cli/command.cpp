#include "cli/command.hpp"

namespace dtflop::cli {

void setup_all(CLI::App& root) {
  add_characterize_command(root);  // the main job first
  add_probe_command(root);
  add_predict_command(root);
  add_run_command(root);
  add_sweep_command(root);
  add_calibrate_command(root);
  add_validate_command(root);
  add_tune_command(root);
  add_report_command(root);
#ifdef DTFLOP_IMAGE_IO
  add_specimen_command(root);  // these two read or write image files
  add_fields_command(root);
  add_live_command(root);  // reads cameras, videos and streams
#endif
  add_density_command(root);
  add_sar_command(root);
}

}  // namespace dtflop::cli
