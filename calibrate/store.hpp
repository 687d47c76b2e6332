// The sample store: an append-only file of JSON lines, one sample per line, written as each
// sample completes.
//
// Crash safety: each sample is written with one write() of the whole line (newline included)
// on a file opened O_APPEND, then flushed to disk (fdatasync). A process killed at any moment
// (kill -9 included) leaves every completed sample intact and at most one torn last line,
// which readers skip with a warning and the next writer cuts off before appending.
#pragma once

#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "calibrate/sample.hpp"

namespace dtflop::calib {

struct StoreContents {
  std::vector<Sample> samples;
  std::vector<std::string> warnings;  // e.g. the torn last line that was skipped
  std::uintmax_t good_bytes = 0;      // length of the file up to the end of the last good line
  bool torn_tail = false;             // a last line that is not a sample was skipped

  std::set<std::string> keys() const;
};

// Reads a store. A missing file reads as empty. Empty lines are ignored; a last line that is
// not a sample (an interrupted write) is skipped with a warning. Throws InputError when the
// file cannot be read, is not a sample store (a foreign file), or holds a bad line before its
// last one (naming the line).
StoreContents read_store(const std::filesystem::path& path);

// Which samples of the stores a fit or a validation takes: of these backends (empty: any), with keys
// containing every one of `match`.
struct SampleFilter {
  std::vector<std::string> backends;
  std::vector<std::string> match;
  bool keeps(const Sample& s) const;
};
// Reads every store and keeps the samples `filter` keeps, printing nothing: warnings (a torn last
// line) are returned. Throws InputError (one line, saying what to do) for a store that does not
// exist or holds no sample, when no sample is kept, and when the kept samples are of more than one
// workload (a fit or a validation is of one workload's backends; split the stores or use --backend).
struct LoadedSamples {
  std::vector<Sample> samples;
  std::vector<std::string> warnings;
};
LoadedSamples load_samples(const std::vector<std::string>& stores, const SampleFilter& filter);

// Appends samples to a store. Only one writer at a time (an exclusive lock on the file).
class StoreWriter {
 public:
  // Opens (creating) `path` for appending. Cuts off a torn last line left by an interrupted
  // writer, adding a warning to `warnings`. Throws InputError when the file cannot be opened
  // or locked (another sweep writing it), or is not a sample store.
  StoreWriter(const std::filesystem::path& path, std::vector<std::string>& warnings);
  ~StoreWriter();
  StoreWriter(const StoreWriter&) = delete;
  StoreWriter& operator=(const StoreWriter&) = delete;

  // Writes one line and flushes it to disk before returning.
  void append(const Sample& s);
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  int fd_ = -1;
};

}  // namespace dtflop::calib
