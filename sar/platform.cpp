#include "sar/platform.hpp"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <thread>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "workloads/rbe/likelihood.hpp"

namespace dtflop::sar {
namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::uint64_t mix(std::uint64_t x) {  // splitmix64
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

template <class T>
std::span<const std::byte> bytes_of(std::span<const T> v) {
  return std::as_bytes(v);
}

}  // namespace

std::uint64_t raft_seed(std::uint64_t seed) { return mix(seed * 2 + 1); }
std::uint64_t sensor_seed(std::uint64_t seed, int platform) { return mix(mix(seed) + 1000003ULL * std::uint64_t(platform + 1)); }

Platform::Platform(const Scenario& s, int index, int team, const rbe::BackendOptions& options)
    : s_(s), index_(index), team_(team), grid_(s.grid()), ones_(std::size_t(grid_.cells()), 1.0),
      raft_(s_, raft_seed(s.seed)), sensor_rng_(sensor_seed(s.seed, index)) {
  validate(s_);
  if (index < 0 || index >= static_cast<int>(s_.helicopters.size()))
    throw InputError(fmt::format("platform {} does not exist: the scenario has {} helicopters", index,
                                 s_.helicopters.size()));
  heli_ = s_.helicopters[std::size_t(index)];
  backend_ = rbe::make_backend(s_.backend, options);
  reset(prior_belief(s_, grid_), s_.step_time);
}

const rbe::MotionKernel& Platform::kernel(double dt) {
  auto it = kernels_.find(dt);
  if (it != kernels_.end()) return it->second;
  const rbe::GaussianMotion m = rbe::moments(s_.drift(dt));
  const rbe::KernelSize k = rbe::kernel_size_for_mass(m, grid_, s_.kernel_mass);
  return kernels_.emplace(dt, rbe::make_kernel(m, grid_, k.Ix, k.Iy)).first->second;
}

void Platform::reset(std::vector<double> belief, double dt) {
  rbe::Problem p;
  p.grid = grid_;
  p.kernel = kernel(dt);
  p.prior = std::move(belief);
  p.likelihood = ones_;
  backend_->init(p);
  current_dt_ = dt;
}

Record Platform::step(std::int64_t k, Transport& transport) {
  Record r;
  const double t0 = now();
  double exchange = 0;
  const Traffic traffic_k = traffic(s_, team_, k);
  r.link_delay = link_delay(s_, traffic_k);
  r.dt = s_.step_time + r.link_delay;
  time_ += r.dt;
  raft_.advance(r.dt);
  fly(s_, heli_, turn_, r.dt);
  const Observation own = sense(s_, heli_, index_, raft_.position(), sensor_rng_);
  // The likelihood as a window (only the window travels to a device-resident belief).
  rbe::WindowedLikelihood l = likelihood_window(s_, grid_, own);

  if (s_.rule == Rule::observation && team_ > 1) {
    const double e0 = now();
    if (s_.link_sleep) std::this_thread::sleep_for(std::chrono::duration<double>(r.link_delay));
    const auto got = transport.exchange(bytes_of(std::span<const Observation>(&own, 1)), k);
    exchange += now() - e0;
    for (int p = 0; p < team_; ++p) {
      if (p == index_) continue;
      Observation o;
      if (got[std::size_t(p)].size() != sizeof o)
        throw std::runtime_error(fmt::format("platform {} sent {} bytes for an observation, expected {}", p,
                                             got[std::size_t(p)].size(), sizeof o));
      std::memcpy(&o, got[std::size_t(p)].data(), sizeof o);
      l = rbe::multiply(l, likelihood_window(s_, grid_, o), grid_);  // (4.13)
    }
  }
  double t1 = now();
  if (r.dt != current_dt_) {  // a step of another length: its kernel, the belief kept where it is
    backend_->set_kernel(kernel(r.dt));
    current_dt_ = r.dt;
    const double t2 = now();
    r.wall_reset += t2 - t1;
    t1 = t2;
  }
  try {
    (void)backend_->step(l);
    r.wall_rbe += now() - t1;
  } catch (const rbe::NumericalError&) {
    // The observation put the raft where the belief held nothing: start over from it.
    r.restarted = 1;
    const double t2 = now();
    reset(rbe::expand(l, grid_), r.dt);
    r.wall_reset += now() - t2;
  }
  if (fuses_beliefs(s_, k) && team_ > 1) {
    // The belief is fused where it lives, by the backend (cuda-resident: on the device; only the
    // wire belief comes back to be sent, and the others go up).
    const double w0 = now();
    const std::vector<float> mine = backend_->wire_belief();
    const double e0 = now();
    r.wall_rbe += e0 - w0;
    if (s_.link_sleep) std::this_thread::sleep_for(std::chrono::duration<double>(r.link_delay));
    const auto got = transport.exchange(bytes_of(std::span<const float>(mine)), k);
    exchange += now() - e0;
    // The others' beliefs are read where they arrived (a copy only for a misaligned buffer).
    std::vector<std::vector<float>> copies;
    copies.reserve(std::size_t(team_));  // no reallocation: the spans below point into it
    std::vector<std::span<const float>> others;
    for (int p = 0; p < team_; ++p) {
      if (p == index_) continue;
      const auto& g = got[std::size_t(p)];
      if (g.size() != mine.size() * sizeof(float))
        throw std::runtime_error(fmt::format("platform {} sent {} bytes for a belief, expected {}", p, g.size(),
                                             mine.size() * sizeof(float)));
      if (reinterpret_cast<std::uintptr_t>(g.data()) % alignof(float) == 0) {
        others.emplace_back(reinterpret_cast<const float*>(g.data()), mine.size());
      } else {
        std::vector<float> w(mine.size());
        std::memcpy(w.data(), g.data(), g.size());
        copies.push_back(std::move(w));
        others.emplace_back(copies.back());
      }
    }
    const double f0 = now();
    try {
      backend_->fuse(s_.rule == Rule::belief ? rbe::FusionRule::product : rbe::FusionRule::loglinear, others,
                     std::size_t(index_));
      r.fused = 1;
    } catch (const rbe::NumericalError&) {
      r.fused = 0;  // the beliefs do not overlap: each keeps its own
    }
    r.wall_rbe += now() - f0;
  }
  // The estimate and what the control reads, computed where the belief lives: only these numbers
  // come back (the belief itself is read only for a snapshot, by the team).
  const double s0 = now();
  const std::vector<rbe::Point> at = lookahead_points(s_, heli_);
  const rbe::Summary sum = backend_->summarize(detection_footprint(s_), at);
  r.wall_summary = now() - s0;
  r.estimate = sum.estimate;
  r.estimate.step = k;
  r.estimate.time = time_;
  r.estimate.detected = own.detected != 0 ? 1 : 0;
  turn_ = choose_turn(s_, heli_, sum.footprints, {sum.estimate.mean_x, sum.estimate.mean_y});
  r.heli = heli_;
  r.raft = raft_.position();
  r.distance = std::hypot(r.raft.x - heli_.x, r.raft.y - heli_.y);
  r.wall_exchange = exchange;
  r.wall_compute = now() - t0 - exchange;
  return r;
}

}  // namespace dtflop::sar
