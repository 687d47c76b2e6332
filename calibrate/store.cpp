#include "calibrate/store.hpp"

#include <algorithm>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <system_error>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/json_io.hpp"

namespace dtflop::calib {

namespace {

std::string errno_text(int e) { return std::error_code(e, std::generic_category()).message(); }

std::string shorten(const std::string& s, std::size_t n = 50) {
  return s.size() <= n ? s : s.substr(0, n) + "...";
}

}  // namespace

std::set<std::string> StoreContents::keys() const {
  std::set<std::string> k;
  for (const auto& s : samples) k.insert(s.key);
  return k;
}

StoreContents read_store(const std::filesystem::path& path) {
  StoreContents out;
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return out;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(fmt::format("sample store '{}' is a folder; name a .jsonl file", path.string()));
  // At most kMaxStoreBytes are read: a device (--store /dev/zero) or a stream cannot exhaust memory.
  const std::string text = read_file_limited(path, fmt::format("sample store '{}'", path.string()), kMaxStoreBytes);

  // Split into lines, remembering where each ends.
  struct Line {
    std::size_t begin, end;  // [begin, end) without the newline
    bool terminated;         // followed by a newline
  };
  std::vector<Line> lines;
  for (std::size_t pos = 0; pos < text.size();) {
    const std::size_t nl = text.find('\n', pos);
    if (nl == std::string::npos) {
      lines.push_back({pos, text.size(), false});
      break;
    }
    lines.push_back({pos, nl, true});
    pos = nl + 1;
  }
  // The last line holding anything: only it may be torn.
  std::size_t last = lines.size();
  for (std::size_t i = lines.size(); i-- > 0;)
    if (text.find_first_not_of(" \t\r", lines[i].begin) < lines[i].end) {
      last = i;
      break;
    }

  for (std::size_t i = 0; i < lines.size(); ++i) {
    const auto& L = lines[i];
    const std::string line = text.substr(L.begin, L.end - L.begin);
    if (line.find_first_not_of(" \t\r") == std::string::npos) {
      if (L.terminated) out.good_bytes = L.end + 1;
      continue;
    }
    if (line.size() > kMaxStoreLineBytes)
      throw InputError(fmt::format("sample store '{}': line {} is {} bytes long, more than the {} MiB a sample may "
                                   "take; name the right file or remove that line",
                                   path.string(), i + 1, line.size(), kMaxStoreLineBytes >> 20));
    nlohmann::json j;
    bool parsed = true;
    try {
      j = parse_json_limited(line, fmt::format("sample store '{}', line {},", path.string(), i + 1));
    } catch (const InputError&) {
      // Too deep or a number out of range is a bad line wherever it is; only plain syntax errors can
      // be a torn tail.
      bool syntax = true;
      try {
        syntax = !nlohmann::json::accept(line);
      } catch (...) {
      }
      if (!syntax) throw;
      parsed = false;
    }
    // A line cut short by an interrupted write can only be the last one, and cannot parse.
    if (!parsed && i == last && (!out.samples.empty() || (!L.terminated && line.front() == '{'))) {
      out.torn_tail = true;
      out.warnings.push_back(fmt::format(
          "sample store '{}': skipped its last line ({} bytes), which is not complete JSON; a "
          "sweep was probably interrupted while writing it, and rerunning the sweep measures "
          "that configuration again",
          path.string(), L.end - L.begin));
      continue;
    }
    std::string problem;
    if (!parsed) problem = "is not JSON";
    else if (!j.is_object() || !j.contains("schema")) problem = "is not a dtflop sample (no \"schema\" field)";
    else if (j["schema"] != kSampleSchema)
      problem = fmt::format("holds a {} object, not a dtflop sample", shorten(j["schema"].dump()));
    if (!problem.empty()) {
      if (out.samples.empty())
        throw InputError(fmt::format(
            "'{}' is not a dtflop sample store: its line {} {}. A store is written by `dtflop "
            "sweep --store FILE`, one JSON sample per line",
            path.string(), i + 1, problem));
      throw InputError(fmt::format(
          "sample store '{}' is damaged: line {} of {} {} (it starts '{}'). Only the last line "
          "can be cut short by an interrupted sweep; remove line {} by hand to keep the rest",
          path.string(), i + 1, lines.size(), problem, shorten(line), i + 1));
    }
    try {
      out.samples.push_back(sample_from_json(j));
    } catch (const InputError& e) {
      throw InputError(fmt::format("sample store '{}', line {}: {}", path.string(), i + 1, e.what()));
    }
    out.good_bytes = L.terminated ? L.end + 1 : L.end;
  }
  return out;
}

StoreWriter::StoreWriter(const std::filesystem::path& path, std::vector<std::string>& warnings)
    : path_(path) {
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw InputError(fmt::format("cannot open sample store '{}' for writing: {}", path.string(),
                                 errno_text(errno)));
  struct ::stat st {};
  if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd_);
    fd_ = -1;
    throw InputError(fmt::format("sample store '{}' is not a regular file (a device, a FIFO or a folder); name a "
                                 ".jsonl file",
                                 path.string()));
  }
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    ::close(fd_);
    fd_ = -1;
    if (e == EWOULDBLOCK)
      throw InputError(fmt::format("sample store '{}' is being written by another process (a "
                                   "sweep still running?); wait for it or use another --store",
                                   path.string()));
    throw InputError(fmt::format("cannot lock sample store '{}': {}", path.string(), errno_text(e)));
  }
  // Under the lock, nothing else appends: check the tail and cut off a torn line.
  StoreContents c;
  try {
    c = read_store(path);
  } catch (...) {
    ::close(fd_);
    fd_ = -1;
    throw;
  }
  const auto size = std::filesystem::file_size(path);
  if (c.good_bytes < size) {
    if (c.torn_tail)
      warnings.push_back(fmt::format("sample store '{}': cut off a torn last line ({} bytes) left by "
                                     "an interrupted sweep",
                                     path.string(), size - c.good_bytes));
    if (::ftruncate(fd_, static_cast<off_t>(c.good_bytes)) != 0) {
      const int e = errno;
      ::close(fd_);
      fd_ = -1;
      throw InputError(fmt::format("cannot repair sample store '{}': {}", path.string(), errno_text(e)));
    }
  } else if (size > 0 && c.good_bytes == size) {
    // A last sample without its newline (written by hand): end the line before appending.
    char last = 0;
    if (::pread(fd_, &last, 1, static_cast<off_t>(size - 1)) == 1 && last != '\n') {
      if (::write(fd_, "\n", 1) != 1) {
        const int e = errno;
        ::close(fd_);
        fd_ = -1;
        throw InputError(fmt::format("cannot write sample store '{}': {}", path.string(), errno_text(e)));
      }
    }
  }
}

StoreWriter::~StoreWriter() {
  if (fd_ >= 0) ::close(fd_);  // also releases the lock
}

void StoreWriter::append(const Sample& s) {
  const std::string line = to_json(s).dump() + "\n";
  // One write() of the whole line: a signal cannot split it. A short write (disk full) is
  // finished by further writes; the reader skips a line torn by a crash in between.
  std::size_t done = 0;
  while (done < line.size()) {
    const ssize_t n = ::write(fd_, line.data() + done, line.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw InputError(fmt::format("writing sample store '{}' failed: {}", path_.string(), errno_text(errno)));
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fdatasync(fd_) != 0)
    throw InputError(fmt::format("flushing sample store '{}' failed: {}", path_.string(), errno_text(errno)));
}

bool SampleFilter::keeps(const Sample& s) const {
  if (!backends.empty() && std::find(backends.begin(), backends.end(), s.backend) == backends.end()) return false;
  return std::all_of(match.begin(), match.end(), [&s](const std::string& m) { return s.key.find(m) != std::string::npos; });
}

LoadedSamples load_samples(const std::vector<std::string>& stores, const SampleFilter& filter) {
  if (stores.empty()) throw InputError("name at least one --store");
  LoadedSamples out;
  for (const auto& path : stores) {
    if (!std::filesystem::exists(path))
      throw InputError(fmt::format("sample store '{}' does not exist; measure one with `dtflop sweep WORKLOAD --backend "
                                   "NAME --plan PLAN --store {}`",
                                   path, path));
    StoreContents c = read_store(path);
    for (auto& w : c.warnings) out.warnings.push_back(std::move(w));
    if (c.samples.empty())
      throw InputError(fmt::format("sample store '{}' holds no samples; measure some with `dtflop sweep`", path));
    for (auto& s : c.samples)
      if (filter.keeps(s)) out.samples.push_back(std::move(s));
  }
  if (out.samples.empty()) {
    std::string list;
    for (const auto& b : filter.backends) list += (list.empty() ? "" : ", ") + b;
    throw InputError(fmt::format("the stores hold no samples of backend {}{}; drop --backend / --match or name what "
                                 "the stores hold",
                                 list.empty() ? "(any)" : list, filter.match.empty() ? "" : " matching --match"));
  }
  for (const Sample& s : out.samples)
    if (s.workload != out.samples.front().workload)
      throw InputError(fmt::format("the samples are of more than one workload ({} in '{}', {} in '{}'); fit or "
                                   "validate one workload at a time: split the stores or pick backends with --backend",
                                   out.samples.front().workload, out.samples.front().key, s.workload, s.key));
  return out;
}

}  // namespace dtflop::calib
