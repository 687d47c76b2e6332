// JSON read/write of MachineProfile and CostCounts, with a schema version.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "model/cost_counts.hpp"
#include "model/predict.hpp"
#include "model/profile.hpp"

namespace dtflop {

inline constexpr int kProfileSchemaVersion = 1;
inline constexpr const char* kProfileSchemaName = "dtflop.machine-profile";

// Reading the fields of dtflop's JSON files (profiles, calibrations): each failure is an InputError
// naming the field (path + key), what it held and what was expected.
namespace json_field {
[[noreturn]] void bad(const std::string& field, const nlohmann::json& value, const std::string& expected);
const nlohmann::json& need(const nlohmann::json& obj, const std::string& key, const std::string& path);
// Absent: empty, or an error when `required`.
std::string get_string(const nlohmann::json& obj, const std::string& key, const std::string& path, bool required);
// An optional object of strings (e.g. "metadata").
std::map<std::string, std::string> string_map(const nlohmann::json& obj, const std::string& key);
}  // namespace json_field

nlohmann::json to_json(const MachineProfile& p);
// Validates every field; throws InputError naming the field, the value and what was expected.
MachineProfile profile_from_json(const nlohmann::json& j);

MachineProfile load_profile(const std::filesystem::path& path);
// Reads and parses one JSON file; a file that cannot be read or parsed is an InputError naming
// `what` (e.g. "machine profile") and ending with `remedy`.
nlohmann::json read_json_file(const std::filesystem::path& path, std::string_view what, std::string_view remedy);
// Writes atomically (temporary file + rename) so a crash never leaves a torn profile.
void save_profile(const MachineProfile& p, const std::filesystem::path& path);

nlohmann::json to_json(const CostCounts& c);
CostCounts counts_from_json(const nlohmann::json& j);

nlohmann::json to_json(const Prediction& p);

// ---- Input and output boundaries (every file dtflop reads or writes goes through these) --------

// Limits checked before anything is allocated. A JSON document nested deeper than kMaxJsonDepth is
// refused (dtflop's own files nest at most 6 deep); files larger than their reader's limit are
// refused before they are read to the end.
inline constexpr int kMaxJsonDepth = 64;
inline constexpr std::uintmax_t kMaxJsonFileBytes = std::uintmax_t{64} << 20;   // profiles, plans
inline constexpr std::uintmax_t kMaxStoreBytes = std::uintmax_t{2} << 30;       // sample stores
inline constexpr std::size_t kMaxStoreLineBytes = std::size_t{16} << 20;        // one stored sample

// The whole of `path` as bytes. `what` names the input in messages ("machine profile 'm.json'").
// Throws InputError when it cannot be opened, is a folder, or holds more than `max_bytes` (read
// at most max_bytes + 1 bytes, so /dev/zero or a FIFO cannot exhaust memory).
std::string read_file_limited(const std::filesystem::path& path, const std::string& what, std::uintmax_t max_bytes);

// Parses `text` as JSON. Throws InputError starting with `what` for a syntax error, a number that
// does not fit a double (1e309), or nesting deeper than kMaxJsonDepth; never anything else.
nlohmann::json parse_json_limited(std::string_view text, const std::string& what);

// Writes `text` to `path` atomically: a new temporary file in the same folder, written in full and
// flushed to disk, then renamed over `path`. Replaces an earlier regular file only: throws
// InputError when `path` is a link, a device file, a FIFO or a folder, and when the write fails or
// comes up short (full disk); then `path` is untouched and the temporary file removed.
void write_file_atomically(const std::filesystem::path& path, const std::string& text);

// Makes `folder` (and its parents) for outputs. Throws InputError naming `what` (e.g. "-o 'out'")
// when it, or a parent, exists and is not a folder, or cannot be made.
void make_output_folder(const std::filesystem::path& folder, const std::string& what);

}  // namespace dtflop
