#pragma once
/// \file json_util.hpp
/// JSON helpers: NaN/Inf become null (never NaN in a result), version stamping.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <span>
#include <string>

namespace voxpack {

/// A finite double as JSON, or null when NaN/Inf.
nlohmann::json finiteOrNull(double v);
/// A vector of doubles as a JSON array with NaN/Inf -> null.
nlohmann::json finiteArray(std::span<const double> v);
/// Recursively replaces every NaN/Inf number in `j` with null.
void sanitizeNonFinite(nlohmann::json& j);
/// Writes `j` (sanitized, indented) to `path` atomically. Throws IoError.
void writeJsonFile(const std::filesystem::path& path, nlohmann::json j);
/// Reads a JSON file. Throws IoError / InputError.
nlohmann::json readJsonFile(const std::filesystem::path& path);

}  // namespace voxpack
