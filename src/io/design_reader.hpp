#pragma once
// The parts of a design file that a kit, a truth, a machine and a result file read alike:
// internal to the library's readers (the installed design_io.hpp reads whole designs).

#include <Eigen/Core>
#include <optional>
#include <string>

#include "dbbkit/design.hpp"
#include "dbbkit/io/design_io.hpp"
#include "object_reader.hpp"

namespace dbbkit::io {

// {"distribution": "uniform", "accuracy_um": a} or {"distribution": "normal", "std_um": s};
// with allow_none, {"distribution": "none"} gives std::nullopt.
std::optional<NoiseModel> read_noise(ObjectReader noise, bool allow_none);

// Set-up tolerances {"length_offset_um", "centring_um", "L_mm", "D_mm", "H_mm"}, each
// optional: a design's default (`setup_std`) or one installation's override.
SetupOverride read_setup_override(ObjectReader r);

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

// {"model": "per_angle"} or {"model": "fourier" | "legendre", "order": K}.
ErrorModel read_error_model(ObjectReader errors);

}  // namespace dbbkit::io
