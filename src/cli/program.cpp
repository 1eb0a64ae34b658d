#include "dbbkit/program.hpp"

#include <iostream>
#include <map>
#include <memory>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/program_io.hpp"
#include "dbbkit/io/setup_sheet_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/setup_sheet.hpp"
#include "program_options.hpp"

namespace dbbkit::cli {

namespace {
struct ProgramCommandArgs {
  std::string design, kit, out, dialect;
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
  sub->add_option("--dialect", args->dialect,
                  "iso (G-code), heidenhain (Klartext) or sinumerik (Siemens G-code)")
      ->required()
      ->check(CLI::IsMember({"iso", "heidenhain", "sinumerik"}));
  sub->add_option("--out", args->out, "Program file; '-' or absent: stdout");
  sub->add_option("--kit", args->kit,
                  "Kit file (dbbkit.kit/1): the program is written only when every following "
                  "ball stays in its travel, the clearance plane too, and nothing clashes with "
                  "its workspace; its time model is stated");
  add_program_options(sub, prog);
  CLI::Option* program_number =
      sub->add_option("--program-number", args->program_number,
                      "ISO O-number (default 1; iso only: a heidenhain program is named by "
                      "its BEGIN PGM line, a sinumerik one by its file)")
          ->transform(integer_in(limits::kMinProgramNumber, limits::kMaxProgramNumber));
  sub->add_flag("--quiet", args->quiet, "Nothing on the terminal but the files asked for");
  return [args, prog, program_number]() {
    if (program_number->count() > 0)
      if (const auto refusal = io::program_number_refusal(*io::dialect_named(args->dialect)))
        throw InputError("--program-number", "", *refusal);
    io::OutputSet outputs({{"--out", args->out.empty() ? "-" : args->out}},
                          {args->design, args->kit});
    const Design design = io::read_design_file(args->design);
    const ProgramOptions options = program_options(*prog, design, args->design);
    std::optional<Kit> kit;
    if (!args->kit.empty()) kit = io::read_kit_file(args->kit);
    MeasurementProgram program;
    std::optional<SetupSheet> sheet;
    try {
      if (kit) {
        // The set-up sheet's checks, on the design as given (no rounding).
        sheet = make_setup_sheet(design, options, std::nullopt, &*kit);
        program = sheet->program;
      } else {
        program = measurement_program(design, options);
      }
    } catch (const InputError& e) {
      throw e.source() == "design" ? e.with_source(args->design) : e;
    }
    if (sheet && !sheet->fits_kit()) {
      std::cerr << "dbbkit: program: not written: the design does not fit the kit " << args->kit
                << ":\n"
                << io::setup_sheet_summary(*sheet);
      return 1;
    }
    const io::Dialect dialect = *io::dialect_named(args->dialect);
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
      if (sheet)
        std::cout << "the kit's time model (set-ups and readings, as optimize plans): about "
                  << io::fmt_rounded(sheet->time->total_s / 60.0, 1)
                  << " min; every installation fits the kit's travel and workspace\n";
    }
    return 0;
  };
}

}  // namespace dbbkit::cli
