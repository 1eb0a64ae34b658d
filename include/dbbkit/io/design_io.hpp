#pragma once
// Reader and writer of design files, format `dbbkit.design/1` (formats.md).

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "dbbkit/design.hpp"
#include "dbbkit/io/json_reader.hpp"

namespace dbbkit::io {

inline constexpr const char* kDesignFormat = "dbbkit.design/1";

// Throws InputError naming the file and the key of the first problem.
Design read_design_file(const std::string& path);
Design design_from_json(const nlohmann::json& j, const std::string& source);
nlohmann::json design_to_json(const Design& design);

// {"distribution": "uniform", "accuracy_um": a} or {"distribution": "normal", "std_um": s};
// with allow_none, {"distribution": "none"} gives std::nullopt.
std::optional<NoiseModel> read_noise(ObjectReader noise, bool allow_none);
nlohmann::json noise_to_json(const NoiseModel& noise);

// Set-up tolerances {"length_offset_um", "centring_um", "L_mm", "D_mm", "H_mm"}, each
// optional: a design's default (`setup_std`) or one installation's override.
SetupOverride read_setup_override(ObjectReader r);
nlohmann::json setup_to_json(const SetupUncertainty& u, Axis axis);
nlohmann::json setup_override_to_json(const SetupOverride& o);

// "axis": "C" or "B".
Axis read_axis(ObjectReader& top);

// {"model": "per_angle"} or {"model": "fourier" | "legendre", "order": K}.
ErrorModel read_error_model(ObjectReader errors);

}  // namespace dbbkit::io
