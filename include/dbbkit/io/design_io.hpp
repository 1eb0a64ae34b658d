#pragma once
// Reader and writer of design files, format `dbbkit.design/1` (formats.md).

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "dbbkit/design.hpp"

namespace dbbkit::io {

inline constexpr const char* kDesignFormat = "dbbkit.design/1";

// Throws InputError naming the file and the key of the first problem. A machine the design names
// by a relative path is read relative to `base_dir` (read_design_file: the design file's folder;
// empty: the working directory).
Design read_design_file(const std::string& path);
Design design_from_json(const nlohmann::json& j, const std::string& source,
                        const std::string& base_dir = "");
nlohmann::json design_to_json(const Design& design);

// The reading noise as a design writes it: {"distribution": "uniform", "accuracy_um": a} or
// {"distribution": "normal", "std_um": s}.
nlohmann::json noise_to_json(const NoiseModel& noise);

// Set-up tolerances: a design's default (`setup_std`) or one installation's override.
nlohmann::json setup_to_json(const SetupUncertainty& u, const AxisFrame& axis);
nlohmann::json setup_override_to_json(const SetupOverride& o);

// The axis as a design or kit writes it: the shorthand "C" or "B", else the general form.
nlohmann::json axis_to_json(const AxisFrame& axis);
// The frame written out whatever the design used: letter, side, direction, reference,
// travel_deg, shorthand ("C", "B" or null) and ball_axes (the machine directions of L, D and
// H at angle 0; H null where the frame has none).
nlohmann::json axis_frame_to_json(const AxisFrame& axis);

}  // namespace dbbkit::io
