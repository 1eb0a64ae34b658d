#pragma once
// Reader and writer of design files, format `dbbkit.design/1` (formats.md).

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "dbbkit/design.hpp"
#include "dbbkit/io/json_reader.hpp"

namespace dbbkit::io {

inline constexpr const char* kDesignFormat = "dbbkit.design/1";

// Throws InputError naming the file and the key of the first problem. A machine the design names
// by a relative path is read relative to `base_dir` (read_design_file: the design file's folder;
// empty: the working directory).
Design read_design_file(const std::string& path);
Design design_from_json(const nlohmann::json& j, const std::string& source,
                        const std::string& base_dir = "");
nlohmann::json design_to_json(const Design& design);

// {"distribution": "uniform", "accuracy_um": a} or {"distribution": "normal", "std_um": s};
// with allow_none, {"distribution": "none"} gives std::nullopt.
std::optional<NoiseModel> read_noise(ObjectReader noise, bool allow_none);
nlohmann::json noise_to_json(const NoiseModel& noise);

// Set-up tolerances {"length_offset_um", "centring_um", "L_mm", "D_mm", "H_mm"}, each
// optional: a design's default (`setup_std`) or one installation's override.
SetupOverride read_setup_override(ObjectReader r);
nlohmann::json setup_to_json(const SetupUncertainty& u, const AxisFrame& axis);
nlohmann::json setup_override_to_json(const SetupOverride& o);

// A vector [x, y, z] of three numbers at `key`.
Eigen::Vector3d read_vector3(ObjectReader& r, const std::string& key);

// A rotary axis' travel: "full_turn" or an arc [min, max] in degrees (within -360..360, at most
// one turn); absent: a full turn when full_turn_default, else the arc -180..180.
struct Travel {
  bool full_turn = true;
  double min_deg = -180, max_deg = 180;
};
Travel read_travel(ObjectReader& r, const std::string& key, bool full_turn_default);

// "axis": "C" or "B".
AxisFrame read_axis(ObjectReader& top);
// "machine": "m.json", "axis": "A" [, "park_deg": {"C": 90}] (formats.md, "Machine file"): a
// design's or a kit's machine, a relative path read relative to `base_dir`.
DesignMachine read_design_machine(ObjectReader& top, const std::string& base_dir);
// The axis as a design or kit writes it: the shorthand "C" or "B", else the general form.
nlohmann::json axis_to_json(const AxisFrame& axis);
// The frame written out whatever the design used: letter, side, direction, reference,
// travel_deg, shorthand ("C", "B" or null) and ball_axes (the machine directions of L, D and
// H at angle 0; H null where the frame has none).
nlohmann::json axis_frame_to_json(const AxisFrame& axis);

// {"model": "per_angle"} or {"model": "fourier" | "legendre", "order": K}.
ErrorModel read_error_model(ObjectReader errors);

}  // namespace dbbkit::io
