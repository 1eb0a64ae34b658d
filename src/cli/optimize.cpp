#include "dbbkit/optimize.hpp"

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <thread>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/io/optimize_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/setup_sheet.hpp"
#include "dbbkit/user_text.hpp"
#include "report_options.hpp"

namespace dbbkit::cli {

namespace {
struct OptimizeArgs {
  std::string kit, out, result, reference, pareto_csv, criterion;
  bool pareto = false, quiet = false, require_detection = false;
  std::vector<std::string> require_detect;
  int threads = 0;
};

}  // namespace

Runner add_optimize(CLI::App& app) {
  auto args = std::make_shared<OptimizeArgs>();
  CLI::App* sub = app.add_subcommand(
      "optimize", "Search a kit for the design with the smallest worst-case uncertainty");
  sub->add_option("--kit", args->kit, "Kit file (dbbkit.kit/1)")->required();
  sub->add_option(
      "--out", args->out,
      "The best design (dbbkit.design/1), which identify accepts as it is; '-': stdout. Absent: "
      "the design on stdout when it is not a terminal, else the summary");
  sub->add_option("--result", args->result,
                  "Search result JSON (dbbkit.optimize/1): every choice, the Pareto front");
  CLI::Option* criterion_option =
      sub->add_option("--criterion", args->criterion,
                      "worst (worst_std_um; the default without set-up tolerances), worst_total "
                      "(worst_total_std_um: "
                      "noise and the kit's setup_std; the default with them), D (max log det M), A "
                      "(min trace M^-1), E "
                      "(max smallest eigenvalue), condition (min condition number)");
  sub->add_option(
      "--reference", args->reference,
      "A design to compare with (same noise and error model as the kit): ratio of worst_std_um");
  sub->add_flag(
      "--require-setup-detection", args->require_detection,
      "Only designs in which diagnose detects every declared set-up effect at its declared size "
      "(the kit's require_setup_detection)");
  sub->add_option(
      "--require-detect", args->require_detect,
      "What diagnose must detect in the designs: 'setup' (as --require-setup-detection) or "
      "'drift=UM', a drift of UM um over the whole test (the kit's require_drift_detection_um; "
      "the kit's return_reading lets each sweep read its first angle again to see it)");
  sub->add_flag("--pareto", args->pareto,
                "Print the front of the criterion against measurement time");
  sub->add_option("--pareto-csv", args->pareto_csv, "Write the Pareto front as CSV");
  sub->add_option("--threads", args->threads,
                  "Worker threads (0: all cores); the result does not depend on it")
      ->transform(thread_count());
  auto rep = std::make_shared<ReportArgs>();
  add_report_options(sub, rep);
  return [args, rep, criterion_option]() {
    args->quiet = rep->quiet;
    const std::vector<std::string> inputs = {args->kit, args->reference};
    io::OutputSet outputs(
        output_targets(json_to_stdout(args->out) ? "-" : args->out, *rep,
                       {{"--result", args->result}, {"--pareto-csv", args->pareto_csv}}),
        inputs);
    Kit kit = io::read_kit_file(args->kit);
    for (const std::string& r : args->require_detect) {
      if (r == "setup") {
        args->require_detection = true;
      } else if (r.rfind("drift=", 0) == 0) {
        if (!instrument_info(kit.instrument).has_clock)
          throw InputError("--require-detect", quote_value(r),
                           instrument_info(kit.instrument).no_clock_reason);
        const std::string v = r.substr(6);
        char* end = nullptr;
        const double um = std::strtod(v.c_str(), &end);
        if (v.empty() || v.find_first_not_of("0123456789.") != std::string::npos ||
            end != v.c_str() + v.size() ||
            !(um >= limits::kMinRequiredDrift_um && um <= limits::kMaxRequiredDrift_um))
          throw InputError("--require-detect", quote_value(r),
                           "a drift over the whole test in um, at least " +
                               io::fmt_num(limits::kMinRequiredDrift_um, 6) + " and at most " +
                               io::fmt_num(limits::kMaxRequiredDrift_um, 6) + " (drift=2)");
        kit.require_drift_detection_um = um;
      } else {
        throw InputError("--require-detect", quote_value(r),
                         "expected setup or drift=UM (a drift of UM um over the whole test)");
      }
    }
    const Criterion criterion = search_criterion(
        kit, criterion_option->count() > 0 ? std::optional(args->criterion) : std::nullopt,
        args->require_detection, args->kit, "--criterion", "--require-setup-detection");
    std::optional<Reference> reference;
    if (!args->reference.empty()) {
      reference = make_reference(kit, io::read_design_file(args->reference), args->reference);
    }
    OptimizeOptions options;
    options.criterion = criterion;
    options.threads =
        args->threads > 0 ? args->threads : std::max(1u, std::thread::hardware_concurrency());
    const auto start = std::chrono::steady_clock::now();
    auto elapsed = [&]() {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    double last_report = 0;
    if (!args->quiet) {
      options.progress = [&](int done, int total, const Candidate* best) {
        const double t = elapsed();
        if (t < 1.0 || (t - last_report < 1.0 && done < total)) return;
        last_report = t;
        std::cerr << "optimize: " << done << "/" << total << " choices searched, " << t << " s";
        // The choices take alike long on average: the rest at the rate so far.
        if (done > 0 && done < total)
          std::cerr << " (about " << std::llround(t * (total - done) / done) << " s left)";
        if (best && best->objective_defined)
          std::cerr << ", best " << criterion_name(criterion) << " " << best->objective;
        std::cerr << "\n";
      };
    }
    const OptimizeResult res = optimize_kit(kit, options);
    const double seconds = elapsed();
    if (!args->result.empty()) {
      outputs.stage(
          "--result",
          io::dump_json(io::optimize_to_json(kit, res, args->kit, seconds, reference)) + "\n");
    }
    if (!args->pareto_csv.empty()) outputs.stage("--pareto-csv", io::pareto_csv(kit, res));
    const io::RunContext run{command_line(), inputs};
    std::optional<SetupSheet> sheet;
    // A ball bar's design has a set-up sheet; a probe's spheres are listed in the report.
    if (res.best && instrument_info(kit.instrument).has_program &&
        (!rep->report.empty() || !rep->summary.empty()))
      sheet = make_setup_sheet(io::optimized_design(kit, res, args->kit), ProgramOptions{},
                               std::nullopt, &kit);
    for (const auto& [option, file, format] :
         {std::tuple{"--report", rep->report, io::ReportFormat::kHtml},
          std::tuple{"--summary", rep->summary, io::ReportFormat::kMarkdown}}) {
      if (!file.empty())
        outputs.stage(option, io::optimize_report(format, run, kit, res, reference, seconds,
                                                  a_priori_expansion(), sheet ? &*sheet : nullptr));
    }
    const bool design_out = !args->out.empty() || json_to_stdout(args->out);
    if (res.best && design_out) {
      Design d = io::optimized_design(kit, res, args->kit);
      if (d.machine) {
        // The machine as the design names it: relative to the design's own folder (the kit
        // named it relative to the kit's).
        namespace fs = std::filesystem;
        fs::path m(d.machine->file);
        if (m.is_relative()) m = fs::path(args->kit).parent_path() / m;
        m = fs::weakly_canonical(fs::absolute(m));
        const fs::path dir = json_to_stdout(args->out)
                                 ? fs::current_path()
                                 : fs::weakly_canonical(fs::absolute(args->out)).parent_path();
        const fs::path rel = m.lexically_relative(dir);
        d.machine->file = (rel.empty() ? m : rel).generic_string();
      }
      outputs.stage("--out", io::dump_json(io::design_to_json(d)) + "\n");
    } else if (design_out) {
      outputs.withhold("--out");  // no design: the file given is left as it is
    }
    outputs.commit();
    if (!res.best && !args->quiet) {  // no design: why, on the error stream (exit 1)
      std::cerr << io::optimize_summary(kit, res, args->kit, seconds, reference, args->pareto);
    } else if (tables_to_stdout(args->out, args->quiet)) {
      std::cout << io::optimize_summary(kit, res, args->kit, seconds, reference, args->pareto);
    }
    return res.best ? 0 : 1;
  };
}

}  // namespace dbbkit::cli
