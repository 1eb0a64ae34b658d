#include "dbbkit/predict.hpp"

#include <iostream>
#include <memory>
#include <optional>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/hashing.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/predict_io.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/result_read.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/io/verify_io.hpp"
#include "dbbkit/limits.hpp"
#include "grid_options.hpp"
#include "report_options.hpp"

namespace dbbkit::cli {

namespace {
struct PredictArgs {
  std::string result, at, design, out, report, summary;
  double coverage = 0.95;
  bool quiet = false, location_only = false;
  GridOptions grid;
};

// --design: the test's readings before it is run.
int predict_test(const PredictArgs& args) {
  if (!args.report.empty() || !args.summary.empty())
    throw InputError(args.report.empty() ? "--summary" : "--report", "",
                     "the report maps points of the body; a test's predicted readings are "
                     "written by --out (or on the terminal)");
  std::vector<io::OutputTarget> targets;
  if (!args.out.empty()) targets.push_back({"--out", args.out});
  io::OutputSet outputs(targets, {args.result, args.design});
  const std::string text = io::read_json_file(args.result);
  const io::ResultFile r = io::result_from_text(text, args.result);
  const Design design = io::read_design_file(args.design);
  io::TestPrediction t =
      io::predict_test(r, design, args.design, args.coverage, args.location_only);
  t.result_sha256 = io::sha256_hex(text);
  if (!args.out.empty())
    outputs.stage("--out", io::dump_json(io::test_prediction_to_json(t)) + "\n");
  outputs.commit();
  if (args.out != "-" && !args.quiet) std::cout << io::test_prediction_text(t);
  return 0;
}

}  // namespace

Runner add_predict(CLI::App& app) {
  auto args = std::make_shared<PredictArgs>();
  CLI::App* sub = app.add_subcommand(
      "predict",
      "Where points of the turning body will be off, and how sure: the error of each pose's "
      "point from an identify or diagnose result (location errors and, at a measured angle, the "
      "component error motions), its uncertainty, and what remains once the location errors "
      "are entered");
  sub->add_option("--result", args->result, "identify or diagnose result (--out)")->required();
  CLI::Option* at =
      sub->add_option("--at", args->at,
                      "Poses: CSV angle_deg,x_mm,y_mm,z_mm (a point fixed to the body that turns, "
                      "body frame, from the axis frame's origin)");
  args->grid.add(sub, "A map instead of --at");
  at->excludes(args->grid.radii_option);
  CLI::Option* design =
      sub->add_option("--design", args->design,
                      "Instead of poses: a test of the same axis (dbbkit.design/1), each of its "
                      "readings predicted before it is run, with U (verify then checks it)");
  design->excludes(at)->excludes(args->grid.radii_option);
  sub->add_option("--out", args->out, "JSON result (dbbkit.predict/1); '-': stdout");
  sub->add_option("--report", args->report,
                  "A self-contained HTML report: the largest error at each angle before and after "
                  "entering, with U, and over a map where it sits (gnuplot)");
  sub->add_option("--summary", args->summary, "The same as Markdown (tables only)");
  sub->add_option("--coverage", args->coverage,
                  "Coverage probability of U (default 0.95; normal, or t with the result's "
                  "degrees of freedom)")
      ->check(finite_in(limits::kMinCoverage, limits::kMaxCoverage));
  sub->add_flag("--location-only", args->location_only,
                "The location errors alone at every angle (what a controller's kinematics can be "
                "off by), the component error motions left out");
  sub->add_flag("--quiet", args->quiet, "Nothing on the terminal but the files asked for");
  return [args]() {
    if (!args->design.empty()) return predict_test(*args);
    if (args->at.empty() && !args->grid.given())
      throw InputError("--at", "",
                       "give the poses (--at FILE), a map (--grid-radius-mm) or a test (--design)");
    std::vector<io::OutputTarget> targets;
    if (!args->out.empty()) targets.push_back({"--out", args->out});
    if (!args->report.empty()) targets.push_back({"--report", args->report});
    if (!args->summary.empty()) targets.push_back({"--summary", args->summary});
    io::OutputSet outputs(targets, {args->result, args->at});
    // Read once (a pipe gives its bytes once): parsed and hashed from the same text.
    const std::string text = io::read_json_file(args->result);
    if (io::is_chain_text(text)) {  // a machine result: its chain at each pose
      if (args->at.empty())
        throw InputError(args->grid.given() ? "--grid-radius-mm" : "--at", "",
                         "a machine result is predicted at poses (--at FILE: each axis' angle "
                         "and a point), not over a map");
      if (!args->report.empty() || !args->summary.empty() || args->location_only)
        throw InputError(!args->report.empty()    ? "--report"
                         : !args->summary.empty() ? "--summary"
                                                  : "--location-only",
                         "", "not for a machine result (its location errors alone: --out)");
      const io::ChainFile f = io::chain_from_text(text, args->result);
      const ChainErrors chain = io::chain_errors_of(f);
      const std::vector<ChainPose> poses =
          io::parse_chain_poses(io::read_text_file(args->at), args->at, chain);
      io::ChainPredictResult p = io::predict_chain(f, chain, poses, args->coverage);
      p.poses_source = args->at;
      p.result_sha256 = io::sha256_hex(text);
      if (!args->out.empty())
        outputs.stage("--out", io::dump_json(io::chain_prediction_to_json(p)) + "\n");
      outputs.commit();
      if (args->out != "-" && !args->quiet) std::cout << io::chain_prediction_text(p);
      return 0;
    }
    const io::ResultFile r = io::result_from_text(text, args->result);
    std::vector<Pose> poses;
    std::optional<EnvelopeGrid> grid;
    const bool map = args->at.empty();
    if (!map) {
      poses = io::read_poses_file(args->at, r.axis);
    } else {
      grid = io::grid_of(r, args->grid.request());
      poses = envelope_poses(r.axis, *grid);
    }
    io::PredictResult p = io::predict(r, poses, args->coverage, args->location_only);
    p.poses_source = map ? std::string("grid") : args->at;
    p.grid = grid;
    p.result_sha256 = io::sha256_hex(text);
    if (!args->out.empty()) outputs.stage("--out", io::dump_json(io::prediction_to_json(p)) + "\n");
    const io::RunContext run{command_line(), {args->result, args->at}};
    if (!args->report.empty())
      outputs.stage("--report", io::predict_report(io::ReportFormat::kHtml, run, p));
    if (!args->summary.empty())
      outputs.stage("--summary", io::predict_report(io::ReportFormat::kMarkdown, run, p));
    outputs.commit();
    if (args->out != "-" && !args->quiet) std::cout << io::prediction_text(p, !map);
    return 0;
  };
}

}  // namespace dbbkit::cli
