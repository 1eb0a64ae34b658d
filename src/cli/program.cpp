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
#include "program_options.hpp"

namespace dbbkit::cli {

namespace {
struct ProgramCommandArgs {
  std::string design, out, dialect;
  int program_number = 1;
  bool quiet = false;
};
}  // namespace

Runner add_program(CLI::App& app) {
  auto args = std::make_shared<ProgramCommandArgs>();
  auto prog = std::make_shared<ProgramArgs>();
  CLI::App* sub = app.add_subcommand(
      "program",
      "A part program of the measurement: rotary moves, the linear moves that keep the "
      "following ball on its path, a dwell per reading");
  sub->add_option("--design", args->design, "Design file (dbbkit.design/1)")->required();
  sub->add_option("--dialect", args->dialect, "iso (G-code) or heidenhain (Klartext)")
      ->required()
      ->check(CLI::IsMember({"iso", "heidenhain"}));
  sub->add_option("--out", args->out, "Program file; '-' or absent: stdout");
  add_program_options(sub, prog);
  sub->add_option("--program-number", args->program_number, "ISO O-number (default 1)")
      ->check(integer_in(1, 9999));
  sub->add_flag("--quiet", args->quiet, "Nothing on the terminal but the files asked for");
  return [args, prog]() {
    io::OutputSet outputs({{"--out", args->out.empty() ? "-" : args->out}}, {args->design});
    const Design design = io::read_design_file(args->design);
    const ProgramOptions options = program_options(*prog, design.axis, args->design);
    MeasurementProgram program;
    try {
      program = measurement_program(design, options);
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
                << " um (tolerance " << io::fmt_rounded(options.path_tolerance_mm * 1e3, 1)
                << " um)\n";
    }
    return 0;
  };
}

}  // namespace dbbkit::cli
