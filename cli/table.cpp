#include "cli/table.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace dtflop::cli {

std::string Table::str() const {
  std::vector<size_t> w(header_.size(), 0);
  auto measure = [&w](const std::vector<std::string>& r) {
    for (size_t i = 0; i < r.size() && i < w.size(); ++i) w[i] = std::max(w[i], r[i].size());
  };
  measure(header_);
  for (const auto& r : rows_) measure(r);
  auto left = [this](size_t i) { return i < align_.size() ? align_[i] == 'l' : i == 0; };
  auto line = [&w, &left](const std::vector<std::string>& r) {
    std::string s;
    for (size_t i = 0; i < w.size(); ++i) {
      const std::string& c = i < r.size() ? r[i] : std::string();
      if (i) s += "  ";
      s += left(i) ? fmt::format("{:<{}}", c, w[i]) : fmt::format("{:>{}}", c, w[i]);
    }
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s + "\n";
  };
  std::string out = line(header_);
  size_t total = 0;
  for (auto x : w) total += x;
  out += std::string(total + 2 * (w.size() - 1), '-') + "\n";
  for (const auto& r : rows_) out += line(r);
  return out;
}

}  // namespace dtflop::cli
