// One helicopter of the team: its RBE (any backend), its sensor, its control, and its part of
// the fusion rule. The exchange with the other platforms goes through a Transport (MPI in
// `dtflop sar`, tests can give their own), so the same code runs in every process.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "sar/fusion.hpp"
#include "sar/scenario.hpp"
#include "sar/world.hpp"
#include "workloads/rbe/backend.hpp"
#include "workloads/rbe/estimate.hpp"

namespace dtflop::sar {

// A platform that stopped answering: no message from it within the timeout, or the runtime
// was told by the launcher that it is gone.
class RankLost : public std::runtime_error {
 public:
  RankLost(int rank, std::int64_t step, const std::string& what) : std::runtime_error(what), rank_(rank), step_(step) {}
  int rank() const { return rank_; }
  std::int64_t step() const { return step_; }

 private:
  int rank_;
  std::int64_t step_;
};

class Transport {
 public:
  virtual ~Transport() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  // Sends `mine` to every other platform and returns what each sent (index: rank; the own slot
  // holds `mine`). Every platform sends the same number of bytes. `step` names the step in
  // errors. Throws RankLost.
  virtual std::vector<std::vector<std::byte>> exchange(std::span<const std::byte> mine, std::int64_t step) = 0;
};

// What a platform records each step.
struct Record {
  rbe::Estimate estimate;     // of its belief after the step (step, time, detected filled in)
  double dt = 0;              // physical time of the step, s (step_time + the link's delay)
  double link_delay = 0;      // s
  Helicopter heli;            // after the step
  rbe::Point raft;            // the true raft after the step
  double distance = 0;        // helicopter to raft, km
  int fused = 0;              // 1 when beliefs were fused this step
  int restarted = 0;          // 1 when the belief lost its mass and restarted from the observation
  double wall_compute = 0;    // s: sensing, likelihoods, the RBE step, fusion arithmetic, control
  double wall_exchange = 0;   // s: in the transport (messages, waiting, the link's sleep)
  // Parts of wall_compute, s: the RBE backend's step, fusion and wire belief; its summary (the
  // estimate and the control's footprint sums, Backend::summarize); the kernel of a step of
  // another length (the link's delay: Backend::set_kernel) or a restart of the belief. The rest of
  // wall_compute is the host's: sensing, likelihoods, the control's choice.
  double wall_rbe = 0;
  double wall_summary = 0;
  double wall_reset = 0;
};

class Platform {
 public:
  // Throws InputError for a bad scenario or backend, DeviceUnavailable for a GPU backend here.
  // `options` go to the RBE backend (e.g. cpu-par's threads; default: the backend's own).
  Platform(const Scenario& s, int index, int team, const rbe::BackendOptions& options = {});
  // Step k (1-based) of the team; every platform calls it for the same k.
  Record step(std::int64_t k, Transport& transport);
  std::vector<double> belief() { return backend_->belief(); }
  const rbe::Grid& grid() const { return grid_; }
  const Helicopter& helicopter() const { return heli_; }
  rbe::Point raft() const { return raft_.position(); }

 private:
  const rbe::MotionKernel& kernel(double dt);
  void reset(std::vector<double> belief, double dt);

  Scenario s_;
  int index_, team_;
  rbe::Grid grid_;
  std::unique_ptr<rbe::Backend> backend_;
  std::map<double, rbe::MotionKernel> kernels_;
  double current_dt_ = 0;
  std::vector<double> ones_;
  Raft raft_;
  Helicopter heli_;
  std::mt19937_64 sensor_rng_;
  double turn_ = 0;
  double time_ = 0;
};

// Seeds of a run: the raft's (every platform draws the same raft) and each sensor's.
std::uint64_t raft_seed(std::uint64_t seed);
std::uint64_t sensor_seed(std::uint64_t seed, int platform);

}  // namespace dtflop::sar
