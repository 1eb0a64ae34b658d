#pragma once
// A measurement program as text a control runs: ISO (G-code of the Fanuc family) or
// Heidenhain conversational (Klartext). What the program assumes (work offset, controlled
// point, rotary-axis sense, no tool-centre-point control) is written at its top.
//
// ISO: G21 G90 G94, the work offset G54, G00 to the first position, M00 to mount the bar,
//   G01 X Y Z C|B F between positions, G04 P<ms> for each reading, M30.
// Heidenhain: BEGIN PGM / END PGM, L X Y Z C|B R0 F, STOP to mount the bar, cycle 9
//   (CYCL DEF 9.0 DWELL TIME / 9.1 DWELL s) for each reading, M30.
// Sinumerik: G17 G71 G90 G94 G40, TRAFOOF and CYCLE800() (no transformation or swivelled frame
//   left on), G54, T<n> M6 D1, SPOS=0 to orient the spindle, G0 / G1 X Y Z A|B|C F, M0 to
//   mount the bar, G4 F<s> for each reading, M30; comments after ';'.
// A design that names its machine: every other rotary axis to its park angle at the clearance
// plane before any sideways move; TCPM (options.tcpm) on and off as program.hpp says.
// Coordinates and angles are written with 4 decimals (0.1 um, 1e-4 deg).

#include <optional>
#include <string>

#include "dbbkit/design.hpp"
#include "dbbkit/program.hpp"

namespace dbbkit::io {

enum class Dialect { kIso, kHeidenhain, kSinumerik };
// "iso", "heidenhain", "sinumerik"; nullopt for another name.
std::optional<Dialect> dialect_named(const std::string& name);
// Why a dialect takes no O-number (a heidenhain program is named by its BEGIN PGM line, a
// sinumerik one by its file), or none for iso: a number asked of one is refused, not dropped.
std::optional<std::string> program_number_refusal(Dialect dialect);

// The program text. `program_number` (ISO O-number, 1..9999) is written as O%04d.
std::string program_text(const Design& design, const MeasurementProgram& program, Dialect dialect,
                         int program_number = 1);

}  // namespace dbbkit::io
