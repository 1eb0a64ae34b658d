#include "dbbkit/predict.hpp"

#include <iostream>
#include <memory>
#include <optional>

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
  std::string radii, heights, angles;  // a map's lists, as given
  int around = 8;
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
      sub->add_option("--grid-radius-mm", args->radii,
                      "A map instead of --at: circles about the axis line at these distances from "
                      "it [mm] (on a head, the tool's reach), e.g. 0,100,200");
  CLI::Option* heights = sub->add_option("--grid-height-mm", args->heights,
                                         "The map's heights along the axis from the axis frame's "
                                         "origin [mm], e.g. -50,0,50 (default 0)");
  CLI::Option* around =
      sub->add_option("--grid-around", args->around,
                      "The map's points on each circle, evenly spaced from the radial direction "
                      "(default 8)")
          ->check(integer_in(1, 360));
  CLI::Option* angles = sub->add_option("--grid-angles-deg", args->angles,
                                        "The map's angles, e.g. -90,0,90 (default: every angle "
                                        "the result measured)");
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
  return [args, radii, heights, angles]() {
    if (args->at.empty() && radii->count() == 0)
      throw InputError("--at", "", "give the poses (--at FILE) or a map (--grid-radius-mm)");
    std::vector<io::OutputTarget> targets;
    if (!args->out.empty()) targets.push_back({"--out", args->out});
    io::OutputSet outputs(targets, {args->result, args->at});
    // Read once (a pipe gives its bytes once): parsed and hashed from the same text.
    const std::string text = io::read_json_file(args->result);
    const io::ResultFile r = io::result_from_text(text, args->result);
    std::vector<Pose> poses;
    std::optional<EnvelopeGrid> grid;
    const bool map = args->at.empty();
    if (!map) {
      poses = io::read_poses_file(args->at, r.axis);
    } else {
      io::GridRequest request;
      request.radii_mm = io::parse_number_list(args->radii, "--grid-radius-mm");
      if (heights->count() > 0)
        request.heights_mm = io::parse_number_list(args->heights, "--grid-height-mm");
      if (angles->count() > 0)
        request.angles_deg = io::parse_number_list(args->angles, "--grid-angles-deg");
      request.around = args->around;
      grid = io::grid_of(r, request);
      poses = envelope_poses(r.axis, *grid);
    }
    io::PredictResult p = io::predict(r, poses, args->coverage, args->location_only);
    p.poses_source = map ? std::string("grid") : args->at;
    p.grid = grid;
    p.result_sha256 = io::sha256_hex(text);
    if (!args->out.empty()) outputs.stage("--out", io::dump_json(io::prediction_to_json(p)) + "\n");
    outputs.commit();
    if (args->out != "-" && !args->quiet) std::cout << io::prediction_text(p, !map);
    return 0;
  };
}

}  // namespace dbbkit::cli
