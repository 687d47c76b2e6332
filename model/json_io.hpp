// JSON read/write of MachineProfile and CostCounts, with a schema version.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "model/cost_counts.hpp"
#include "model/predict.hpp"
#include "model/profile.hpp"

namespace dtflop {

inline constexpr int kProfileSchemaVersion = 1;
inline constexpr const char* kProfileSchemaName = "dtflop.machine-profile";

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

// Writes `text` to `path` atomically (temporary file in the same folder + rename). Replaces an
// earlier regular file only: throws InputError when `path` is a link, a device file or a folder.
void write_file_atomically(const std::filesystem::path& path, const std::string& text);

}  // namespace dtflop
