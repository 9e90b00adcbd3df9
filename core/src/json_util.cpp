#include "voxpack/core/json_util.hpp"

#include <cmath>
#include <fstream>
#include <sstream>

#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/errors.hpp"

namespace voxpack {

nlohmann::json finiteOrNull(double v) { return std::isfinite(v) ? nlohmann::json(v) : nullptr; }

nlohmann::json finiteArray(std::span<const double> v) {
  nlohmann::json a = nlohmann::json::array();
  for (double x : v) a.push_back(finiteOrNull(x));
  return a;
}

void sanitizeNonFinite(nlohmann::json& j) {
  if (j.is_number_float()) {
    if (!std::isfinite(j.get<double>())) j = nullptr;
  } else if (j.is_structured()) {
    for (auto& child : j) sanitizeNonFinite(child);
  }
}

void writeJsonFile(const std::filesystem::path& path, nlohmann::json j) {
  sanitizeNonFinite(j);
  writeTextFileAtomic(path, j.dump(2) + "\n");
}

nlohmann::json readJsonFile(const std::filesystem::path& path) {
  std::ifstream f(path);
  if (!f) throw IoError(path.string() + ": cannot open");
  std::stringstream ss;
  ss << f.rdbuf();
  auto j = nlohmann::json::parse(ss.str(), nullptr, false);
  if (j.is_discarded()) throw InputError(path.string() + ": not valid JSON");
  return j;
}

}  // namespace voxpack
