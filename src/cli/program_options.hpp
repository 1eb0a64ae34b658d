#pragma once
// The options of the measurement as programmed (program.hpp), shared by `program` and
// `setup-sheet`: the sweeps, the dwell, the feed, the path tolerance, and where the tool
// points on a B head.

#include <CLI/CLI.hpp>
#include <map>
#include <memory>
#include <string>

#include "checks.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/program.hpp"
#include "dbbkit/user_text.hpp"

namespace dbbkit::cli {

struct ProgramArgs {
  ProgramOptions options;
  std::string sweeps = "ccw";
  std::string tcpm;        // on, off, or empty (not given)
  bool tool_down = false;  // retired: refused with the frame to write instead
};

inline void add_program_options(CLI::App* sub, const std::shared_ptr<ProgramArgs>& args) {
  sub->add_option("--sweeps", args->sweeps,
                  "ccw (increasing angle, the default), cw, or both (ccw then cw: diagnose can "
                  "then see a reversal error)")
      ->check(CLI::IsMember({"ccw", "cw", "both"}));
  sub->add_option("--dwell-s", args->options.dwell_s, "Dwell at each reading [s] (default 2)")
      ->check(finite_in(limits::kMinDwell_s, limits::kMaxDwell_s));
  sub->add_option("--feed-mm-min", args->options.feed_mm_per_min,
                  "Feed of the linear axes between positions [mm/min] (default 500)")
      ->check(finite_in(limits::kMinFeed_mm_per_min, limits::kMaxFeed_mm_per_min));
  sub->add_option("--path-tolerance-mm", args->options.path_tolerance_mm,
                  "Largest bar-length change along the interpolated move between two "
                  "positions [mm] (default 0.05)")
      ->check(finite_in(limits::kMinPathTolerance_mm, limits::kMaxPathTolerance_mm));
  sub->add_flag(
      "--tool-down", args->tool_down,
      "Retired: a spindle pointing down is the design's axis frame (reference [0, 0, -1])");
  sub->add_option("--tool", args->options.tool_number,
                  "Tool number of the ballbar's spindle cup (T, H; default 99): its length "
                  "measured to the ball centre (C), to the pivot (B)")
      ->transform(integer_in(limits::kMinToolNumber, limits::kMaxToolNumber));
  sub->add_option("--clearance-z-mm", args->options.clearance_z_mm,
                  "Z of the clearance plane in the work frame, where every sideways rapid runs "
                  "(default: the highest point reached plus --clearance-margin-mm)")
      ->check(finite_in(-limits::kMaxLength_mm, limits::kMaxLength_mm));
  sub->add_option("--clearance-margin-mm", args->options.clearance_margin_mm,
                  "Margin of the clearance plane above the highest point reached [mm] (default 50)")
      ->check(finite_in(limits::kMinClearanceMargin_mm, limits::kMaxClearanceMargin_mm));
  sub->add_flag("--air-run", args->options.air_run,
                "The same moves with no bar: a stop at each installation and after the first "
                "step of each sweep, to check the sense of the rotary axis and the clearance");
  sub->add_option("--orient-code", args->options.orient_code,
                  "M-code that orients the spindle (default M19; 'none' for none)");
  sub->add_option("--tcpm", args->tcpm,
                  "on or off (required when the design names its machine): tool-centre-point "
                  "control during the sweeps, so the controller's own kinematics moves the "
                  "linear axes; off: the positions come from the machine file's axis points")
      ->check(CLI::IsMember({"on", "off"}));
}

// The options as given, checked against the design's axis.
// A set-up sheet is the same with TCPM on or off (tcpm_required false: absent is off).
inline ProgramOptions program_options(const ProgramArgs& args, const Design& design,
                                      const std::string& design_file, bool tcpm_required = true) {
  if (args.tool_down) {
    throw InputError(
        "--tool-down", "",
        "--tool-down is retired: it turned the program but not the model, so identify reported "
        "dx, dz, ex, ez of a head whose spindle points down with the wrong sign. Write the "
        "spindle's direction in the design instead (formats.md, general axis form), e.g. "
        "\"axis\": {\"letter\": \"B\", \"side\": \"head\", \"direction\": [0, 1, 0], "
        "\"reference\": [0, 0, -1]} (the B shorthand's D is that form's H); " +
            design_file + " is read as it is written");
  }
  ProgramOptions o = args.options;
  const auto sweeps = program_sweeps_named(args.sweeps);
  if (!sweeps) throw InputError("--sweeps", quote_value(args.sweeps), "is not ccw, cw or both");
  o.sweeps = *sweeps;
  if (o.orient_code == "none") o.orient_code.clear();
  if (design.machine && args.tcpm.empty() && tcpm_required)
    throw InputError("--tcpm", "",
                     "the design " + design_file + " names machine " +
                         quote_value(design.machine->machine->name) +
                         ": say --tcpm on (the controller's kinematics moves the linear axes) or "
                         "--tcpm off (the positions come from the machine file's axis points)");
  if (!design.machine && args.tcpm == "on")
    throw InputError("--tcpm", "on",
                     "TCPM runs on the controller's kinematics: the design " + design_file +
                         " must name its machine (\"machine\": \"m.json\", formats.md, "
                         "\"Machine file\")");
  o.tcpm = args.tcpm == "on";
  validate_program_options(o, "program");
  return o;
}

}  // namespace dbbkit::cli
