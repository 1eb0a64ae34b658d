#include "dbbkit/program.hpp"

#include <iostream>
#include <map>
#include <memory>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/program_io.hpp"
#include "dbbkit/io/text.hpp"

namespace dbbkit::cli {

namespace {
struct ProgramArgs {
  std::string design, out, dialect, sweeps = "ccw";
  ProgramOptions options;
  int program_number = 1;
  bool quiet = false;
};
}  // namespace

Runner add_program(CLI::App& app) {
  auto args = std::make_shared<ProgramArgs>();
  CLI::App* sub = app.add_subcommand(
      "program",
      "A part program of the measurement: rotary moves, the linear moves that keep the "
      "following ball on its path, a dwell per reading");
  sub->add_option("--design", args->design, "Design file (dbbkit.design/1)")->required();
  sub->add_option("--dialect", args->dialect, "iso (G-code) or heidenhain (Klartext)")
      ->required()
      ->check(CLI::IsMember({"iso", "heidenhain"}));
  sub->add_option("--out", args->out, "Program file; '-' or absent: stdout");
  sub->add_option("--sweeps", args->sweeps,
                  "ccw (increasing angle, the default), cw, or both (ccw then cw: diagnose can "
                  "then see a reversal error)")
      ->check(CLI::IsMember({"ccw", "cw", "both"}));
  sub->add_option("--dwell-s", args->options.dwell_s, "Dwell at each reading [s] (default 2)")
      ->check(finite_in(1e-3, 600));
  sub->add_option("--feed-mm-min", args->options.feed_mm_per_min,
                  "Feed of the linear axes between positions [mm/min] (default 500)")
      ->check(finite_in(1, 60000));
  sub->add_option("--path-tolerance-mm", args->options.path_tolerance_mm,
                  "Largest bar-length change along the interpolated move between two "
                  "positions [mm] (default 0.05)")
      ->check(finite_in(1e-4, 1));
  sub->add_option("--program-number", args->program_number, "ISO O-number (default 1)")
      ->check(integer_in(1, 9999));
  sub->add_flag("--tool-down", args->options.tool_down,
                "B only: the tool points to -Z at B0 (commanded points turned 180 deg about Y)");
  sub->add_flag("--quiet", args->quiet, "Nothing on the terminal but the files asked for");
  return [args]() {
    io::OutputSet outputs({{"--out", args->out.empty() ? "-" : args->out}}, {args->design});
    const Design design = io::read_design_file(args->design);
    if (args->options.tool_down && design.axis != Axis::kB)
      throw InputError("--tool-down", "", "applies to a B design; " + args->design + " is C");
    const std::map<std::string, ProgramOptions::Sweeps> sweeps = {
        {"ccw", ProgramOptions::Sweeps::kCCW},
        {"cw", ProgramOptions::Sweeps::kCW},
        {"both", ProgramOptions::Sweeps::kBoth}};
    args->options.sweeps = sweeps.at(args->sweeps);
    MeasurementProgram program;
    try {
      program = measurement_program(design, args->options);
    } catch (const InputError& e) {
      throw e.source() == "design" ? e.with_source(args->design) : e;
    }
    const io::Dialect dialect =
        args->dialect == "iso" ? io::Dialect::kIso : io::Dialect::kHeidenhain;
    outputs.stage("--out", io::program_text(design, program, dialect, args->program_number));
    outputs.commit();
    if (!args->quiet && !args->out.empty() && args->out != "-") {
      double worst = 0;
      for (const InstallationProgram& ip : program.installations)
        worst = std::max(worst, ip.largest_bar_change_mm);
      std::cout << "program (" << args->dialect << ") of " << design.name << ": "
                << program.installations.size() << " installations, " << program.readings
                << " readings, moves and dwells about "
                << io::fmt_rounded(program.motion_time_s / 60.0, 1)
                << " min; largest bar change between positions " << io::fmt_num(worst * 1e3, 3)
                << " um (tolerance " << io::fmt_rounded(args->options.path_tolerance_mm * 1e3, 1)
                << " um)\n";
    }
    return 0;
  };
}

}  // namespace dbbkit::cli
