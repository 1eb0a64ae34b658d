#include "dbbkit/setup_sheet.hpp"

#include <iostream>
#include <memory>
#include <optional>

#include "app.hpp"
#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/setup_sheet_io.hpp"
#include "program_options.hpp"
#include "report_options.hpp"

namespace dbbkit::cli {

namespace {
struct SetupSheetArgs {
  std::string design, kit;
  std::optional<double> resolution_mm;
};
}  // namespace

Runner add_setup_sheet(CLI::App& app) {
  auto args = std::make_shared<SetupSheetArgs>();
  auto prog = std::make_shared<ProgramArgs>();
  auto rep = std::make_shared<ReportArgs>();
  CLI::App* sub = app.add_subcommand(
      "setup-sheet",
      "The design as a person sets it up: the order that changes blocks and bars least, each "
      "installation's hardware, ball positions, the following ball, readings and time, a "
      "drawing of each");
  sub->add_option("--design", args->design, "Design file (dbbkit.design/1)")->required();
  sub->add_option("--kit", args->kit,
                  "The kit (dbbkit.kit/1): its set-up times, its resolution (the default of "
                  "--resolution-mm) and its travel, against which the rounded design is checked");
  sub->add_option("--resolution-mm", args->resolution_mm,
                  "Round the ball positions to multiples of this, and state the worst case and "
                  "the travel again")
      ->check(finite_in(limits::kMinResolution_mm, limits::kMaxResolution_mm));
  add_program_options(sub, prog);
  add_report_options(sub, rep);
  return [args, prog, rep]() {
    // Without --report or --summary the Markdown sheet goes to stdout.
    const bool to_stdout = rep->report.empty() && rep->summary.empty();
    io::OutputSet outputs(output_targets(to_stdout ? "-" : "", *rep), {args->design, args->kit});
    const Design design = io::read_design_file(args->design);
    std::optional<Kit> kit;
    if (!args->kit.empty()) kit = io::read_kit_file(args->kit);
    std::optional<double> resolution = args->resolution_mm;
    if (!resolution && kit) resolution = kit->resolution_mm;
    SetupSheet sheet;
    try {
      sheet = make_setup_sheet(design, program_options(*prog, design, args->design, false),
                               resolution, kit ? &*kit : nullptr);
    } catch (const InputError& e) {
      throw e.source() == "design" ? e.with_source(args->design) : e;
    }
    const io::RunContext run{command_line(), {args->design, args->kit}};
    if (to_stdout)
      outputs.stage("--out",
                    io::setup_sheet_report(io::ReportFormat::kMarkdown, run, sheet, args->kit));
    if (!rep->report.empty())
      outputs.stage("--report",
                    io::setup_sheet_report(io::ReportFormat::kHtml, run, sheet, args->kit));
    if (!rep->summary.empty())
      outputs.stage("--summary",
                    io::setup_sheet_report(io::ReportFormat::kMarkdown, run, sheet, args->kit));
    outputs.commit();
    if (!to_stdout && !rep->quiet) std::cout << io::setup_sheet_summary(sheet);
    // A following ball outside the kit's travel: the sheet is written, and the check fails.
    if (!sheet.clashes.empty()) {
      std::cerr << "dbbkit: setup-sheet: " << sheet.clashes.size()
                << " clash(es) with the kit's workspace (the sheet says which)\n";
    }
    if (!sheet.outside_travel.empty()) {
      std::cerr << "dbbkit: setup-sheet: " << sheet.outside_travel.size()
                << " installation(s) leave the kit's travel "
                << (sheet.outside_travel_as_given.empty() ? "once rounded" : "as designed")
                << " (the sheet says which)\n";
      return 1;
    }
    return sheet.fits_kit() ? 0 : 1;
  };
}

}  // namespace dbbkit::cli
