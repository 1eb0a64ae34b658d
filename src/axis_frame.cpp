#include "dbbkit/axis_frame.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <sstream>
#include <vector>

#include "dbbkit/kinematics.hpp"
#include "number_text.hpp"

namespace dbbkit {

namespace {

const char* kMachineAxes = "XYZ";

// The machine axis index of a unit vector along one (+-), or -1.
int along_machine_axis(const Eigen::Vector3d& v) {
  for (int k = 0; k < 3; ++k) {
    if (std::abs(v(k)) == 1.0 && v((k + 1) % 3) == 0.0 && v((k + 2) % 3) == 0.0) return k;
  }
  return -1;
}

}  // namespace

std::string direction_text(const Eigen::Vector3d& v) {
  const int k = along_machine_axis(v);
  if (k >= 0) return std::string(v(k) > 0 ? "+" : "-") + kMachineAxes[k];
  return "[" + text::significant(v.x(), 6) + ", " + text::significant(v.y(), 6) + ", " +
         text::significant(v.z(), 6) + "]";
}

Eigen::Vector3d snapped_to_machine_axis(const Eigen::Vector3d& v) {
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(k);
    if (v(k) != 0 && v.cross(e).norm() <= kFrameTolerance)
      return v(k) > 0 ? e : Eigen::Vector3d(-e);
  }
  return v;
}

AxisFrame AxisFrame::c_turntable() {
  AxisFrame f =
      general('C', Side::kTable, Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX(), true);
  f.shorthand_ = "C";
  return f;
}

AxisFrame AxisFrame::b_head() {
  AxisFrame f = general('B', Side::kHead, Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(), false,
                        -180, 180);
  f.shorthand_ = "B";
  // The shorthand's D lies along the swing axis (model.md §4), and it has no H.
  f.e_D_ = f.direction_;
  f.e_H_ = f.direction_.cross(f.reference_);
  f.has_H_ = false;
  return f;
}

AxisFrame AxisFrame::general(char letter, Side side, const Eigen::Vector3d& direction,
                             const Eigen::Vector3d& reference, bool full_turn,
                             double travel_min_deg, double travel_max_deg) {
  AxisFrame f(0);
  f.letter_ = letter;
  f.side_ = side;
  f.direction_ = direction;
  f.reference_ = reference;
  f.e_L_ = reference;
  f.e_D_ = direction.cross(reference);
  f.e_H_ = direction;
  f.full_turn_ = full_turn;
  f.travel_min_deg_ = full_turn ? -3600 : travel_min_deg;
  f.travel_max_deg_ = full_turn ? 3600 : travel_max_deg;
  f.form_harmonics();
  return f;
}

void AxisFrame::form_harmonics() {
  const Eigen::Matrix3d R0 = rotation(0.0), R90 = rotation(90.0), R180 = rotation(180.0);
  harmonics_.A0 = 0.5 * (R0 + R180);
  harmonics_.A1 = 0.5 * (R0 - R180);
  harmonics_.A2 = R90 - harmonics_.A0;
}

Eigen::Vector3d AxisFrame::body_point(double L, double D, double H) const {
  // + 0.0: a coordinate that is a sum of zeros is +0, never -0.
  return (L * e_L_ + D * e_D_ + H * e_H_).array() + 0.0;
}

Eigen::Vector3d AxisFrame::named_direction(int kind) const {
  return kind == 0   ? reference_
         : kind == 1 ? Eigen::Vector3d(direction_.cross(reference_))
                     : direction_;
}

Eigen::Matrix3d AxisFrame::rotation(double angle_deg) const {
  double s, c;
  sincos_deg(angle_deg, s, c);
  Eigen::Matrix3d R;
  const int k = along_machine_axis(direction_);
  if (k >= 0) {
    // About a machine axis: the rotation matrix written out, every other entry 0 or 1.
    const double sk = direction_(k) > 0 ? s : -s;
    if (k == 2) {
      R << c, -sk, 0, sk, c, 0, 0, 0, 1;
    } else if (k == 1) {
      R << c, 0, sk, 0, 1, 0, -sk, 0, c;
    } else {
      R << 1, 0, 0, 0, c, -sk, 0, sk, c;
    }
    return R;
  }
  // Rodrigues: R = c I + s [a]x + (1 - c) a a'.
  const Eigen::Vector3d& a = direction_;
  Eigen::Matrix3d K;
  K << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  R = c * Eigen::Matrix3d::Identity() + s * K + (1.0 - c) * (a * a.transpose());
  return R;
}

std::string AxisFrame::label() const {
  if (!shorthand_.empty()) return shorthand_;
  return std::string(1, letter_) + " (" + (table() ? "table" : "head") + ", about " +
         direction_text(direction_) + ")";
}

int AxisFrame::machine_axis() const { return along_machine_axis(direction_); }

bool AxisFrame::same_as(const AxisFrame& o) const { return same_axis(o) && has_H_ == o.has_H_; }

bool AxisFrame::same_axis(const AxisFrame& o) const {
  return letter_ == o.letter_ && side_ == o.side_ && direction_ == o.direction_ &&
         reference_ == o.reference_ && full_turn_ == o.full_turn_ &&
         (full_turn_ ||
          (travel_min_deg_ == o.travel_min_deg_ && travel_max_deg_ == o.travel_max_deg_));
}

std::string axis_difference(const AxisFrame& a, const AxisFrame& b, bool with_travel) {
  std::vector<std::string> out;
  auto travel = [](const AxisFrame& f) {
    return f.full_turn() ? std::string("a full turn")
                         : text::significant(f.travel_min_deg(), 12) + ".." +
                               text::significant(f.travel_max_deg(), 12) + " deg";
  };
  if (a.letter() != b.letter())
    out.push_back("letter " + std::string(1, a.letter()) + " against " + b.letter());
  if (a.side() != b.side())
    out.push_back(std::string("side ") + (a.table() ? "table" : "head") + " against " +
                  (b.table() ? "table" : "head"));
  if (a.direction() != b.direction())
    out.push_back("direction " + direction_text(a.direction()) + " against " +
                  direction_text(b.direction()));
  if (a.reference() != b.reference())
    out.push_back("reference " + direction_text(a.reference()) + " against " +
                  direction_text(b.reference()));
  if (with_travel && travel(a) != travel(b))
    out.push_back("travel " + travel(a) + " against " + travel(b));
  if (a.has_H() != b.has_H())
    out.push_back(std::string("form ") + (a.shorthand().empty() ? "general" : "shorthand") +
                  " against " + (b.shorthand().empty() ? "general" : "shorthand"));
  std::string t;
  for (size_t i = 0; i < out.size(); ++i) t += (i ? "; " : "") + out[i];
  return t;
}

std::string axis_frame_problem(const Eigen::Vector3d& d, const Eigen::Vector3d& r) {
  if (!d.allFinite() || std::abs(d.norm() - 1.0) > kFrameTolerance)
    return "direction must be a unit vector (|v| = " + text::significant(d.norm(), 12) + ")";
  if (!r.allFinite() || std::abs(r.norm() - 1.0) > kFrameTolerance)
    return "reference must be a unit vector (|v| = " + text::significant(r.norm(), 12) + ")";
  if (std::abs(d.dot(r)) > kFrameTolerance)
    return "reference must be perpendicular to direction (d . r = " +
           text::significant(d.dot(r), 6) + ")";
  return "";
}

}  // namespace dbbkit
