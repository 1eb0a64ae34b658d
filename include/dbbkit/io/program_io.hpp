#pragma once
// A measurement program as text a control runs: ISO (G-code of the Fanuc family) or
// Heidenhain conversational (Klartext). What the program assumes (work offset, controlled
// point, rotary-axis sense, no tool-centre-point control) is written at its top.
//
// ISO: G21 G90 G94, the work offset G54, G00 to the first position, M00 to mount the bar,
//   G01 X Y Z C|B F between positions, G04 P<ms> for each reading, M30.
// Heidenhain: BEGIN PGM / END PGM, L X Y Z C|B R0 F, STOP to mount the bar, cycle 9
//   (CYCL DEF 9.0 DWELL TIME / 9.1 DWELL s) for each reading, M30.
// Coordinates and angles are written with 4 decimals (0.1 um, 1e-4 deg).

#include <string>

#include "dbbkit/design.hpp"
#include "dbbkit/program.hpp"

namespace dbbkit::io {

enum class Dialect { kIso, kHeidenhain };

// The program text. `program_number` (ISO O-number, 1..9999) is written as O%04d.
std::string program_text(const Design& design, const MeasurementProgram& program, Dialect dialect,
                         int program_number = 1);

}  // namespace dbbkit::io
