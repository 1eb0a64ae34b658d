#pragma once
// Location errors of the axis average line and component error motions in the terms
// of ISO 230-1 / ISO 230-7, from the identified error motions (any parameterisation),
// to first order (docs/iso230.md, checked by the tests against the exact
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
//   C (a = z): X0C, Y0C [um]; A0C, B0C, C0C [urad]; components EXC, EYC, EZC, EAC, EBC, ECC
//   B (a = y): X0B, Z0B [um]; A0B, C0B, B0B [urad]; components EXB, EYB, EZB, EAB, EBB, ECB
// Error motion values (ISO 230-7, fixed sensitive direction): the range (peak-to-valley)
// of each component error motion over the measured angles: radial (the two translations
// perpendicular to the axis), axial (along it), tilt (the two rotations perpendicular to
// it), and the range of the angular positioning error motion. A range is not linear in
// the readings, and the range of estimated values is biased upward by their errors, so
// neither value +- k u nor the Monte Carlo distribution of range(estimate + error) (which
// can lie wholly above the estimate) is a coverage interval for it. What holds for every
// true motion v: with the estimate v^ = v + eps,
//   |range(v^) - range(v)| <= range(eps),
// so [range(v^) - q, range(v^) + q] (its low end at least 0), q the p-quantile of
// range(eps), covers range(v) with probability at least p. q comes from Monte Carlo
// (JCGM 101): eps at every measured angle drawn jointly from the Gaussian of the
// component values' covariance (a multivariate t with the residual's degrees of freedom
// when the noise is Type A), in batches until twice the standard deviation of the batch
// quantiles over sqrt(batches) is below the numerical tolerance of q (JCGM 101 §7.9).
// A block whose fit is not determined by the determined values (too few angles, or the
// errors it needs undetermined) is reported as not determined, with the reason.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/parameterisation.hpp"

namespace dbbkit {

struct IsoQuantity {
  std::string name;  // e.g. "X0C", or "constant part of dx"
  std::string unit;  // "um" or "urad"
  Determined value;  // value and standard uncertainty (k = 1); determined = false: not determined
};

struct IsoComponentsAtAngle {
  int station = 0;
  double angle_deg = 0;
  std::array<Determined, 6> motions;  // in the order of the names (translations, then rotations)
  // The joint covariance (um, urad; the scale of the std) of the six error motions at this angle
  // less their constant parts: the location errors' part (location_motion) plus the component,
  // translations then rotations. What a point of the body is off by, and what remains of it once
  // the location errors are entered, take their uncertainty from it (predict.hpp). Absent where
  // one of the six or a block's fit is not determined, where not asked for, and where a share
  // that is not a covariance was added to the std (diagnose's equivalent effects).
  std::optional<Eigen::Matrix<double, 6, 6>> motion_covariance;
  // The joint covariance of the six error motions themselves at this angle (their constant parts
  // included): where motion_covariance is stated. With IsoResult::independent_between_angles, the
  // estimates at two angles are independent, and a test's readings predicted at the measured
  // angles have this covariance once that test's own constant parts are fitted (verify.hpp).
  std::optional<Eigen::Matrix<double, 6, 6>> errors_covariance;
};

enum class IsoMotionGap { kNone, kLocationNotDetermined, kNotEveryAngle, kTooManyAngles };

struct IsoMotionValue {
  std::string name;       // e.g. "radial error motion value, X"
  std::string component;  // e.g. "EXC"
  std::string unit;       // "um" or "urad"
  bool computed = false;
  // Why not computed: the block (translations or rotations) does not determine the location
  // errors, not every measured angle determines the component (`angles` of `measured`), or
  // more than `max_angles` angles.
  IsoMotionGap gap = IsoMotionGap::kNone;
  int measured = 0, max_angles = 0;
  int angles = 0;            // the measured angles the range is taken over
  double value = 0;          // the range of the estimated component motion
  double U = 0;              // q: the p-quantile of the range of the estimation errors
  double low = 0, high = 0;  // max(0, value - U), value + U: coverage probability at least p
};

struct IsoMotionOptions {
  bool enabled = true;
  std::uint64_t seed = 1;
  double coverage_probability = 0.95;
  long batch_trials = 10000;
  long max_trials = 1000000;  // at most 24 MB of trials (4 bytes x 6 values)
  int significant_digits = 2;
  // Beyond: not computed, said so (each trial costs angles^2 per component: 400 angles,
  // about a second per batch of 10^4 trials).
  int max_angles = 400;
  std::optional<double> dof;  // Type A: degrees of freedom of the multivariate t; absent: Gaussian
  // The joint covariance of each angle's six motions less their constant parts
  // (IsoComponentsAtAngle::motion_covariance).
  bool covariance = true;
};

struct IsoMotionValues {
  std::vector<IsoMotionValue> values;  // in the order of the component names
  long trials = 0;
  bool converged = false;
  std::uint64_t seed = 0;
  double coverage_probability = 0.95;
  std::optional<double> dof;  // of the multivariate t (Type A); absent: Gaussian
};

// A block (0: translations, 1: rotations) whose determined values (`values`) leave the
// location errors and constant parts undetermined (rank `rank` of 5).
struct IsoBlockGap {
  int block = 0;
  int values = 0;
  int rank = 0;
};

struct IsoResult {
  std::vector<IsoQuantity> location;  // 5: two positions, two orientations, the zero position
  // Their joint covariance (um, urad; the same scale as their std), in the order of `location`;
  // the rows and columns of an undetermined one are 0.
  Eigen::Matrix<double, 5, 5> location_covariance = Eigen::Matrix<double, 5, 5>::Zero();
  std::vector<IsoQuantity> constants;  // 5: d0 (3 components) and e0 (the two perpendicular to a)
  std::array<std::string, 6> component_names;
  std::vector<IsoComponentsAtAngle> components;
  IsoMotionValues motion_values;  // empty when not asked for
  std::vector<IsoBlockGap> gaps;  // what a block could not determine
  // The location errors the error model cannot express (not determined, whatever the readings:
  // a model constant over the angle holds no offset or tilt of the axis line).
  std::vector<std::string> not_in_model;
  // The error motions' estimates at two angles are independent: a per-angle model with no set-up
  // effect shared by the angles (no declared length offset, centring or ball placement).
  bool independent_between_angles = false;
};

// The ISO names of an axis: its location errors (two positions, two orientations, the zero
// position) and its component error motions (translations, then rotations).
struct IsoNames {
  std::array<std::string, 5> location;
  std::array<std::string, 6> components;
  // The constant parts: dx, dy, dz (um), then the tilts about p1 and p2 (urad).
  std::array<std::string, 5> constants;
};
// ISO 230-1: a location error is the direction, the digit zero, the axis' letter. For an axis
// along a machine axis (either sense): the positions along the two other machine axes, the
// orientations about them, the zero position about the machine axis (C: X0C, Y0C, A0C, B0C,
// C0C; B: X0B, Z0B, A0B, C0B, B0B; A: Y0A, Z0A, B0A, C0A, A0A). A nutating axis is named in
// its own frame, u = reference, v = direction x reference: U0C, V0C, AU0C, AV0C, C0C.
IsoNames iso230_names(const AxisFrame& axis);

// The frame the location errors are fitted in: p1, p2 perpendicular to the axis and q along
// it (the machine axes, positive, for an axis along one; else the axis' own frame).
struct IsoFrame {
  bool aligned = true;
  int ia = 2, ip1 = 0, ip2 = 1;  // the machine axes (aligned)
  Eigen::Vector3d p1, p2, q;
};
IsoFrame iso_frame(const AxisFrame& axis);

// What the five location errors (in the order of IsoNames::location, um and urad) add to the six
// error motions (dx, dy, dz in um, ex, ey, ez in urad) at the commanded angle (docs/iso230.md):
//   d = (I - R) o,  e = (I - R) alpha + c0 q,
// o and alpha the positions and orientations along p1 and p2, c0 the zero position about q.
Eigen::Matrix<double, 6, 5> location_motion(const AxisFrame& axis, double angle_deg);

// `uncertainty_scale` multiplies every standard uncertainty (the budget's Type A scale, 1 for Type
// B). Error motion values with `motion.enabled`.
IsoResult iso230_quantities(const Design& design, const Parameterisation& param,
                            const Estimate& est, double uncertainty_scale = 1.0,
                            const IsoMotionOptions& motion = {});

}  // namespace dbbkit
