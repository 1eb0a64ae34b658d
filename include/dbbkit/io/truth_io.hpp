#pragma once
// Reader of truth files, format `dbbkit.truth/1` (README, "Truth file").

#include <nlohmann/json.hpp>
#include <string>

#include "dbbkit/simulate.hpp"

namespace dbbkit::io {

inline constexpr const char* kTruthFormat = "dbbkit.truth/1";

Truth read_truth_file(const std::string& path);
Truth truth_from_json(const nlohmann::json& j, const std::string& source);

}  // namespace dbbkit::io
