#include "dbbkit/verify.hpp"

#include <iostream>
#include <memory>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/hashing.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/result_read.hpp"
#include "dbbkit/io/verify_io.hpp"

namespace dbbkit::cli {

namespace {
struct VerifyArgs {
  std::string result, design, data, out;
  double coverage = 0.95;
  bool quiet = false, location_only = false;
};
}  // namespace

Runner add_verify(CLI::App& app) {
  auto args = std::make_shared<VerifyArgs>();
  CLI::App* sub = app.add_subcommand(
      "verify",
      "A held-out check: the readings of another test of the same axis predicted from an "
      "identify or diagnose result and compared with what was read (exit 0: pass, 1: fail)");
  sub->add_option("--result", args->result, "identify or diagnose result (--out)")->required();
  sub->add_option("--design", args->design, "the test's design file (dbbkit.design/1)")->required();
  sub->add_option("--data", args->data, "the test's readings (measurement CSV)")->required();
  sub->add_option("--out", args->out, "JSON result (dbbkit.verify/1); '-': stdout");
  sub->add_option("--coverage", args->coverage,
                  "Coverage probability of the check (default 0.95: a right result fails 5 % of "
                  "such tests)")
      ->check(finite_in(limits::kMinCoverage, limits::kMaxCoverage));
  sub->add_flag("--location-only", args->location_only,
                "The location errors alone at every angle, the component error motions left in "
                "the residual");
  sub->add_flag("--quiet", args->quiet, "Nothing on the terminal but the files asked for");
  return [args]() {
    std::vector<io::OutputTarget> targets;
    if (!args->out.empty()) targets.push_back({"--out", args->out});
    io::OutputSet outputs(targets, {args->result, args->design, args->data});
    const std::string text = io::read_json_file(args->result);
    const io::ResultFile r = io::result_from_text(text, args->result);
    const Design design = io::read_design_file(args->design);
    io::check_test_axis(r, design, args->design);  // before its readings are checked against it
    const std::vector<Reading> readings = io::read_measurement_file(args->data, design);
    io::VerifyReport report = io::verify(r, design, readings, args->design, args->data,
                                         args->coverage, args->location_only);
    report.result_sha256 = io::sha256_hex(text);
    if (!args->out.empty())
      outputs.stage("--out", io::dump_json(io::verification_to_json(report)) + "\n");
    outputs.commit();
    if (args->out != "-" && !args->quiet) std::cout << io::verification_text(report);
    return report.v.pass ? 0 : 1;
  };
}

}  // namespace dbbkit::cli
