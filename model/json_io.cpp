#include "model/json_io.hpp"

#include <cmath>
#include <fstream>
#include <sstream>
#include <system_error>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/terms.hpp"

namespace dtflop {

using nlohmann::json;

namespace {

[[noreturn]] void bad(const std::string& field, const json& value, const std::string& expected) {
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
             {"gpu_name", p.identity.gpu_name},
             {"gpu_sms", p.identity.gpu_sms},
             {"gpu_driver", p.identity.gpu_driver},
             {"cuda_version", p.identity.cuda_version},
             {"measured_at", p.identity.measured_at}};
  if (p.identity.cpu_clock_ghz) id["cpu_clock_ghz"] = *p.identity.cpu_clock_ghz;
  json params = json::object();
  for (const auto& [k, v] : p.params()) {
    json e = {{"value", v.value}, {"unit", info(k).unit}, {"provenance", to_string(v.provenance)}};
    if (v.uncertainty) e["uncertainty"] = *v.uncertainty;
    if (v.spread) e["spread"] = *v.spread;
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
  p.identity.gpu_name = get_string(id, "gpu_name", "identity.", false);
  p.identity.gpu_sms = get_count(id, "gpu_sms", "identity.");  // 0 when absent (older profiles)
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
  if (auto it = j.find("metadata"); it != j.end()) {
    if (!it->is_object()) bad("metadata", *it, "an object of strings");
    for (const auto& [k, v] : it->items()) {
      if (!v.is_string()) bad("metadata." + k, v, "a string");
      p.metadata[k] = v.get<std::string>();
    }
  }
  return p;
}

json read_json_file(const std::filesystem::path& path, std::string_view what, std::string_view remedy) {
  std::ifstream in(path);
  if (!in)
    throw InputError(fmt::format("cannot read {} '{}': {}; {}", what, path.string(),
                                 std::error_code(errno, std::generic_category()).message(), remedy));
  try {
    return json::parse(in);
  } catch (const json::parse_error& e) {
    throw InputError(fmt::format("{} '{}' is not valid JSON (byte {}): {}", what, path.string(), e.byte, remedy));
  }
}

MachineProfile load_profile(const std::filesystem::path& path) {
  const json j = read_json_file(path, "machine profile", fmt::format("write one with `dtflop probe -o {}`", path.string()));
  try {
    return profile_from_json(j);
  } catch (const InputError& e) {
    throw InputError(fmt::format("machine profile '{}': {}", path.string(), e.what()));
  }
}

void write_file_atomically(const std::filesystem::path& path, const std::string& text) {
  // An output replaces an earlier output (a regular file) and nothing else: not a link, a device
  // file or a folder.
  std::error_code ec0;
  const auto st = std::filesystem::symlink_status(path, ec0);
  if (!ec0 && std::filesystem::exists(st) && !std::filesystem::is_regular_file(st))
    throw InputError(fmt::format("'{}' exists and is not a regular file (a link, a device or a folder); write the "
                                 "output to a new file name",
                                 path.string()));
  auto tmp = path;
  tmp += ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out)
      throw InputError(fmt::format("cannot write '{}': {}", tmp.string(),
                                   std::error_code(errno, std::generic_category()).message()));
    out << text;
    out.flush();
    if (!out) throw InputError(fmt::format("writing '{}' failed (disk full?)", tmp.string()));
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw InputError(fmt::format("cannot move '{}' to '{}': {}", tmp.string(), path.string(), ec.message()));
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
  if (j.contains("cpu_threads")) c.cpu_threads = static_cast<int>(get_i64(j, "cpu_threads", 1));
  return c;
}

json to_json(const Prediction& p) {
  json out = {{"variant", to_string(p.variant)}, {"dt_C", p.dt_C}, {"dt_trans", p.dt_trans()}, {"total", p.total}};
  for (const Term& t : terms()) out[std::string(t.name)] = p.*t.field;
  return out;
}

}  // namespace dtflop
