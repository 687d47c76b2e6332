#include "cli/command.hpp"

#include <algorithm>
#include <utility>
#include <vector>

namespace dtflop::cli {

namespace {
std::vector<std::pair<int, Setup>>& setups() {
  static std::vector<std::pair<int, Setup>> s;
  return s;
}
std::vector<PredictTarget>& targets() {
  static std::vector<PredictTarget> t;
  return t;
}
}  // namespace

Registrar::Registrar(int order, Setup setup) { setups().emplace_back(order, std::move(setup)); }

void setup_all(CLI::App& root) {
  auto& s = setups();
  std::stable_sort(s.begin(), s.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (auto& [order, fn] : s) fn(root);
}

CLI::App& group(CLI::App& parent, const std::string& name, const std::string& description) {
  for (auto* sub : parent.get_subcommands([](CLI::App*) { return true; }))
    if (sub->get_name() == name) return *sub;
  auto* sub = parent.add_subcommand(name, description);
  sub->require_subcommand(1);
  return *sub;
}

PredictRegistrar::PredictRegistrar(PredictTarget target) { targets().push_back(std::move(target)); }

const std::vector<PredictTarget>& predict_targets() {
  auto& t = targets();
  std::sort(t.begin(), t.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  return t;
}

}  // namespace dtflop::cli
