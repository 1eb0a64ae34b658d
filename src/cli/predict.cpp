#include "dbbkit/predict.hpp"

#include <iostream>
#include <memory>

#include "checks.hpp"
#include "commands.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/io/hashing.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/io/predict_io.hpp"
#include "dbbkit/io/result_read.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/limits.hpp"

namespace dbbkit::cli {

namespace {
struct PredictArgs {
  std::string result, at, out;
  double coverage = 0.95;
  bool quiet = false, location_only = false;
  EnvelopeGrid grid;
};
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
  CLI::Option* radii =
      sub->add_option("--grid-radius-mm", args->grid.radii_mm,
                      "A map instead of --at: circles about the axis line at these distances from "
                      "it [mm] (on a head, the tool's reach), e.g. 0,100,200")
          ->delimiter(',')
          ->check(finite_in(0, limits::kMaxLength_mm));
  CLI::Option* heights =
      sub->add_option("--grid-height-mm", args->grid.heights_mm,
                      "The map's heights along the axis from the axis frame's origin [mm] "
                      "(default 0)")
          ->delimiter(',')
          ->check(finite_in(-limits::kMaxLength_mm, limits::kMaxLength_mm));
  CLI::Option* around =
      sub->add_option("--grid-around", args->grid.around,
                      "The map's points on each circle, evenly spaced from the radial direction "
                      "(default 8)")
          ->check(integer_in(1, 360));
  CLI::Option* angles = sub->add_option("--grid-angles-deg", args->grid.angles_deg,
                                        "The map's angles (default: every angle the result "
                                        "measured)")
                            ->delimiter(',')
                            ->check(finite_in(-36000, 36000));
  at->excludes(radii);
  for (CLI::Option* o : {heights, around, angles}) o->needs(radii);
  sub->add_option("--out", args->out, "JSON result (dbbkit.predict/1); '-': stdout");
  sub->add_option("--coverage", args->coverage,
                  "Coverage probability of U (default 0.95; normal, or t with the result's "
                  "degrees of freedom)")
      ->check(finite_in(0.5, 0.9999));
  sub->add_flag("--location-only", args->location_only,
                "The location errors alone at every angle (what a controller's kinematics can be "
                "off by), the component error motions left out");
  sub->add_flag("--quiet", args->quiet, "Nothing on the terminal but the files asked for");
  return [args]() {
    if (args->at.empty() && args->grid.radii_mm.empty())
      throw InputError("--at", "", "give the poses (--at FILE) or a map (--grid-radius-mm)");
    std::vector<io::OutputTarget> targets;
    if (!args->out.empty()) targets.push_back({"--out", args->out});
    io::OutputSet outputs(targets, {args->result, args->at});
    // Read once (a pipe gives its bytes once): parsed and hashed from the same text.
    const std::string text = io::read_json_file(args->result);
    const io::ResultFile r = io::result_from_text(text, args->result);
    std::vector<Pose> poses;
    const bool map = args->at.empty();
    if (!map) {
      poses = io::read_poses_file(args->at, r.axis);
    } else {
      EnvelopeGrid grid = args->grid;
      if (grid.heights_mm.empty()) grid.heights_mm = {0.0};
      if (grid.angles_deg.empty())
        for (const io::ResultErrors& e : r.errors) grid.angles_deg.push_back(e.angle_deg);
      const double n = static_cast<double>(grid.angles_deg.size()) *
                       static_cast<double>(grid.radii_mm.size()) *
                       static_cast<double>(grid.heights_mm.size()) * grid.around;
      if (n > static_cast<double>(limits::kMaxPoses))
        throw InputError("--grid-radius-mm", "",
                         "the map would hold " + io::fmt_num(n, 3) + " points, more than " +
                             std::to_string(limits::kMaxPoses) +
                             ": give fewer angles, radii, heights or points around");
      poses = envelope_poses(r.axis, grid);
      for (std::size_t i = 0; i < poses.size(); ++i)
        io::check_pose(poses[i], r.axis, "--grid-angles-deg",
                       "point " + std::to_string(i + 1) + ".");
    }
    io::PredictResult p = io::predict(r, poses, args->coverage, args->location_only);
    p.poses_source = map ? std::string("grid") : args->at;
    p.result_sha256 = io::sha256_hex(text);
    if (!args->out.empty()) outputs.stage("--out", io::dump_json(io::prediction_to_json(p)) + "\n");
    outputs.commit();
    if (args->out != "-" && !args->quiet) std::cout << io::prediction_text(p, !map);
    return 0;
  };
}

}  // namespace dbbkit::cli
