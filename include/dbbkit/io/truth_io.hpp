#pragma once
// Reader of truth files, format `dbbkit.truth/1` (README, "Truth file").

#include <nlohmann/json.hpp>
#include <string>

#include "dbbkit/simulate.hpp"

namespace dbbkit::io {

inline constexpr const char* kTruthFormat = "dbbkit.truth/1";

Truth read_truth_file(const std::string& path);
Truth truth_from_json(const nlohmann::json& j, const std::string& source);

// The set-up errors a simulation used (format `dbbkit.setup-errors/1`): per
// installation its id, length_offset_um, centring_um [x, y, z] and ball_mm {L, D, H}.
nlohmann::json setup_errors_to_json(const Design& design, const std::vector<SetupError>& setup);

}  // namespace dbbkit::io
