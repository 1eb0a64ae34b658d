#pragma once
// From a result to the controller (formats.md, "Comparing two results, and compensation"):
//   isg       the ISG kernel's CSV (Beckhoff TF5280 volumetric compensation): a header row of
//             ISO 230-1 names, a row of values, `//` comments, `#` between blocks; offsets in
//             mm, angles in rad. The location errors, then the component errors as a table over
//             the axis' angle (the argument, in rad) where every one is determined.
//   linuxcnc  HAL `setp` lines for the position pins of LinuxCNC's xyzac-trt-kins or
//             xyzbc-trt-kins (positions only; the module takes no tilt and no zero): each pin's
//             new value is its current value (--current) plus the change; without a current
//             value the change is written as a comment only.
//   table     a plain table for controls whose tables are entered by hand (Heidenhain, Siemens,
//             Fanuc): each value with its unit (angles also in degrees), its expanded
//             uncertainty, and whether it is worth entering.
// Every value is the location error as measured: the axis' actual location minus its nominal
// (ISO 230-1), from the work frame the measurement was taught in. A value whose expanded
// uncertainty is as large as the value itself (|value| <= U) is not distinguishable from zero
// and is said to be too uncertain to enter; an undetermined one is never written as a number.
//
// Over an envelope (CompensationOptions::envelope, predict's map) the decision rests on the
// tool tip's error there (the location errors' part, predict.hpp): of the values worth entering
// one by one, the set whose entering leaves the smallest bound (the largest over the envelope of
// the error left plus its U) is entered, and only where that bound is below the largest error
// today; otherwise none is (EnvelopeJudgement).

#include <array>
#include <map>
#include <optional>
#include <string>

#include "dbbkit/io/chain_io.hpp"
#include "dbbkit/io/result_read.hpp"
#include "dbbkit/predict.hpp"

namespace dbbkit::io {

// The largest position a compensation reads (--current) or writes [mm]: beyond it a number is
// no machine's (formats.md, "Limits").
inline constexpr double kMaxCompensation_mm = 1e5;
// The largest coverage factor an envelope's judgement takes (a coverage of 1 - 2e-9): beyond it
// the coverage rounds to 1 in double precision and U's quantile does not exist.
inline constexpr double kMaxEnvelopeK = 6.0;

enum class CompensationFormat { kIsg, kLinuxCnc, kTable, kSiemens };
// "isg", "linuxcnc", "table", "siemens"; InputError(source, "format") for any other name.
CompensationFormat compensation_format(const std::string& name, const std::string& source);

struct CompensationOptions {
  double k = 2.0;  // coverage factor of the expanded uncertainties stated (about 95 %)
  // linuxcnc: "xyzac-trt" or "xyzbc-trt" (absent: the one the axis belongs to, C: required).
  std::string linuxcnc_kins;
  // linuxcnc: the pins' current values [mm], by pin name without the module prefix
  // ("x-rot-point").
  std::map<std::string, double> current_mm;
  // siemens: the number of the swivel data record written (0: not given).
  int record = 0;
  // siemens, a machine with a head axis (kinematic types T and M): the tool adapter's reference
  // point with every axis at zero, machine frame, mm (where the record's head vectors start).
  std::optional<Eigen::Vector3d> tool_reference_mm;
  // An identify or diagnose result: the envelope the decision to enter rests on (io::grid_of's,
  // defaults filled in); absent: each value on its own (|value| > U).
  std::optional<EnvelopeGrid> envelope;
};

// The decision to enter over an envelope (judge_entering, predict.hpp), from a result: U at the
// coverage of k (normal, or t with the result's degrees of freedom).
struct EnvelopeJudgement : EnteringJudgement {
  bool determined = false;          // false: a location error is not determined; no judgement
  std::size_t points = 0;           // of the envelope
  std::array<bool, 5> candidate{};  // worth entering on its own (|value| > U), the target takes it
  double coverage_probability = 0.95;
};
// `takes`: the values the target can hold (LinuxCNC's trt modules: positions only); a value it
// cannot is never a candidate. InputError naming the result's key where it lacks the location
// errors' covariance.
EnvelopeJudgement judge_envelope(const ResultFile& result, const EnvelopeGrid& grid, double k,
                                 const std::array<bool, 5>& takes = {true, true, true, true, true});

// --tool-reference-mm's value: three numbers x,y,z (mm, within +-kMaxCompensation_mm);
// InputError naming `key` otherwise.
Eigen::Vector3d parse_tool_reference(const std::string& text, const std::string& key);

// Refuses the options the format does not take (kins and current are LinuxCNC's): throws
// InputError(option_name("--current") or ("--kins")) saying so.
void check_compensation_options(CompensationFormat format, const CompensationOptions& options);

// Throws InputError (source option_name of "--format", "--kins", "--current") when the result
// cannot be written for the target: an axis the target does not take, an unknown pin, an option
// the format does not take (check_compensation_options).
std::string compensation_text(const ResultFile& result, CompensationFormat format,
                              const CompensationOptions& options);

// A machine result (dbbkit chain) for its controller: every axis' line corrected by the
// location errors worth entering (the zero errors said, not written):
//   siemens   the swivel data record of two table axes (kinematic type P) as an MPF of
//             $TC_CARR assignments: l2, l3, l4 = -(l2 + l3), v1, v2, each with what it was and U
//   linuxcnc  both axes' position pins of xyzac-trt / xyzbc-trt (the module takes no tilt)
//   isg       every axis' location errors in one CSV
//   table     each axis' errors, its corrected point and direction with U, the chain terms
// Throws InputError(option_name("--format"), ...) for a machine the format cannot describe,
// ("--record") when siemens lacks it.
std::string machine_compensation_text(const ChainFile& machine, CompensationFormat format,
                                      const CompensationOptions& options);

// The pins of a LinuxCNC trt module a location error moves, and by how much per unit of it:
// (pin, factor) pairs. Empty: the module takes no such quantity.
std::vector<std::pair<std::string, double>> linuxcnc_pins(const std::string& kins,
                                                          const std::string& iso_name);

}  // namespace dbbkit::io
