#include "sar/counts.hpp"

#include <cmath>

#include "sar/fusion.hpp"
#include "sar/world.hpp"
#include "workloads/rbe/likelihood.hpp"

namespace dtflop::sar {

TeamCounts team_counts(const Scenario& s, std::int64_t team, const rbe::BackendOptions& options) {
  validate(s);
  TeamCounts t;
  const rbe::Grid g = s.grid();
  const rbe::GaussianMotion m = rbe::moments(s.drift(s.step_time));
  const rbe::KernelSize k = rbe::kernel_size_for_mass(m, g, s.kernel_mass);
  t.shape = {s.nx, s.ny, k.Ix, k.Iy};
  const bool periodic = (s.rule == Rule::belief || s.rule == Rule::loglinear) && team > 1;
  t.steps = periodic ? s.interval : 1;
  const std::int64_t cells = g.cells();
  t.rbe = rbe::step_counts(s.backend, t.shape, options).scaled(t.steps);

  CostCounts h;
  h.P = 8;
  h.precision = Precision::fp64;
  // Likelihoods: one per step, one per platform with observation fusion, and their product.
  const std::int64_t likelihoods = s.rule == Rule::observation ? team : 1;
  h.N_C += t.steps * likelihoods * cells * kLikelihoodFlopsPerCell;
  h.N_CC += t.steps * likelihoods * cells;
  if (s.rule == Rule::observation && team > 1) h += rbe::observation_fusion_counts(cells, team);
  if (periodic) {  // the backend's own fusion and wire belief, once a period
    const auto rule = s.rule == Rule::belief ? rbe::FusionRule::product : rbe::FusionRule::loglinear;
    const auto backend = rbe::make_backend(s.backend, options);
    t.rbe += backend->fusion_counts(t.shape, rule, team, options);
    t.rbe += backend->wire_counts(t.shape, options);
  }
  t.host = h;
  // The estimate and the control's footprint sums, once a step, by the backend.
  const Helicopter centre{0.5 * (g.x_min() + g.x_max()), 0.5 * (g.y_min() + g.y_max()), 0.0};
  const std::vector<rbe::Point> at = lookahead_points(s, centre);
  t.summary = rbe::make_backend(s.backend, options)
                  ->summary_counts(g, detection_footprint(s), at, options)
                  .scaled(t.steps);

  for (std::int64_t j = 1; j <= t.steps; ++j) {
    const Traffic tr = traffic(s, team, periodic ? j : 1);
    t.net.net_messages += tr.messages;
    t.net.net_bytes += tr.bytes;
  }
  return t;
}

}  // namespace dtflop::sar
