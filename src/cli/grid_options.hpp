#pragma once
// predict's map and compensation's envelope: the --grid-* options, read alike (each list parsed
// by io::parse_number_list, so an empty item or a word is refused naming the option and item).

#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "checks.hpp"
#include "dbbkit/io/predict_io.hpp"

namespace dbbkit::cli {

struct GridOptions {
  std::string radii, heights, angles;  // as given
  int around = 8;
  CLI::Option *radii_option = nullptr, *heights_option = nullptr, *angles_option = nullptr;

  // `what`: the map's name in the help ("A map instead of --at", "The envelope the decision to
  // enter rests on"); heights, around and angles need the radii.
  void add(CLI::App* sub, const std::string& what) {
    radii_option = sub->add_option("--grid-radius-mm", radii,
                                   what +
                                       ": circles about the axis line at these distances from it "
                                       "[mm] (on a head, the tool's reach), e.g. 0,100,200");
    heights_option = sub->add_option("--grid-height-mm", heights,
                                     "Its heights along the axis from the axis frame's origin "
                                     "[mm], e.g. -50,0,50 (default 0)");
    CLI::Option* around_option =
        sub->add_option("--grid-around", around,
                        "Its points on each circle, evenly spaced from the radial direction "
                        "(default 8)")
            ->transform(integer_in(1, 360));
    angles_option = sub->add_option("--grid-angles-deg", angles,
                                    "Its angles, e.g. -90,0,90 (default: every angle the result "
                                    "measured)");
    for (CLI::Option* o : {heights_option, around_option, angles_option}) o->needs(radii_option);
  }
  bool given() const { return radii_option->count() > 0; }
  // The lists as given (defaults left to io::grid_of).
  io::GridRequest request() const {
    io::GridRequest r;
    r.radii_mm = io::parse_number_list(radii, "--grid-radius-mm");
    if (heights_option->count() > 0)
      r.heights_mm = io::parse_number_list(heights, "--grid-height-mm");
    if (angles_option->count() > 0)
      r.angles_deg = io::parse_number_list(angles, "--grid-angles-deg");
    r.around = around;
    return r;
  }
};

}  // namespace dbbkit::cli
