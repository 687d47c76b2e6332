// Plain-text tables for the terminal.
#pragma once

#include <string>
#include <vector>

namespace dtflop::cli {

class Table {
 public:
  // `align` holds one letter per column, 'l' or 'r'; by default the first column is left-
  // and the others right-aligned.
  explicit Table(std::vector<std::string> header, std::string align = {})
      : header_(std::move(header)), align_(std::move(align)) {}
  void row(std::vector<std::string> cells) { rows_.push_back(std::move(cells)); }
  std::string str() const;

 private:
  std::vector<std::string> header_;
  std::string align_;
  std::vector<std::vector<std::string>> rows_;
};

}  // namespace dtflop::cli
