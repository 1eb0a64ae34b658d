#pragma once
// The gnuplot process: a script in, an SVG out. gnuplot runs as a child of this process
// (posix_spawn, no shell) in a private temporary directory that the signal handlers of
// output.hpp remove should the run be interrupted.

#include <string>

#include "dbbkit/io/escape.hpp"

namespace dbbkit::io {

// Runs gnuplot on a script (its terminal and output are set here: SVG, white
// background) and returns the SVG without its XML prolog. Throws InputError naming
// "--report" when gnuplot is not installed or fails.
std::string gnuplot_svg(const std::string& script, int width_px = 760, int height_px = 380);

// Strings reach a script through gnuplot_quote and gnuplot_label alone (escape.hpp).
// A number with 10 significant digits; "NaN" (a gap in the plot) when not finite.
std::string gnuplot_number(double x);

}  // namespace dbbkit::io
