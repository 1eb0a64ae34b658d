#pragma once
// Where a point of the turning body is off, and how sure (formats.md, "Predicting the tool tip"):
// from one axis' identified errors, the error of a point fixed to the body that turns (a point of
// the workpiece on a table, the tool tip on a head) at a commanded angle, with its covariance, and
// what remains of it once the location errors are entered in the controller.
//
// To first order (model.md §1) the point P0 (body frame = machine frame at angle 0, from the axis
// frame's origin) is at P = R(gamma) P0 and is displaced by dP = d + e x P, (d, e) the error
// motions at gamma. Of these the prediction takes what a controller's kinematics can be off by
// and what it cannot correct, never the constant parts (where each reading's zero was taken):
//   (d, e) = G(gamma) l + c(gamma),
// l the five location errors (iso230.hpp, location_motion) and c the component error motions.
// - At an angle the result measured, with the joint covariance of G l + c stated there
//   (IsoComponentsAtAngle::motion_covariance): dP from both, its covariance H S H', H the
//   Jacobian of dP in (d, e).
// - At any other angle: the location errors' part alone, covariance (H G) C (H G)', C their
//   covariance; the component motions there are not known and are said to be left out.
// After entering the location errors l^ the controller moves the point by -G l^: the point is
// then off by G (l - l^) + c, whose estimate is H c^ and whose uncertainty is that of dP itself
// (the estimate's error is the same); at an angle not measured, 0 with the location errors'
// covariance, the component motions again left out.
//
// Coverage: each coordinate's U = k u, k the normal quantile of the coverage probability (the
// Student t quantile with the result's effective degrees of freedom where it states them). The
// error vector as a whole: the true error lies within `U_length` of the predicted one with the
// coverage probability: for a Gaussian error the radius whose ball holds that probability
// (P(sum lambda_i z_i^2 <= U^2), the eigenvalues lambda of the covariance: the chi-squared (3)
// distribution of the radius averaged over the directions, 24 x 24 nodes on an octant of the
// sphere; checked against the chi-squared and normal cases and by sampling); with degrees of
// freedom, at least
// it: U^2 = lambda_max 3 F(3, nu), the sphere around the ellipsoid of that probability.

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/axis_frame.hpp"

namespace dbbkit {

// What a result states of one axis, for prediction.
struct AxisErrors {
  AxisFrame axis;
  std::array<std::optional<double>, 5> location;  // in the order of IsoNames::location (um, urad)
  Eigen::Matrix<double, 5, 5> location_covariance = Eigen::Matrix<double, 5, 5>::Zero();
  // The angles where the six component error motions and the joint covariance of the motions
  // less their constant parts are stated.
  struct AtAngle {
    double angle_deg = 0;
    std::array<double, 6> component{};  // translations um, rotations urad (machine frame)
    Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
    // The covariance of the six motions themselves (constant parts included), where stated.
    std::optional<Eigen::Matrix<double, 6, 6>> errors_covariance;
    // The six motions themselves (the result's `errors` at this angle: constant parts included),
    // where all six are stated.
    std::optional<Eigen::Matrix<double, 6, 1>> errors;
  };
  std::vector<AtAngle> measured;
  // The motions' constant parts (iso230.constant_parts: d0 x, y, z um, e0 along the frame's p1
  // and p2 urad) and their standard deviations, where all five are determined.
  std::optional<Eigen::Matrix<double, 5, 1>> constants;
  Eigen::Matrix<double, 5, 1> constants_std = Eigen::Matrix<double, 5, 1>::Zero();
  // Angles whose component motions the result states without the motions' covariance.
  std::vector<double> measured_without_covariance;
  std::optional<double> dof;  // effective degrees of freedom (Type A); absent: Gaussian
  // The motions' estimates at two angles are independent (IsoResult::independent_between_angles).
  bool independent_between_angles = false;
};

struct Pose {
  double angle_deg = 0;
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();  // body frame, from the axis frame's origin
};

enum class PredictionBasis {
  kMotions,       // location errors and component error motions at a measured angle
  kLocationOnly,  // the location errors alone: `location_reason` says why
};
// Why the location errors alone: the angle was not measured (the component motions there are not
// known: U is then the location part's alone and does not cover them), the result states no
// covariance of the motions (an earlier version, or diagnose's shares), or it was asked for.
enum class LocationReason { kNotMeasured, kNoMotionCovariance, kAsked };

enum class PredictionGap { kNone, kLocationNotDetermined };

struct PointPrediction {
  Pose pose;
  PredictionBasis basis = PredictionBasis::kLocationOnly;
  LocationReason location_reason = LocationReason::kNotMeasured;
  PredictionGap gap = PredictionGap::kNone;              // kNone: the numbers below hold
  Eigen::Vector3d nominal_mm = Eigen::Vector3d::Zero();  // R(gamma) P0: where the point should be
  Eigen::Vector3d error_um = Eigen::Vector3d::Zero();    // the point's true minus nominal position
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // of error_um (um^2)
  Eigen::Vector3d after_um = Eigen::Vector3d::Zero();    // what remains once the values are entered
  Eigen::Matrix3d after_covariance = Eigen::Matrix3d::Zero();
  double U_um = 0, after_U_um = 0;  // length_uncertainty of each covariance
};

struct PredictionCoverage {
  double coverage_probability = 0.95;
  double k = 0;         // per coordinate
  double k_length = 0;  // sqrt(q): U_length = k_length sqrt(lambda_max)
  std::optional<double> dof;
};
PredictionCoverage prediction_coverage(double coverage_probability, std::optional<double> dof);

// The radius around a predicted error within which the true one lies with at least the coverage
// probability.
double length_uncertainty(const Eigen::Matrix3d& covariance, const PredictionCoverage& c);

// The Jacobian of dP [um] in (d [um], e [urad]) at the point P [mm]: dP = d + 1e-3 e x P.
Eigen::Matrix<double, 3, 6> point_jacobian(const Eigen::Vector3d& P_mm);

// A map over the envelope: at each angle, points on circles about the axis line, `around` to a
// circle evenly spaced from the reference direction (radial), at each distance from the axis
// line (radius) and each height along the axis from the axis frame's origin. On a table, the
// workpiece's points; on a head, tool tips (a radius is a tool's reach from the axis).
struct EnvelopeGrid {
  std::vector<double> angles_deg, radii_mm, heights_mm;
  int around = 8;  // points on each circle (1: the reference direction alone)
};
// The grid's poses, angle by angle, then radius, height and position around (body frame, from
// the axis frame's origin): P = r (cos(phi) u + sin(phi) w x u) + h w, w the axis direction,
// u the reference direction, phi = 360 deg k / around. A radius of 0 gives one point per height.
std::vector<Pose> envelope_poses(const AxisFrame& axis, const EnvelopeGrid& grid);

// The five location errors as a vector, or nothing where one is not determined.
std::optional<Eigen::Matrix<double, 5, 1>> location_values(const AxisErrors& axis);

// Whether two commanded angles are the same position: within 1e-9 deg (on a full turn, or whole
// turns apart).
bool same_angle(const AxisFrame& axis, double a_deg, double b_deg);
// The angle the result measured (with the motions' covariance) that is this one, or nullptr.
const AxisErrors::AtAngle* measured_at(const AxisErrors& axis, double angle_deg);

// A machine result (chain.hpp; `dbbkit chain --out`): every rotary axis' line as the controller
// holds it, moved by its location errors, each in its carrier's body. The location errors alone:
// a chain states no component error motions.
struct ChainErrors {
  struct Axis {
    char letter = 'C';
    bool table = true;
    int on = -1;  // the index in `axes` of the axis that carries this one; -1: the machine's frame
    Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();  // the nominal line (machine frame at zero)
    Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
    std::array<std::optional<double>, 5> location;  // two offsets (um), two tilts, the zero (urad)
    // Each location error's direction: the offsets' and the tilts' rotation axes (machine frame),
    // the zero error's rotation axis (the axis' own direction, or its opposite).
    std::array<Eigen::Vector3d, 5> vector{};
  };
  std::vector<Axis> axes;
  Eigen::MatrixXd covariance;  // of the location errors, 5 per axis in axes' order (um, urad)
};

// A pose of a machine: every rotary axis' commanded angle (in `axes`' order) and the points fixed
// to its innermost bodies, given where they are with every axis at zero (machine frame, mm). One
// side alone (table on table, or head on head): `point_mm` is the innermost body's point (on a
// table the workpiece's, on a head the tool tip). A table and a head: `point_mm` is the
// workpiece's point on the innermost table, `tool_mm` the tool tip in the innermost head (the
// linear axes at zero too).
struct ChainPose {
  std::vector<double> angles_deg;
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> tool_mm;
};

struct ChainPointPrediction {
  ChainPose pose;
  bool determined = true;  // false: a location error it moves with is not determined
  // Where the controller's model puts the point (a table and a head: the workpiece's point, where
  // TCPM brings the tool tip).
  Eigen::Vector3d nominal_mm = Eigen::Vector3d::Zero();
  // One side: the point's true minus nominal position (machine frame, um), each axis turned about
  // its real line (exact rotations: T_1 ... T_n x, the innermost first). A table and a head: the
  // tool tip's place relative to the workpiece's point, true minus nominal, = the tool tip's
  // displacement minus the workpiece point's (the linear axes move both alike; they are taken as
  // exact); its covariance to first order (central differences of 1e-3 um and urad) from the
  // chain's (the two sides' correlation included), and its length uncertainty.
  Eigen::Vector3d error_um = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  double U_um = 0;
  // A table and a head: the two displacements whose difference is error_um (um).
  std::optional<Eigen::Vector3d> tool_um, workpiece_um;
};

// The axes on each side from the innermost body outwards: on each side one chain (every axis but
// that side's outermost carried by the next one of the same side; the outermost carried by the
// machine's frame). Either side may be empty, not both.
struct ChainOrder {
  std::vector<int> table, head;
  bool both() const { return !table.empty() && !head.empty(); }
};
// Nothing where the axes are not so (a fork: two axes on one carrier; a head carried by a table).
std::optional<ChainOrder> chain_order(const ChainErrors& chain);

// `order`: chain_order(chain). `pose.tool_mm` is given exactly where order.both().
ChainPointPrediction predict_chain_point(const ChainErrors& chain, const ChainOrder& order,
                                         const ChainPose& pose, const PredictionCoverage& coverage);

// The prediction at one pose. An angle is a measured one when it equals it within 1e-9 deg (on a
// full turn, or differs from it by whole turns). `location_only`: the location errors alone at
// every angle (what a controller's kinematics can be off by; the component motions left out).
PointPrediction predict_point(const AxisErrors& axis, const Pose& pose,
                              const PredictionCoverage& coverage, bool location_only = false);

// Which of the location errors to enter, judged over an envelope's poses (compensation,
// formats.md): at each pose the location errors' part of its error, A l with A = H G, and U,
// the length uncertainty of A C A' (the same before and after entering: the estimate's error is
// the same). A set S of the candidates leaves at most max over the poses of |A l_S'| + U, l_S'
// the location errors with those of S taken out (its bound). Every non-empty set of candidates
// is tried; the one of the smallest bound (on a tie, of fewer values) is entered where that bound
// is below the largest error today (max |A l|), none otherwise. Every location error must be
// determined.
struct EnteringJudgement {
  std::array<bool, 5> enter{};          // the set entered (all false: none)
  double today_um = 0, today_U_um = 0;  // the largest error today (estimate) and its U
  Pose today_at;
  double after_bound_um = 0;  // entering `enter`: the largest of the error left plus its U
  Pose after_at;
  double best_bound_um = 0;  // the smallest bound of any non-empty set (infinite: no candidate)
  // The bound with each candidate left out of the set entered, or added to it.
  std::array<double, 5> bound_without{}, bound_with{};
};
EnteringJudgement judge_entering(const AxisErrors& axis, const std::vector<Pose>& poses,
                                 const std::array<bool, 5>& candidate,
                                 const PredictionCoverage& coverage);

}  // namespace dbbkit
