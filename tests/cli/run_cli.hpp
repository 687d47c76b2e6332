// Runs the built `dtflop` executable and captures its exit status, stdout and stderr.
#pragma once

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>

namespace dtflop::test {

struct CliResult {
  int status = -1;
  std::string out;
  std::string err;
};

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// `args` is appended to the executable's path as shell text; run in folder `cwd` when given.
inline CliResult run_dtflop(const std::string& args, const std::string& cwd = {}) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("dtflop_cli_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string cmd = (cwd.empty() ? std::string() : "cd '" + cwd + "' && ") + std::string(DTFLOP_BINARY_DIR) +
                          "/dtflop " + args + " >" +
                          (dir / "out").string() + " 2>" + (dir / "err").string();
  CliResult r;
  const int raw = std::system(cmd.c_str());
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = slurp(dir / "out");
  r.err = slurp(dir / "err");
  std::filesystem::remove_all(dir);
  return r;
}

// A file of the source tree (e.g. docs/examples/h200.json).
inline std::string source_path(const std::string& relative) { return std::string(DTFLOP_SOURCE_DIR) + "/" + relative; }

inline int count_lines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

}  // namespace dtflop::test
