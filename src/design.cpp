#include "dbbkit/design.hpp"

#include <cmath>
#include <set>
#include <sstream>

#include "dbbkit/error.hpp"

namespace dbbkit {

InputError::InputError(std::string source, std::string where, std::string detail)
    : std::runtime_error(source + ": " + (where.empty() ? "" : where + ": ") + detail),
      source_(std::move(source)),
      where_(std::move(where)),
      detail_(std::move(detail)) {}

InputError InputError::with_source(const std::string& source) const {
  return InputError(source, where_, detail_);
}

const char* axis_name(Axis axis) { return axis == Axis::C ? "C" : "B"; }

Direction Direction::named(Axis axis, Kind kind) {
  Direction d;
  d.kind = kind;
  if (axis == Axis::C) {
    d.body = kind == Kind::Radial       ? Eigen::Vector3d::UnitX()
             : kind == Kind::Tangential ? Eigen::Vector3d::UnitY()
                                        : Eigen::Vector3d::UnitZ();
  } else {
    d.body = kind == Kind::Radial       ? Eigen::Vector3d::UnitZ()
             : kind == Kind::Tangential ? Eigen::Vector3d::UnitX()
                                        : Eigen::Vector3d::UnitY();
  }
  return d;
}

Direction Direction::vector(const Eigen::Vector3d& unit_body) {
  Direction d;
  d.kind = Kind::Vector;
  d.body = unit_body;
  return d;
}

std::string Direction::label() const {
  switch (kind) {
    case Kind::Radial:
      return "radial";
    case Kind::Tangential:
      return "tangential";
    case Kind::Axial:
      return "axial";
    case Kind::Vector:
      break;
  }
  std::ostringstream s;
  s << "[" << body.x() << ", " << body.y() << ", " << body.z() << "]";
  return s.str();
}

double NoiseModel::sigma_um() const {
  return distribution == Distribution::Uniform ? half_width_um / std::sqrt(3.0) : std_um;
}

std::string NoiseModel::describe() const {
  std::ostringstream s;
  if (distribution == Distribution::Uniform) {
    s << "rectangular +-" << half_width_um << " um (sigma = a/sqrt(3) = " << sigma_um() << " um)";
  } else {
    s << "normal, sigma = " << std_um << " um";
  }
  return s.str();
}

std::string ErrorModel::describe() const {
  switch (kind) {
    case Kind::PerAngle:
      return "per_angle";
    case Kind::Fourier:
      return "fourier order " + std::to_string(order);
    case Kind::Legendre:
      return "legendre order " + std::to_string(order);
  }
  return "";
}

int Design::find_installation(const std::string& id) const {
  for (size_t i = 0; i < installations.size(); ++i) {
    if (installations[i].id == id) return static_cast<int>(i);
  }
  return -1;
}

namespace {

void require(bool ok, const std::string& source, const std::string& key, const std::string& what) {
  if (!ok) throw InputError(source, key, what);
}

bool finite(double x) { return std::isfinite(x); }

}  // namespace

void validate_noise_and_model(const NoiseModel& n, const ErrorModel& m, Axis axis, const std::string& source) {
  if (n.distribution == NoiseModel::Distribution::Uniform) {
    require(finite(n.half_width_um) && n.half_width_um > 0, source, "noise.accuracy_um",
            "must be a positive number of um");
  } else {
    require(finite(n.std_um) && n.std_um > 0, source, "noise.std_um", "must be a positive number of um");
  }
  require(m.order >= 0, source, "errors.order", "must be a non-negative integer");
  if (m.kind == ErrorModel::Kind::Fourier) {
    require(axis == Axis::C, source, "errors.model",
            "a Fourier series is for the full-turn axis C; use \"legendre\" for the swinging head B");
  }
  if (m.kind == ErrorModel::Kind::Legendre) {
    require(axis == Axis::B, source, "errors.model",
            "a Legendre series is for the partial-range axis B; use \"fourier\" for the turntable C");
  }
}

void validate_design(const Design& d, const std::string& source) {
  require(!d.angles_deg.empty(), source, "angles_deg", "no angles");
  for (size_t i = 0; i < d.angles_deg.size(); ++i) {
    const std::string key = "angles_deg[" + std::to_string(i) + "]";
    const double a = d.angles_deg[i];
    require(finite(a), source, key, "angle is not a finite number");
    if (d.axis == Axis::B) {
      require(a >= -180.0 && a <= 180.0, source, key,
              "angle " + std::to_string(a) + " deg is outside [-180, 180] deg, the most a swinging head B can reach");
    }
    for (size_t j = 0; j < i; ++j) {
      require(std::abs(d.angles_deg[j] - a) >= kAngleTolerance_deg, source, key,
              "angle repeats angles_deg[" + std::to_string(j) + "]");
    }
  }

  validate_noise_and_model(d.noise, d.errors, d.axis, source);
  if (d.errors.kind == ErrorModel::Kind::Legendre) {
    if (d.errors.order > 0) {
      double lo = d.angles_deg.front(), hi = lo;
      for (double a : d.angles_deg) lo = std::min(lo, a), hi = std::max(hi, a);
      require(hi - lo > kAngleTolerance_deg, source, "errors.order",
              "a Legendre series of order > 0 needs more than one angle");
    }
  }
  if (d.reference_length_mm) {
    require(finite(*d.reference_length_mm) && *d.reference_length_mm > 0, source,
            "reference_length_mm", "must be a positive length in mm");
  }

  for (const auto& [key, u] : {std::pair<const char*, double>{"L", d.setup_std.L_mm}, {"D", d.setup_std.D_mm},
                               {"H", d.setup_std.H_mm}}) {
    require(std::isfinite(u) && u >= 0, source, std::string("setup_std_mm.") + key,
            "must be a standard uncertainty >= 0 mm");
  }
  if (d.axis == Axis::B) {
    require(d.setup_std.H_mm == 0, source, "setup_std_mm.H", "H is not used for the swinging head B");
  }
  require(!d.installations.empty(), source, "installations", "no installations");
  std::set<std::string> ids;
  for (size_t i = 0; i < d.installations.size(); ++i) {
    const Installation& in = d.installations[i];
    const std::string key = "installations[" + std::to_string(i) + "]";
    require(!in.id.empty(), source, key + ".id", "empty id");
    for (char c : in.id) {
      require(c != ',' && c != '"' && !std::isspace(static_cast<unsigned char>(c)), source,
              key + ".id", "id '" + in.id + "' contains a comma, quote or white space");
    }
    require(ids.insert(in.id).second, source, key + ".id", "duplicate installation id '" + in.id + "'");
    require(finite(in.L_mm), source, key + ".ball_mm.L", "not a finite number");
    require(finite(in.D_mm), source, key + ".ball_mm.D", "not a finite number");
    require(finite(in.H_mm), source, key + ".ball_mm.H", "not a finite number");
    if (d.axis == Axis::C) {
      require(in.L_mm >= 0, source, key + ".ball_mm.L",
              "the radial distance L of a turntable ball must be >= 0 mm");
    } else {
      require(in.H_mm == 0.0, source, key + ".ball_mm.H",
              "H is not used for the swinging head B (ball at (L sin b, D, L cos b))");
    }
    const double norm = in.direction.body.norm();
    require(finite(norm) && std::abs(norm - 1.0) < 1e-6, source, key + ".direction",
            "an explicit direction must be a unit vector (|v| = " + std::to_string(norm) + ")");
    require(in.sign == 1 || in.sign == -1, source, key + ".sign", "must be +1 or -1");
    if (in.bar_mm) {
      require(finite(*in.bar_mm) && *in.bar_mm > 0, source, key + ".bar_mm", "must be a positive length in mm");
    }
  }
}

}  // namespace dbbkit
