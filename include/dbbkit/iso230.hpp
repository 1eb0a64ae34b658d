#pragma once
// Location errors of the axis average line and component error motions in the terms
// of ISO 230-1 / ISO 230-7, from the identified error motions (any parameterisation),
// to first order (../shared/docs/iso230.md, checked by the tests against the exact
// two-ball geometry of a displaced, tilted and offset axis).
//
// The real axis passes through o (o perpendicular to the nominal axis a), its direction
// tilted by the small rotation alpha (alpha perpendicular to a), and stands at gamma + c0
// when gamma is commanded. Then, with R = R(gamma) the nominal rotation,
//   d(gamma) = d0 + (I - R) o + component,     e(gamma) = e0 + (I - R) alpha + c0 a + component
// with d0 and e0 (perpendicular to a) constant parts: where each reading's zero was
// taken, reported and named, never called location errors. The location errors and the
// constant parts are fitted by ordinary least squares to every determined value, the
// translations (d0, o) and the rotations (e0, alpha, c0) separately; each is a linear
// function c'theta of the estimate, so its standard uncertainty comes from the same
// covariance (reading noise and declared set-up tolerances; Type A scaled as the budget
// is). The component error motions are what remains of each value, with the uncertainty
// of that difference.
//   C (a = z): XOC, YOC [um]; AOC, BOC, C0C [urad]; components EXC, EYC, EZC, EAC, EBC, ECC
//   B (a = y): XOB, ZOB [um]; AOB, COB, B0B [urad]; components EXB, EYB, EZB, EAB, EBB, ECB
// A block whose fit is not determined by the determined values (too few angles, or the
// errors it needs undetermined) is reported as not determined, with the reason.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/parameterisation.hpp"

namespace dbbkit {

struct IsoQuantity {
  std::string name;     // e.g. "XOC", or "constant part of dx"
  std::string unit;     // "um" or "urad"
  Determined value;     // value and standard uncertainty (k = 1); determined = false: not determined
};

struct IsoComponentsAtAngle {
  int station = 0;
  double angle_deg = 0;
  std::array<Determined, 6> motions;  // in the order of the names (translations, then rotations)
};

struct IsoResult {
  std::vector<IsoQuantity> location;  // 5: two positions, two orientations, the zero position
  std::vector<IsoQuantity> constants;  // 5: d0 (3 components) and e0 (the two perpendicular to a)
  std::array<std::string, 6> component_names;
  std::vector<IsoComponentsAtAngle> components;
  std::string note;  // what a block could not determine, or ""
};

// `uncertainty_scale` multiplies every standard uncertainty (the budget's Type A scale, 1 for Type B).
IsoResult iso230_quantities(const Design& design, const Parameterisation& param, const Estimate& est,
                            double uncertainty_scale = 1.0);

}  // namespace dbbkit
