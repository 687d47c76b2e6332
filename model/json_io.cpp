#include "model/json_io.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <system_error>
#include <vector>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/terms.hpp"

namespace dtflop {

using nlohmann::json;

namespace json_field {

void bad(const std::string& field, const json& value, const std::string& expected) {
  std::string shown = value.is_null() ? std::string("nothing") : value.dump();
  if (shown.size() > 60) shown = shown.substr(0, 57) + "...";
  throw InputError(fmt::format("field '{}' is {}, expected {}", field, shown, expected));
}

const json& need(const json& obj, const std::string& key, const std::string& path) {
  auto it = obj.find(key);
  if (it == obj.end()) bad(path + key, json(), "to be present");
  return *it;
}

std::string get_string(const json& obj, const std::string& key, const std::string& path, bool required) {
  auto it = obj.find(key);
  if (it == obj.end()) {
    if (required) bad(path + key, json(), "a string");
    return {};
  }
  if (!it->is_string()) bad(path + key, *it, "a string");
  return it->get<std::string>();
}

std::map<std::string, std::string> string_map(const json& obj, const std::string& key) {
  std::map<std::string, std::string> out;
  auto it = obj.find(key);
  if (it == obj.end()) return out;
  if (!it->is_object()) bad(key, *it, "an object of strings");
  for (const auto& [k, v] : it->items()) {
    if (!v.is_string()) bad(key + "." + k, v, "a string");
    out[k] = v.get<std::string>();
  }
  return out;
}

}  // namespace json_field

using namespace json_field;

namespace {

std::string errno_text(int e) { return std::error_code(e, std::generic_category()).message(); }

std::string format_limit(std::uintmax_t bytes) {
  if (bytes >= (std::uintmax_t{1} << 30) && bytes % (std::uintmax_t{1} << 30) == 0)
    return fmt::format("{} GiB", bytes >> 30);
  if (bytes >= (std::uintmax_t{1} << 20) && bytes % (std::uintmax_t{1} << 20) == 0)
    return fmt::format("{} MiB", bytes >> 20);
  return fmt::format("{} bytes", bytes);
}

int get_count(const json& obj, const std::string& key, const std::string& path) {
  auto it = obj.find(key);
  if (it == obj.end()) return 0;
  if (!it->is_number_integer() || it->get<long long>() < 0 || it->get<long long>() > 1'000'000)
    bad(path + key, *it, "a non-negative integer");
  return it->get<int>();
}

std::int64_t get_i64(const json& obj, const std::string& key, std::int64_t lo, const std::string& path = "counts.") {
  auto it = obj.find(key);
  if (it == obj.end()) return 0;
  if (!it->is_number_integer() || it->get<long long>() < lo)
    bad(path + key, *it, fmt::format("an integer >= {}", lo));
  return it->get<std::int64_t>();
}

double positive_finite(const json& v, const std::string& field) {
  if (!v.is_number()) bad(field, v, "a positive number");
  const double d = v.get<double>();
  if (!std::isfinite(d) || d <= 0) bad(field, v, "a positive finite number");
  return d;
}

}  // namespace

json to_json(const MachineProfile& p) {
  json id = {{"hostname", p.identity.hostname},
             {"cpu_model", p.identity.cpu_model},
             {"cpu_cores", p.identity.cpu_cores},
             {"cpu_threads", p.identity.cpu_threads},
             {"cpu_llc_bytes", p.identity.cpu_llc_bytes},
             {"cpu_llc_effective_bytes", p.identity.cpu_llc_effective_bytes},
             {"gpu_name", p.identity.gpu_name},
             {"gpu_sms", p.identity.gpu_sms},
             {"gpu_l2_bytes", p.identity.gpu_l2_bytes},
             {"gpu_driver", p.identity.gpu_driver},
             {"cuda_version", p.identity.cuda_version},
             {"measured_at", p.identity.measured_at}};
  if (p.identity.cpu_clock_ghz) id["cpu_clock_ghz"] = *p.identity.cpu_clock_ghz;
  json params = json::object();
  for (const auto& [k, v] : p.params()) {
    json e = {{"value", v.value}, {"unit", info(k).unit}, {"provenance", to_string(v.provenance)}};
    // A figure that is not a finite number is no figure: left out (JSON has no infinity, and
    // the reader refuses what would stand in for it).
    if (v.uncertainty && std::isfinite(*v.uncertainty)) e["uncertainty"] = *v.uncertainty;
    if (v.spread && std::isfinite(*v.spread)) e["spread"] = *v.spread;
    if (!v.note.empty()) e["note"] = v.note;
    params[std::string(info(k).name)] = e;
  }
  json out = {{"schema", kProfileSchemaName},
              {"schema_version", kProfileSchemaVersion},
              {"identity", id},
              {"parameters", params}};
  if (!p.metadata.empty()) out["metadata"] = p.metadata;
  return out;
}

MachineProfile profile_from_json(const json& j) {
  if (!j.is_object()) bad("(top level)", j, "a JSON object holding a dtflop machine profile");
  const std::string schema = get_string(j, "schema", "", true);
  if (schema != kProfileSchemaName) bad("schema", schema, fmt::format("\"{}\"", kProfileSchemaName));
  const auto& ver = need(j, "schema_version", "");
  if (!ver.is_number_integer() || ver.get<int>() != kProfileSchemaVersion)
    bad("schema_version", ver, fmt::format("{} (this dtflop reads version {} only)",
                                           kProfileSchemaVersion, kProfileSchemaVersion));
  MachineProfile p;
  const auto& id = need(j, "identity", "");
  if (!id.is_object()) bad("identity", id, "an object");
  p.identity.hostname = get_string(id, "hostname", "identity.", false);
  p.identity.cpu_model = get_string(id, "cpu_model", "identity.", false);
  p.identity.cpu_cores = get_count(id, "cpu_cores", "identity.");
  p.identity.cpu_threads = get_count(id, "cpu_threads", "identity.");
  p.identity.cpu_llc_bytes = get_i64(id, "cpu_llc_bytes", 0, "identity.");  // 0 when absent (older profiles)
  // 0 when absent (profiles probed before the cache ladder): the model uses cpu_llc_bytes.
  p.identity.cpu_llc_effective_bytes = get_i64(id, "cpu_llc_effective_bytes", 0, "identity.");
  p.identity.gpu_name = get_string(id, "gpu_name", "identity.", false);
  p.identity.gpu_sms = get_count(id, "gpu_sms", "identity.");  // 0 when absent (older profiles)
  p.identity.gpu_l2_bytes = get_i64(id, "gpu_l2_bytes", 0, "identity.");  // 0 when absent (older profiles)
  p.identity.gpu_driver = get_string(id, "gpu_driver", "identity.", false);
  p.identity.cuda_version = get_string(id, "cuda_version", "identity.", false);
  p.identity.measured_at = get_string(id, "measured_at", "identity.", false);
  if (auto it = id.find("cpu_clock_ghz"); it != id.end())
    p.identity.cpu_clock_ghz = positive_finite(*it, "identity.cpu_clock_ghz");

  const auto& params = need(j, "parameters", "");
  if (!params.is_object()) bad("parameters", params, "an object of named parameters");
  for (const auto& [name, e] : params.items()) {
    const std::string path = "parameters." + name;
    auto id_ = param_from_name(name);
    if (!id_) {
      std::string known;
      for (const auto& i : all_params()) known += (known.empty() ? "" : ", ") + std::string(i.name);
      bad(path, name, "one of the known parameters (" + known + ")");
    }
    if (!e.is_object()) bad(path, e, "an object with value, unit and provenance");
    Parameter par;
    par.value = positive_finite(need(e, "value", path + "."), path + ".value");
    const std::string unit = get_string(e, "unit", path + ".", true);
    if (unit != info(*id_).unit) bad(path + ".unit", unit, fmt::format("\"{}\"", info(*id_).unit));
    const std::string prov = get_string(e, "provenance", path + ".", true);
    auto pv = provenance_from_string(prov);
    if (!pv) bad(path + ".provenance", prov, "\"probed\", \"fitted\" or \"user\"");
    par.provenance = *pv;
    if (auto it = e.find("uncertainty"); it != e.end()) {
      if (!it->is_number() || !std::isfinite(it->get<double>()) || it->get<double>() < 0)
        bad(path + ".uncertainty", *it, "a non-negative number");
      par.uncertainty = it->get<double>();
    }
    if (auto it = e.find("spread"); it != e.end()) {
      if (!it->is_number() || !std::isfinite(it->get<double>()) || it->get<double>() < 0)
        bad(path + ".spread", *it, "a non-negative number");
      par.spread = it->get<double>();
    }
    par.note = get_string(e, "note", path + ".", false);
    p.set(*id_, std::move(par));
  }
  p.metadata = string_map(j, "metadata");
  return p;
}

json read_json_file(const std::filesystem::path& path, std::string_view what, std::string_view remedy) {
  const std::string named = fmt::format("{} '{}'", what, path.string());
  std::string text;
  try {
    text = read_file_limited(path, named, kMaxJsonFileBytes);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}; {}", e.what(), remedy));
  }
  return parse_json_limited(text, named);
}

MachineProfile load_profile(const std::filesystem::path& path) {
  const std::string what = fmt::format("machine profile '{}'", path.string());
  const json j = read_json_file(path, "machine profile", fmt::format("write one with `dtflop probe -o {}`", path.string()));
  try {
    return profile_from_json(j);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", what, e.what()));
  }
}

std::string read_file_limited(const std::filesystem::path& path, const std::string& what, std::uintmax_t max_bytes) {
  // O_NONBLOCK keeps open() from waiting on a FIFO without a writer; reads block again below.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) throw InputError(fmt::format("cannot read {}: {}", what, errno_text(errno)));
  struct ::stat st {};
  if (::fstat(fd, &st) != 0) {
    const int e = errno;
    ::close(fd);
    throw InputError(fmt::format("cannot read {}: {}", what, errno_text(e)));
  }
  if (S_ISDIR(st.st_mode)) {
    ::close(fd);
    throw InputError(fmt::format("{} is a folder; name a file", what));
  }
  auto too_big = [&] {
    return InputError(fmt::format("{} is larger than the {} this reader accepts (a device or a stream is never read "
                                  "to its end); name the right file",
                                  what, format_limit(max_bytes)));
  };
  if (S_ISREG(st.st_mode) && static_cast<std::uintmax_t>(st.st_size) > max_bytes) {
    ::close(fd);
    throw too_big();
  }
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  std::string text;
  if (S_ISREG(st.st_mode)) text.reserve(static_cast<std::size_t>(st.st_size));
  std::vector<char> buf(std::size_t{1} << 16);
  for (;;) {
    const ssize_t n = ::read(fd, buf.data(), buf.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      const int e = errno;
      ::close(fd);
      throw InputError(fmt::format("reading {} failed: {}", what, errno_text(e)));
    }
    if (n == 0) break;
    if (text.size() + static_cast<std::size_t>(n) > max_bytes) {
      ::close(fd);
      throw too_big();
    }
    text.append(buf.data(), static_cast<std::size_t>(n));
  }
  ::close(fd);
  return text;
}

json parse_json_limited(std::string_view text, const std::string& what) {
  // The depth is checked as the parser opens each array or object, before it holds deeper ones.
  const json::parser_callback_t limit_depth = [&what](int depth, json::parse_event_t event, json&) {
    if ((event == json::parse_event_t::object_start || event == json::parse_event_t::array_start) &&
        depth >= kMaxJsonDepth)
      throw InputError(fmt::format("{} nests arrays or objects more than {} deep (dtflop writes nothing like that); "
                                   "name the right file",
                                   what, kMaxJsonDepth));
    return true;
  };
  try {
    return json::parse(text.begin(), text.end(), limit_depth);
  } catch (const json::parse_error& e) {
    throw InputError(fmt::format("{} is not valid JSON (byte {}); fix or re-create it", what, e.byte));
  } catch (const json::out_of_range&) {
    throw InputError(fmt::format("{} holds a number too large for a double (e.g. 1e309); fix or re-create it",
                                 what));
  } catch (const json::exception&) {
    throw InputError(fmt::format("{} is not valid JSON; fix or re-create it", what));
  }
}

void make_output_folder(const std::filesystem::path& folder, const std::string& what) {
  std::error_code ec;
  for (auto p = folder; !p.empty(); p = p.parent_path()) {
    const auto st = std::filesystem::status(p, ec);  // through links: a link to a folder is a folder
    if (std::filesystem::exists(st)) {
      if (!std::filesystem::is_directory(st))
        throw InputError(fmt::format("{}: '{}' exists and is not a folder; name a new folder", what, p.string()));
      break;
    }
    if (p == p.parent_path()) break;
  }
  std::filesystem::create_directories(folder, ec);
  if (ec) throw InputError(fmt::format("{}: cannot make folder '{}': {}", what, folder.string(), ec.message()));
}

void write_file_atomically(const std::filesystem::path& path, const std::string& text) {
  // An output replaces an earlier output (a regular file) and nothing else: not a link, a device
  // file, a FIFO or a folder.
  std::error_code ec0;
  const auto st = std::filesystem::symlink_status(path, ec0);
  const bool existed = !ec0 && std::filesystem::exists(st);
  if (existed && !std::filesystem::is_regular_file(st))
    throw InputError(fmt::format("'{}' exists and is not a regular file (a link, a device or a folder); write the "
                                 "output to a new file name",
                                 path.string()));
  // A fresh temporary file beside it (mkstemp: never an existing file or link), so the rename stays
  // in one file system and nothing else is touched.
  std::string tmp = path.string() + ".tmp.XXXXXX";
  const int fd = ::mkstemp(tmp.data());
  if (fd < 0) throw InputError(fmt::format("cannot write '{}': {}", path.string(), errno_text(errno)));
  auto fail = [&](int e, bool open) {
    if (open) ::close(fd);
    ::unlink(tmp.c_str());
    return InputError(fmt::format("writing '{}' failed: {}; '{}' was left as it was", path.string(), errno_text(e),
                                  path.string()));
  };
  // The replaced file's permissions, or those a new file gets (0666 less the umask).
  mode_t mode = 0644;
  struct ::stat old {};
  if (existed && ::stat(path.c_str(), &old) == 0) {
    mode = old.st_mode & 07777;
  } else {
    const mode_t mask = ::umask(0);
    ::umask(mask);
    mode = 0666 & ~mask;
  }
  if (::fchmod(fd, mode) != 0) throw fail(errno, true);
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw fail(n < 0 ? errno : ENOSPC, true);
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) throw fail(errno, true);
  if (::close(fd) != 0) throw fail(errno, false);
  if (::rename(tmp.c_str(), path.c_str()) != 0) throw fail(errno, false);
}

void save_profile(const MachineProfile& p, const std::filesystem::path& path) {
  write_file_atomically(path, to_json(p).dump(2) + "\n");
}

json to_json(const CostCounts& c) {
  json copies = json::array();
  for (const CopySize& s : c.copies_GC) copies.push_back({{"bytes", s.bytes}, {"count", s.count}});
  json out = {{"P", c.P},
              {"precision", to_string(c.precision)},
              {"host_memory", to_string(c.host_memory)},
              {"peer_path", to_string(c.peer_path)},
              {"cpu_threads", c.cpu_threads},
              {"copies_GC", copies}};
  for (const CountField& f : count_fields()) out[std::string(f.name)] = c.*f.member;
  return out;
}

CostCounts counts_from_json(const json& j) {
  if (!j.is_object()) bad("counts", j, "an object");
  CostCounts c;
  if (auto it = j.find("P"); it != j.end()) {
    if (!it->is_number_integer() || (it->get<int>() != 4 && it->get<int>() != 8 && it->get<int>() != 2))
      bad("counts.P", *it, "2, 4 or 8 bytes per value");
    c.P = it->get<int>();
  }
  const std::string prec = get_string(j, "precision", "counts.", false);
  if (prec == "fp64") c.precision = Precision::fp64;
  else if (prec.empty() || prec == "fp32") c.precision = Precision::fp32;
  else bad("counts.precision", prec, "\"fp32\" or \"fp64\"");
  // Every count may be absent (counts written before it existed): zero.
  for (const CountField& f : count_fields()) c.*f.member = get_i64(j, std::string(f.name), 0);
  for (const CountField& f : count_fields())
    if (f.part_of && c.*f.member > c.*f.part_of) {
      const CountField& whole = count_field(f.part_of);
      bad(fmt::format("counts.{}", f.name), c.*f.member,
          fmt::format("at most {} = {} ({} counts {} {})", whole.name, c.*f.part_of, f.name, f.unit, f.meaning));
    }
  if (auto it = j.find("copies_GC"); it != j.end()) {
    if (!it->is_array()) bad("counts.copies_GC", *it, "an array of {\"bytes\": B, \"count\": n}");
    for (const json& s : *it) {
      if (!s.is_object()) bad("counts.copies_GC[]", s, "an object {\"bytes\": B, \"count\": n}");
      const std::int64_t bytes = get_i64(s, "bytes", 1, "counts.copies_GC[]."),
                         count = get_i64(s, "count", 1, "counts.copies_GC[].");
      if (bytes == 0 || count == 0) bad("counts.copies_GC[]", s, "both \"bytes\" and \"count\"");
      add_copies(c.copies_GC, bytes, count);
    }
  }
  const std::string mem = get_string(j, "host_memory", "counts.", false);
  if (mem == "pinned") c.host_memory = HostMemory::pinned;
  else if (mem.empty() || mem == "pageable") c.host_memory = HostMemory::pageable;
  else bad("counts.host_memory", mem, "\"pinned\" or \"pageable\"");
  const std::string path = get_string(j, "peer_path", "counts.", false);
  if (path == "device") c.peer_path = PeerPath::device;
  else if (path.empty() || path == "link") c.peer_path = PeerPath::link;
  else bad("counts.peer_path", path, "\"link\" or \"device\"");
  if (j.contains("cpu_threads")) c.cpu_threads = static_cast<int>(get_i64(j, "cpu_threads", 1));
  return c;
}

json to_json(const Prediction& p) {
  json out = {{"variant", to_string(p.variant)}, {"dt_C", p.dt_C}, {"dt_trans", p.dt_trans()}, {"total", p.total}};
  for (const Term& t : terms()) out[std::string(t.name)] = p.*t.field;
  return out;
}

}  // namespace dtflop
