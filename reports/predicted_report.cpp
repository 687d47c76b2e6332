// The predicted-vs-actual report: samples of one machine against the profile fitted for it,
// like the seed's Figures 5.3-5.8 and Tables 5.2-5.3.
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <fmt/format.h>

#include "model/profile.hpp"
#include "calibrate/rounds.hpp"
#include "calibrate/store.hpp"
#include "calibrate/validate.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/units.hpp"
#include "reports/common.hpp"
#include "reports/reports.hpp"
#include "workloads/workload.hpp"

namespace dtflop::reports {
namespace {

using calib::Component;
using calib::Sample;
using calib::SampleError;

int component_colour(Component c) {
  switch (c) {
    case Component::total: return 6;
    case Component::CG: return 0;
    case Component::GC: return 1;
    case Component::G: return 2;
    case Component::C: return 4;
  }
  return 7;
}

std::string component_name(Component c) {
  switch (c) {
    case Component::total: return "total";
    case Component::CG: return "host->device (CG)";
    case Component::GC: return "device->host (GC)";
    case Component::G: return "GPU kernels (G)";
    case Component::C: return "CPU (C)";
  }
  return "?";
}

// A parameter as a number for an axis: a number itself, a size "WxH" or [W, H] as W*H.
std::optional<double> as_number(const nlohmann::json& v) {
  if (v.is_number()) return v.get<double>();
  if (v.is_array() && !v.empty()) {
    double p = 1;
    for (const auto& e : v) {
      if (!e.is_number()) return std::nullopt;
      p *= e.get<double>();
    }
    return p;
  }
  if (v.is_string()) {
    const std::string s = v.get<std::string>();
    double p = 1;
    std::size_t at = 0;
    while (at <= s.size()) {
      const std::size_t x = s.find('x', at);
      const std::string part = s.substr(at, x == std::string::npos ? std::string::npos : x - at);
      if (part.empty() || part.find_first_not_of("0123456789.") != std::string::npos) return std::nullopt;
      p *= std::stod(part);
      if (x == std::string::npos) break;
      at = x + 1;
    }
    return p;
  }
  return std::nullopt;
}

std::string pct(double v) { return fmt::format("{:.2f}%", 100 * v); }

bool wide(double lo, double hi) { return lo > 0 && hi / lo > 20; }

// Charts of one group of rows (one backend, one plan): per component the predicted line and the
// measured points against the parameter the plan sweeps; a predicted-against-measured scatter
// when the plan varies several parameters at once (random plans).
void group_charts(Section& sec, const std::string& backend, const std::string& plan,
                  const std::vector<const SampleError*>& rows, std::set<std::string>& ids) {
  // Which parameters vary, and how.
  std::map<std::string, std::set<std::string>> values;
  for (const auto* r : rows)
    for (const auto& [k, v] : r->sample->parameters.items()) values[k].insert(v.dump());
  std::string axis;
  std::size_t axis_n = 0;
  std::vector<std::string> split;  // other varying parameters, few values each
  bool sweepable = true;
  for (const auto& entry : values) {
    const std::string& k = entry.first;  // a name, not a structured binding: the lambda below captures it
    const std::set<std::string>& vs = entry.second;
    if (vs.size() < 2) continue;
    const bool numeric = std::all_of(rows.begin(), rows.end(), [&](const SampleError* r) {
      return r->sample->parameters.contains(k) && as_number(r->sample->parameters.at(k));
    });
    if (numeric && vs.size() > axis_n) {
      if (!axis.empty()) split.push_back(axis);
      axis = k;
      axis_n = vs.size();
    } else {
      split.push_back(k);
    }
  }
  for (const auto& k : split)
    if (values[k].size() > 4) sweepable = false;
  if (axis.empty() || axis_n < 3) sweepable = false;

  std::set<Component> present;
  for (const auto* r : rows)
    for (const auto& [c, pm] : r->per_step)
      if (pm.second > 0 || pm.first > 0) present.insert(c);
  // A component that is the whole total in every configuration (CPU work on a CPU backend) would
  // hide the total's marks under its own: the total alone is drawn.
  for (Component comp : calib::all_components()) {
    if (comp == Component::total || !present.count(comp)) continue;
    const bool same = std::all_of(rows.begin(), rows.end(), [&](const SampleError* r) {
      auto a = r->per_step.find(comp), t = r->per_step.find(Component::total);
      return a != r->per_step.end() && t != r->per_step.end() &&
             std::abs(a->second.second - t->second.second) <= 1e-9 * std::abs(t->second.second) &&
             std::abs(a->second.first - t->second.first) <= 1e-9 * std::abs(t->second.first);
    });
    if (same) present.erase(comp);
  }

  auto unique_id = [&](std::string id) {
    for (char& ch : id)
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '-') ch = '-';
    std::string u = id;
    for (int n = 2; ids.count(u); ++n) u = fmt::format("{}-{}", id, n);
    ids.insert(u);
    return u;
  };

  if (sweepable) {
    // One chart per combination of the split parameters' values.
    std::map<std::string, std::vector<const SampleError*>> parts;
    for (const auto* r : rows) {
      std::string part;
      for (const auto& k : split) {
        std::string val = "-";
        if (r->sample->parameters.contains(k)) {
          const auto& j = r->sample->parameters.at(k);
          if (j.is_array()) {
            val.clear();
            for (const auto& e : j) val += (val.empty() ? "" : "x") + e.dump();
          } else {
            val = j.is_string() ? j.get<std::string>() : j.dump();
          }
        }
        part += fmt::format("{}{} {}", part.empty() ? "" : ", ", k, val);
      }
      parts[part].push_back(r);
    }
    const bool size_axis = !rows.front()->sample->parameters.at(axis).is_number();
    for (auto& [part, prs] : parts) {
      std::sort(prs.begin(), prs.end(), [&](auto* a, auto* b) {
        return *as_number(a->sample->parameters.at(axis)) < *as_number(b->sample->parameters.at(axis));
      });
      Chart c;
      c.id = unique_id(fmt::format("{}-{}-{}", backend, plan, axis));
      const std::string& part_text = part;
      c.title = fmt::format("{}, {}: time per step against {}{}", backend, plan, axis,
                            part_text.empty() ? "" : " (" + part_text + ")");
      double xlo = INFINITY, xhi = 0, ylo = INFINITY, yhi = 0;
      for (Component comp : calib::all_components()) {
        if (!present.count(comp)) continue;
        Series pred{component_name(comp) + " predicted", SeriesKind::line, component_colour(comp), {}};
        Series meas{component_name(comp) + " measured", SeriesKind::points, component_colour(comp), {}};
        for (const auto* r : prs) {
          auto it = r->per_step.find(comp);
          if (it == r->per_step.end()) continue;
          const double x = *as_number(r->sample->parameters.at(axis));
          pred.points.push_back({x, it->second.first, ""});
          meas.points.push_back({x, it->second.second, config_text(*r->sample)});
          xlo = std::min(xlo, x), xhi = std::max(xhi, x);
          for (double y : {it->second.first, it->second.second})
            if (y > 0) ylo = std::min(ylo, y), yhi = std::max(yhi, y);
        }
        c.series.push_back(std::move(pred));
        c.series.push_back(std::move(meas));
      }
      c.x = {size_axis ? fmt::format("{} (cells: the product of its sizes)", axis) : axis, wide(xlo, xhi)};
      c.y = {"time per step [s]", wide(ylo, yhi)};
      c.note = "Lines: the model's prediction; points: measured (the same colour per component).";
      sec.blocks.emplace_back(std::move(c));
    }
  }
  // Predicted against measured, every component: the points on the dashed line are exact.
  Chart s;
  s.id = unique_id(fmt::format("{}-{}-scatter", backend, plan));
  s.title = fmt::format("{}, {}: predicted against measured, per step", backend, plan);
  s.diagonal = true;
  double lo = INFINITY, hi = 0;
  for (Component comp : calib::all_components()) {
    if (!present.count(comp)) continue;
    Series m{component_name(comp), SeriesKind::points, component_colour(comp), {}};
    for (const auto* r : rows) {
      auto it = r->per_step.find(comp);
      if (it == r->per_step.end() || !(it->second.first > 0) || !(it->second.second > 0)) continue;
      m.points.push_back({it->second.second, it->second.first, config_text(*r->sample)});
      lo = std::min({lo, it->second.first, it->second.second});
      hi = std::max({hi, it->second.first, it->second.second});
    }
    if (!m.points.empty()) s.series.push_back(std::move(m));
  }
  s.x = {"measured time per step [s]", wide(lo, hi)};
  s.y = {"predicted time per step [s]", wide(lo, hi)};
  s.note = "Each point is one configuration and component; on the dashed line the prediction is exact.";
  if (!s.series.empty()) sec.blocks.emplace_back(std::move(s));
}

}  // namespace

Document predicted_report(const PredictedInput& in, const Context& ctx) {
  const MachineProfile profile = load_profile(in.profile_path);
  Variant variant = Variant::extended;
  std::string variant_from = "the default";
  if (in.variant) {
    variant = *in.variant;
    variant_from = "--variant";
  } else if (const auto chosen = chosen_variant(profile)) {
    variant = *chosen;
    variant_from = "the profile's fit";
  }
  calib::LoadedSamples loaded = calib::load_samples(in.stores, {in.backends, in.match});
  // One machine per report: the stores' samples among themselves, then against the profile.
  const Sample first = loaded.samples.front();  // a copy: the samples move on below
  for (const auto& s : loaded.samples) {
    std::string why;
    if (!dtflop::same_machine(s.machine, first.machine, &why))
      throw InputError(fmt::format("the stores mix samples of two machines ('{}' on {}, '{}' on {}: {}); a "
                                   "predicted-vs-actual report is of one machine: give the stores of one machine",
                                   first.key, dtflop::describe(first.machine), s.key, dtflop::describe(s.machine), why));
  }
  {
    std::string why;
    if (!dtflop::same_machine(first.machine, profile.identity, &why))
      throw InputError(fmt::format("the samples were measured on {}, but '{}' describes {} ({}); give the profile "
                                   "fitted on the machine that measured them",
                                   dtflop::describe(first.machine), in.profile_path, dtflop::describe(profile.identity), why));
  }
  std::string combine_name = in.rounds_combine;
  if (combine_name.empty()) {
    auto it = profile.metadata.find("fit_rounds_combine");
    combine_name = it != profile.metadata.end() ? it->second : std::string(calib::to_string(calib::kDefaultRoundCombine));
  }
  const calib::MergedRounds merged =
      calib::merge_rounds(std::move(loaded.samples), calib::parse_round_combine(combine_name));
  const calib::Validation v = calib::validate(merged.samples, profile, variant);

  Document doc;
  doc.kind = "predicted";
  doc.title = fmt::format("Predicted against measured: {} {}", merged.samples.front().workload,
                          [&] {
                            std::set<std::string> b;
                            for (const auto& s : merged.samples) b.insert(s.backend);
                            std::string t;
                            for (const auto& x : b) t += (t.empty() ? "" : ", ") + x;
                            return t;
                          }());
  std::string last_measured;
  for (const auto& s : merged.samples) last_measured = std::max(last_measured, s.measured_at);
  doc.stamp = make_stamp(ctx, dtflop::describe(first.machine), last_measured);

  const auto& all = v.groups.at("all");
  const auto& tot = all.at(Component::total);
  doc.summary.push_back(fmt::format("{}{}", merged.summary(), merged.how()));
  doc.summary.push_back(fmt::format("model variant {} (from {}); total per step: mean error {}, max {}, bias {:+.2f}%",
                                    to_string(variant), variant_from, pct(tot.mean_rel), pct(tot.max_rel), 100 * tot.bias));
  {
    std::string fit_stores;
    if (auto it = profile.metadata.find("fit_stores"); it != profile.metadata.end()) fit_stores = it->second;
    for (const auto& st : in.stores)
      if (!fit_stores.empty() && fit_stores.find(st) != std::string::npos)
        doc.summary.push_back(fmt::format("'{}' was used to fit this profile: its errors are not held-out errors", st));
  }

  // Errors per group and component.
  Section err{"Errors (like the seed's Tables 5.2-5.3)", {}};
  std::map<std::string, std::string> config_of;  // key -> the configuration in words
  for (const auto& r : v.rows) config_of[r.sample->key] = config_text(*r.sample);
  std::set<std::string> backends;
  for (const auto& s : merged.samples) backends.insert(s.backend);
  for (const auto& [g, comps] : v.groups) {
    // "all", then each backend where there are several; plans have their own charts below.
    if (g != "all" && (backends.size() < 2 || g.find(" / ") != std::string::npos)) continue;
    Table t{{"component", "n", "mean abs error", "mean rel", "max abs error", "max rel", "bias", "worst configuration"},
            {},
            "lrrrrrrl"};
    for (Component c : calib::all_components()) {
      auto it = comps.find(c);
      if (it == comps.end()) continue;
      const auto& e = it->second;
      t.rows.push_back({component_name(c), std::to_string(e.n), format_duration(e.mean_abs), pct(e.mean_rel),
                        format_duration(e.max_abs), pct(e.max_rel), fmt::format("{:+.2f}%", 100 * e.bias),
                        config_of.count(e.worst) ? config_of[e.worst] : e.worst});
    }
    err.blocks.emplace_back(Paragraph{g == "all" ? "All samples:" : fmt::format("{}:", g)});
    err.blocks.emplace_back(std::move(t));
  }
  doc.sections.push_back(std::move(err));

  // The charts, per backend and plan.
  std::vector<std::pair<std::string, std::string>> order;
  std::map<std::pair<std::string, std::string>, std::vector<const SampleError*>> groups;
  for (const auto& r : v.rows) {
    const auto k = std::pair{r.sample->backend, r.sample->plan};
    if (!groups.count(k)) order.push_back(k);
    groups[k].push_back(&r);
  }
  std::set<std::string> ids;
  for (const auto& k : order) {
    Section sec{fmt::format("{}, plan {} ({} configurations)", k.first, k.second, groups[k].size()), {}};
    if (auto g = v.groups.find(k.first + " / " + k.second); g != v.groups.end()) {
      Table t{{"component", "n", "mean rel error", "max rel error", "bias"}, {}, "lrrrr"};
      for (Component c : calib::all_components())
        if (auto it = g->second.find(c); it != g->second.end())
          t.rows.push_back({component_name(c), std::to_string(it->second.n), pct(it->second.mean_rel),
                            pct(it->second.max_rel), fmt::format("{:+.2f}%", 100 * it->second.bias)});
      sec.blocks.emplace_back(std::move(t));
    }
    group_charts(sec, k.first, k.second, groups[k], ids);
    doc.sections.push_back(std::move(sec));
  }

  // The variant and the fit.
  Section fit{"Model variant and fitted parameters", {}};
  if (auto it = profile.metadata.find("model_variant_reason"); it != profile.metadata.end())
    fit.blocks.emplace_back(Paragraph{"Which variant won, and by how much: " + it->second});
  else
    fit.blocks.emplace_back(Paragraph{fmt::format("The profile holds no fit's choice of variant; {} was used ({}).",
                                                  to_string(variant), variant_from)});
  if (auto it = profile.metadata.find("fit_rounds"); it != profile.metadata.end())
    fit.blocks.emplace_back(Paragraph{"Fitted to: " + it->second + "."});
  Table ft = parameter_table(profile, true);
  if (ft.rows.empty())
    fit.blocks.emplace_back(Paragraph{"The profile holds no fitted parameter: every prediction here is from probed values."});
  else
    fit.blocks.emplace_back(std::move(ft));
  doc.sections.push_back(std::move(fit));

  // The worst configurations.
  std::vector<const SampleError*> rows;
  for (const auto& r : v.rows) rows.push_back(&r);
  std::sort(rows.begin(), rows.end(),
            [](auto* a, auto* b) { return std::abs(a->rel(Component::total)) > std::abs(b->rel(Component::total)); });
  Section worst{"Worst configurations", {}};
  Table wt{{"backend", "plan", "configuration", "measured/step", "predicted/step", "total error", "largest component error"},
           {},
           "lllrrrl"};
  for (int i = 0; i < std::min<int>(in.worst, static_cast<int>(rows.size())); ++i) {
    const auto& r = *rows[i];
    Component wc = Component::total;
    for (const auto& [c, pm] : r.per_step)
      if (c != Component::total && std::abs(r.rel(c)) > std::abs(r.rel(wc))) wc = c;
    const auto& t = r.per_step.at(Component::total);
    wt.rows.push_back({r.sample->backend, r.sample->plan, config_text(*r.sample), format_duration(t.second),
                       format_duration(t.first), fmt::format("{:+.2f}%", 100 * r.rel(Component::total)),
                       wc == Component::total ? "-" : fmt::format("{} {:+.1f}%", component_name(wc), 100 * r.rel(wc))});
  }
  worst.blocks.emplace_back(std::move(wt));
  doc.sections.push_back(std::move(worst));
  for (const auto& w : loaded.warnings) doc.summary.push_back("warning: " + w);
  for (const auto& w : merged.warnings) doc.summary.push_back("warning: " + w);
  return doc;
}

}  // namespace dtflop::reports
