#include <iostream>
#include <memory>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/io/compare_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/result_io.hpp"
#include "report_options.hpp"

namespace dbbkit::cli {

namespace {
struct CompareArgs {
  std::string a, b, out;
  double level = 0.05;
};
}  // namespace

Runner add_compare(CLI::App& app) {
  auto args = std::make_shared<CompareArgs>();
  auto rep = std::make_shared<ReportArgs>();
  CLI::App* sub = app.add_subcommand(
      "compare",
      "Two identify or diagnose results of one axis: the change B - A of every location "
      "error, constant part and error motion value, its uncertainty, and whether it is "
      "significant");
  sub->add_option("A", args->a, "The first result (dbbkit identify or diagnose --out)")->required();
  sub->add_option("B", args->b, "The second result")->required();
  sub->add_option("--out", args->out, "JSON result (dbbkit.compare/1); '-': stdout");
  sub->add_option("--level", args->level,
                  "Family-wise significance level over the quantities compared (default 0.05)")
      ->check(finite_in(limits::kMinCompareLevel, limits::kMaxCompareLevel));
  add_report_options(sub, rep);
  return [args, rep]() {
    io::OutputSet outputs(output_targets(args->out, *rep), {args->a, args->b});
    const io::Comparison c = io::compare_results(io::read_result_file(args->a),
                                                 io::read_result_file(args->b), args->level);
    if (!args->out.empty()) outputs.stage("--out", io::dump_json(io::comparison_to_json(c)) + "\n");
    const io::RunContext run{command_line(), {args->a, args->b}};
    if (!rep->report.empty())
      outputs.stage("--report", io::comparison_report(io::ReportFormat::kHtml, run, c));
    if (!rep->summary.empty())
      outputs.stage("--summary", io::comparison_report(io::ReportFormat::kMarkdown, run, c));
    outputs.commit();
    if (args->out != "-" && !rep->quiet) std::cout << io::comparison_summary(c);
    return 0;
  };
}

}  // namespace dbbkit::cli
