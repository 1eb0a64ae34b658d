#include "dbbkit/design.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/measurement.hpp"
#include "dbbkit/user_text.hpp"
#include "number_text.hpp"
#include "tolerances.hpp"

namespace dbbkit {

namespace {
// The parts of a message as a terminal may show them (user_text.hpp): a NUL, an escape
// sequence or a value of megabytes is written as an escape or cut, never passed on.
// At most kMaxMessageSource bytes of a source (a path), kMaxMessageWhere of a key path or
// line, kMaxMessageDetail of what is wrong.
constexpr std::size_t kMaxMessageSource = 1000, kMaxMessageWhere = 300, kMaxMessageDetail = 2000;
std::string message_part(const std::string& s, std::size_t max_bytes, bool lines) {
  return printable(s, max_bytes, lines);
}
}  // namespace

InputError::InputError(std::string source, std::string where, std::string detail)
    : std::runtime_error(""),
      source_(message_part(source, kMaxMessageSource, false)),
      where_(message_part(where, kMaxMessageWhere, false)),
      detail_(message_part(detail, kMaxMessageDetail, true)),
      what_(source_ + ": " + (where_.empty() ? "" : where_ + ": ") + detail_) {}

InputError InputError::with_source(const std::string& source) const {
  return InputError(source, where_, detail_);
}

Direction Direction::named(const AxisFrame& axis, Kind kind) {
  Direction d;
  d.kind = kind;
  d.body = axis.named_direction(kind == Kind::kRadial ? 0 : kind == Kind::kTangential ? 1 : 2);
  return d;
}

Direction Direction::vector(const Eigen::Vector3d& unit_body) {
  Direction d;
  d.kind = Kind::kVector;
  d.body = unit_body;
  return d;
}

std::string Direction::label() const {
  switch (kind) {
    case Kind::kRadial:
      return "radial";
    case Kind::kTangential:
      return "tangential";
    case Kind::kAxial:
      return "axial";
    case Kind::kVector:
      break;
  }
  std::ostringstream s;
  s << "[" << body.x() << ", " << body.y() << ", " << body.z() << "]";
  return s.str();
}

double NoiseModel::sigma_um() const {
  return distribution == Distribution::kUniform ? half_width_um / std::sqrt(3.0) : std_um;
}

std::string NoiseModel::describe() const {
  std::ostringstream s;
  if (distribution == Distribution::kUniform) {
    s << "rectangular +-" << half_width_um << " um (sigma = a/sqrt(3) = " << sigma_um() << " um)";
  } else {
    s << "normal, sigma = " << std_um << " um";
  }
  return s.str();
}

std::string ErrorModel::describe() const {
  switch (kind) {
    case Kind::kPerAngle:
      return "per_angle";
    case Kind::kFourier:
      return "fourier order " + std::to_string(order);
    case Kind::kLegendre:
      return "legendre order " + std::to_string(order);
  }
  return "";
}

SetupUncertainty SetupOverride::over(const SetupUncertainty& base) const {
  SetupUncertainty u = base;
  if (length_offset_um) u.length_offset_um = *length_offset_um;
  if (trigger_offset_um) u.trigger_offset_um = *trigger_offset_um;
  if (placement_um) u.placement_um = *placement_um;
  if (centring_um) u.centring_um = *centring_um;
  if (L_mm) u.L_mm = *L_mm;
  if (D_mm) u.D_mm = *D_mm;
  if (H_mm) u.H_mm = *H_mm;
  return u;
}

SetupUncertainty Design::setup_of(int i) const {
  return installations[i].setup_std.over(setup_std);
}

bool Design::setup_nuisance_declared() const {
  for (size_t i = 0; i < installations.size(); ++i) {
    if (setup_of(static_cast<int>(i)).nuisance()) return true;
  }
  return false;
}

bool Design::directions_turn() const { return instrument_info(instrument).directions_turn; }

bool Design::partial_sweeps() const {
  for (const Installation& in : installations) {
    if (!in.angles_deg.empty() && in.angles_deg.size() < angles_deg.size()) return true;
  }
  return false;
}

int Design::readings_per_round() const {
  int n = 0;
  for (std::size_t i = 0; i < installations.size(); ++i)
    n += readings_per_sweep(static_cast<int>(i));
  return n;
}

int Design::find_installation(const std::string& id) const {
  for (size_t i = 0; i < installations.size(); ++i) {
    if (installations[i].id == id) return static_cast<int>(i);
  }
  return -1;
}

std::unordered_map<std::string, int> Design::installation_index() const {
  std::unordered_map<std::string, int> index;
  index.reserve(installations.size());
  for (size_t i = 0; i < installations.size(); ++i)
    index.emplace(installations[i].id, static_cast<int>(i));
  return index;
}

namespace {

void require(bool ok, const std::string& source, const std::string& key, const std::string& what) {
  if (!ok) throw InputError(source, key, what);
}

bool finite(double x) { return std::isfinite(x); }

// A length [mm] within the documented limit (limits.hpp).
bool length_ok(double x) { return std::isfinite(x) && std::abs(x) <= limits::kMaxLength_mm; }
const std::string kLengthLimit =
    "must be a finite length within +-10000 mm (docs/formats.md, \"Limits\")";

bool noise_ok(double x) {
  return std::isfinite(x) && x >= limits::kMinNoise_um && x <= limits::kMaxNoise_um;
}

}  // namespace

void validate_setup_uncertainty(const SetupUncertainty& u, const AxisFrame& axis,
                                const std::string& source, const std::string& key) {
  for (const auto& [name, x] :
       {std::pair<const char*, double>{"length_offset_um", u.length_offset_um},
        {"centring_um", u.centring_um},
        {"trigger_offset_um", u.trigger_offset_um},
        {"placement_um", u.placement_um}}) {
    require(std::isfinite(x) && x >= 0 && x <= limits::kMaxSetupStd_um, source, key + "." + name,
            "must be a standard uncertainty in [0, 10000] um (docs/formats.md, \"Limits\")");
    // The prior enters as 1 / u^2: a positive u far below any instrument underflows it.
    require(x == 0 || x >= limits::kMinSetupStd_um, source, key + "." + name,
            text::significant(x, 6) + " um: a positive tolerance is at least " +
                text::significant(limits::kMinSetupStd_um, 6) +
                " um (smaller ones are beyond the arithmetic: 1 / u^2 overflows); 0 declares "
                "none");
  }
  for (const auto& [name, x] :
       {std::pair<const char*, double>{"L_mm", u.L_mm}, {"D_mm", u.D_mm}, {"H_mm", u.H_mm}}) {
    require(std::isfinite(x) && x >= 0 && x <= limits::kMaxSetupStd_mm, source, key + "." + name,
            "must be a standard uncertainty in [0, 100] mm (docs/formats.md, \"Limits\")");
    require(x == 0 || x >= limits::kMinSetupStd_mm, source, key + "." + name,
            text::significant(x, 6) + " mm: a positive tolerance is at least " +
                text::significant(limits::kMinSetupStd_mm, 6) + " mm; 0 declares none");
  }
  if (!axis.has_H())
    require(u.H_mm == 0, source, key + ".H_mm", "H is not used for the swinging head B");
}

bool length_within_limits(double x_mm) { return length_ok(x_mm); }

void validate_noise_and_model(const NoiseModel& n, const ErrorModel& m, const AxisFrame& axis,
                              const std::string& source) {
  if (n.distribution == NoiseModel::Distribution::kUniform) {
    require(noise_ok(n.half_width_um), source, "noise.accuracy_um",
            "must be a number of um in [1e-4, 1e4] (docs/formats.md, \"Limits\")");
  } else {
    require(noise_ok(n.std_um), source, "noise.std_um",
            "must be a number of um in [1e-4, 1e4] (docs/formats.md, \"Limits\")");
  }
  require(m.order >= 0, source, "errors.order", "must be a non-negative integer");
  require(m.order <= limits::kMaxSeriesOrder, source, "errors.order",
          "must be at most " + std::to_string(limits::kMaxSeriesOrder) +
              " (docs/formats.md, \"Limits\")");
  // The series follows the travel: a full turn is periodic, an arc is not.
  if (m.kind == ErrorModel::Kind::kFourier) {
    require(axis.full_turn(), source, "errors.model",
            "a Fourier series is for a full-turn axis such as the turntable C; axis " +
                axis.label() + " turns through an arc: use \"legendre\"");
  }
  if (m.kind == ErrorModel::Kind::kLegendre) {
    require(!axis.full_turn(), source, "errors.model",
            "a Legendre series is for an axis that turns through an arc such as the swinging "
            "head B; axis " +
                axis.label() + " turns fully: use \"fourier\"");
  }
}

bool table_ball_beyond_tool(const AxisFrame& axis, const Direction& direction, int sign) {
  return !axis.head() || sign * direction.body.dot(axis.reference()) <= kBeyondTool;
}

long angle_index(const std::vector<double>& sorted, double a) {
  const auto it = std::lower_bound(sorted.begin(), sorted.end(), a - kAngleTolerance_deg);
  if (it == sorted.end() || !(std::abs(*it - a) < kAngleTolerance_deg)) return -1;
  return it - sorted.begin();
}

double below_cup_mm(double rise_mm, double bar_mm) {
  constexpr double kDegree = 3.14159265358979323846 / 180.0;
  return -rise_mm - bar_mm * std::sin(kMaxBarBelowCup_deg * kDegree);
}

std::optional<Eigen::Vector3d> head_tool_direction(const AxisFrame& axis,
                                                   const std::optional<DesignMachine>& machine) {
  if (!axis.head()) return std::nullopt;
  if (machine) {
    const Machine& m = *machine->machine;
    const int h = m.innermost(AxisFrame::Side::kHead);
    return m.body_direction_at(h, m.rotary[static_cast<std::size_t>(h)].reference,
                               machine->angles_at(0));
  }
  if (axis.machine_axis() == 2) return std::nullopt;
  return axis.reference();
}

std::optional<Eigen::Vector3d> table_up(const AxisFrame& axis,
                                        const std::optional<DesignMachine>& machine,
                                        double angle_deg) {
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  if (machine) {
    const Machine& m = *machine->machine;
    const int k = m.innermost(AxisFrame::Side::kTable);
    if (k < 0) return z;
    return m.body_direction_at(k, z, machine->angles_at(axis.table() ? angle_deg : 0.0));
  }
  if (axis.table()) {
    if (axis.machine_axis() != 2) return std::nullopt;
    return z;
  }
  const std::optional<Eigen::Vector3d> tool = head_tool_direction(axis, machine);
  return tool ? Eigen::Vector3d(-*tool) : z;
}

namespace {

// Each installation's own angles (installations[i].angles_deg): angles of the design, none
// twice; and every angle of the design is read by some installation.
void validate_installation_angles(const Design& d, const std::string& source) {
  std::vector<double> sorted = d.angles_deg;
  std::sort(sorted.begin(), sorted.end());
  auto design_angle = [&](double a) { return angle_index(sorted, a); };
  std::vector<char> read(sorted.size(), 0);
  for (std::size_t i = 0; i < d.installations.size(); ++i) {
    const Installation& in = d.installations[i];
    if (in.angles_deg.empty()) {
      std::fill(read.begin(), read.end(), 1);
      continue;
    }
    const std::string key = "installations[" + std::to_string(i) + "].angles_deg";
    std::vector<char> own(sorted.size(), 0);
    for (std::size_t k = 0; k < in.angles_deg.size(); ++k) {
      const double a = in.angles_deg[k];
      const std::string at = key + "[" + std::to_string(k) + "]";
      require(finite(a), source, at, "angle is not a finite number");
      const long j = design_angle(a);
      require(j >= 0, source, at,
              "angle " + text::significant(a, 12) +
                  " deg is not an angle of the design's angles_deg (an installation reads at "
                  "some of the design's angles)");
      require(!own[static_cast<std::size_t>(j)], source, at,
              "angle " + text::significant(a, 12) + " deg is given twice");
      own[static_cast<std::size_t>(j)] = read[static_cast<std::size_t>(j)] = 1;
    }
  }
  for (std::size_t j = 0; j < sorted.size(); ++j) {
    require(read[j], source, "angles_deg",
            "angle " + text::significant(sorted[j], 12) +
                " deg is read by no installation (each installation's angles_deg leaves it "
                "out): drop it from the design's angles or add it to an installation's");
  }
}

}  // namespace

namespace {

// A probe's design: its spheres, and its installations their channels; a ball bar's, no sphere
// and no channel.
void validate_instrument(const Design& d, const std::string& source) {
  if (d.instrument == InstrumentKind::kBallbar) {
    require(d.spheres.empty(), source, "spheres",
            "spheres are a touch probe's (instrument.kind probe)");
    if (const auto p = setup_tolerance_problem(d.setup_std, d.instrument))
      throw InputError(source, "setup_std", *p);
    for (std::size_t i = 0; i < d.installations.size(); ++i)
      require(!d.installations[i].setup_std.trigger_offset_um &&
                  !d.installations[i].setup_std.placement_um,
              source, "installations[" + std::to_string(i) + "].setup_std",
              "trigger_offset_um and placement_um are a touch probe's set-up tolerances");
    for (const Installation& in : d.installations)
      require(!in.probe_channel(), source, "installations",
              "installation " + quote_value(in.id) + " is a probe's channel in a ball bar design");
    return;
  }
  require(!d.spheres.empty(), source, "spheres", "no spheres");
  require(d.spheres.size() <= limits::kMaxSpheres, source, "spheres",
          "more than " + std::to_string(limits::kMaxSpheres) +
              " spheres (docs/formats.md, \"Limits\")");
  std::set<std::string> ids;
  for (std::size_t i = 0; i < d.spheres.size(); ++i) {
    const Sphere& sp = d.spheres[i];
    const std::string key = "spheres[" + std::to_string(i) + "]";
    if (const auto p = sphere_id_problem(sp.id))
      throw InputError(source, key + ".id", quote_value(sp.id) + ": " + *p);
    require(ids.insert(sp.id).second, source, key + ".id",
            "duplicate sphere id " + quote_value(sp.id));
    if (const auto p = text_problem(sp.description, limits::kMaxTextBytes))
      throw InputError(source, key + ".description", quote_value(sp.description) + ": " + *p);
    for (const auto& [name, v] : {std::pair{"L", sp.L_mm}, {"D", sp.D_mm}, {"H", sp.H_mm}})
      require(length_ok(v), source, key + ".ball_mm." + name,
              kLengthLimit + ", got " + text::significant(v, 6));
  }
  // What a probe's design cannot state: a ball bar's set-up tolerances and return reading.
  if (const auto p = setup_tolerance_problem(d.setup_std, d.instrument))
    throw InputError(source, "setup_std", *p);
  require(!d.return_reading, source, "return_reading",
          "a return reading is a ball bar sweep's; a probe's repeats are rows of its file");
  const std::vector<Installation> channels = probe_channels(d.axis, d.spheres);
  bool same = channels.size() == d.installations.size();
  for (std::size_t i = 0; same && i < channels.size(); ++i) {
    const Installation& a = channels[i];
    const Installation& b = d.installations[i];
    same = a.id == b.id && a.sphere == b.sphere && a.coordinate == b.coordinate &&
           a.sign == b.sign && a.L_mm == b.L_mm && a.D_mm == b.D_mm && a.H_mm == b.H_mm &&
           a.direction.body == b.direction.body && !b.setup_std.any() && b.angles_deg.empty() &&
           b.reading_sign == 1 && !b.bar_mm;
  }
  require(same, source, "installations",
          "a probe's installations are its spheres' channels (probe_channels), three a sphere");
}

}  // namespace

void validate_design(const Design& d, const std::string& source) {
  // Text is data (user_text.hpp): what no writer could carry safely is refused here.
  if (const auto p = text_problem(d.name, limits::kMaxNameBytes))
    throw InputError(source, "name", quote_value(d.name) + ": " + *p);
  if (const auto p = text_problem(d.description, limits::kMaxTextBytes))
    throw InputError(source, "description", quote_value(d.description) + ": " + *p);
  for (const auto& [k, v] : d.assumed) {
    if (const auto p = text_problem(k, limits::kMaxNameBytes))
      throw InputError(source, "assumed", "the key " + quote_value(k) + ": " + *p);
    if (const auto p = text_problem(v, limits::kMaxTextBytes))
      throw InputError(source, "assumed." + k, quote_value(v) + ": " + *p);
  }
  require(
      std::isfinite(d.instrument_range_mm) && d.instrument_range_mm >= kMinInstrumentRange_mm &&
          d.instrument_range_mm * 1000.0 <= kMaxAbsReading_um,
      source, "instrument.range_mm",
      "must be from 0.001 mm (1 um) to 10 mm, got " + text::significant(d.instrument_range_mm, 6));
  require(std::isfinite(d.max_drift_um_per_min) &&
              d.max_drift_um_per_min >= kMinMaxDrift_um_per_min &&
              d.max_drift_um_per_min <= kMaxMaxDrift_um_per_min,
          source, "instrument.max_drift_um_per_min",
          "must be from " + text::significant(kMinMaxDrift_um_per_min, 6) + " to " +
              text::significant(kMaxMaxDrift_um_per_min, 6) + " um/min, got " +
              text::significant(d.max_drift_um_per_min, 6));
  require(!d.angles_deg.empty(), source, "angles_deg", "no angles");
  require(
      d.angles_deg.size() <= limits::kMaxAngles, source, "angles_deg",
      "more than " + std::to_string(limits::kMaxAngles) + " angles (docs/formats.md, \"Limits\")");
  for (size_t i = 0; i < d.angles_deg.size(); ++i) {
    const std::string key = "angles_deg[" + std::to_string(i) + "]";
    const double a = d.angles_deg[i];
    require(finite(a), source, key, "angle is not a finite number");
    if (!d.axis.full_turn()) {
      require(a >= d.axis.travel_min_deg() && a <= d.axis.travel_max_deg(), source, key,
              "angle " + text::significant(a, 12) + " deg is outside [" +
                  text::significant(d.axis.travel_min_deg(), 12) + ", " +
                  text::significant(d.axis.travel_max_deg(), 12) + "] deg, the travel of axis " +
                  d.axis.label());
    } else {
      require(std::abs(a) <= 3600.0, source, key,
              "angle " + text::significant(a, 12) + " deg is beyond +-10 turns");
    }
  }
  {
    // Repeats: neighbours in sorted order (O(n log n); a design may have 1e5 angles).
    std::vector<std::pair<double, size_t>> sorted;
    for (size_t i = 0; i < d.angles_deg.size(); ++i) sorted.emplace_back(d.angles_deg[i], i);
    std::sort(sorted.begin(), sorted.end());
    for (size_t k = 1; k < sorted.size(); ++k) {
      if (std::abs(sorted[k].first - sorted[k - 1].first) < kAngleTolerance_deg) {
        const size_t i = std::max(sorted[k].second, sorted[k - 1].second);
        const size_t j = std::min(sorted[k].second, sorted[k - 1].second);
        throw InputError(source, "angles_deg[" + std::to_string(i) + "]",
                         "angle repeats angles_deg[" + std::to_string(j) + "]");
      }
    }
  }

  validate_noise_and_model(d.noise, d.errors, d.axis, source);
  // A reading noise as wide as the instrument's range is no noise the instrument can have.
  require(3e-3 * d.noise.sigma_um() < d.instrument_range_mm, source, "noise",
          "a reading noise of " + text::significant(d.noise.sigma_um(), 6) +
              " um (standard deviation) is not small against the instrument's range of +-" +
              text::significant(d.instrument_range_mm, 6) +
              " mm: three of it reach the range (the noise is in um)");
  if (d.errors.kind == ErrorModel::Kind::kLegendre) {
    if (d.errors.order > 0) {
      double lo = d.angles_deg.front(), hi = lo;
      for (double a : d.angles_deg) lo = std::min(lo, a), hi = std::max(hi, a);
      require(hi - lo > kAngleTolerance_deg, source, "errors.order",
              "a Legendre series of order > 0 needs more than one angle");
    }
  }
  if (d.reference_length_mm) {
    require(length_ok(*d.reference_length_mm) &&
                *d.reference_length_mm >= limits::kMinReferenceLength_mm,
            source, "reference_length_mm",
            "must be a length from 0.001 to 10000 mm, got " +
                text::significant(*d.reference_length_mm, 6));
  }

  if (d.predicted) {
    // What optimize predicted: informative, but bench decides on its time, and a report shows
    // it: numbers that can be.
    const Prediction& p = *d.predicted;
    for (const auto& [key, v] : {std::pair{"worst_std_um", p.worst_std_um},
                                 {"worst_determined_std_um", p.worst_determined_std_um},
                                 {"worst_total_std_um", p.worst_total_std_um}}) {
      require(!v || (std::isfinite(*v) && *v >= 0), source, std::string("predicted.") + key,
              "must be a standard uncertainty >= 0 um (or null)");
    }
    require(p.n_unknowns >= 0 && p.rank >= 0 && p.rank <= p.n_unknowns, source, "predicted.rank",
            "must be in [0, n_unknowns]");
    require(!p.time_s || (std::isfinite(*p.time_s) && *p.time_s >= 0), source, "predicted.time_s",
            "must be a time >= 0 s");
    if (const auto problem = text_problem(p.criterion, limits::kMaxNameBytes))
      throw InputError(source, "predicted.criterion", *problem);
  }
  validate_setup_uncertainty(d.setup_std, d.axis, source, "setup_std");
  validate_instrument(d, source);
  require(!d.installations.empty(), source, "installations", "no installations");
  require(d.installations.size() <= limits::kMaxInstallations, source, "installations",
          "more than " + std::to_string(limits::kMaxInstallations) +
              " installations (docs/formats.md, \"Limits\")");
  std::set<std::string> ids;
  for (size_t i = 0; i < d.installations.size(); ++i) {
    const Installation& in = d.installations[i];
    const std::string key = "installations[" + std::to_string(i) + "]";
    if (const auto p = id_problem(in.id))
      throw InputError(source, key + ".id", quote_value(in.id) + ": " + *p);
    if (const auto p = text_problem(in.description, limits::kMaxTextBytes))
      throw InputError(source, key + ".description", quote_value(in.description) + ": " + *p);
    validate_setup_uncertainty(in.setup_std.over(SetupUncertainty{}), d.axis, source,
                               key + ".setup_std");
    require(ids.insert(in.id).second, source, key + ".id",
            "duplicate installation id " + quote_value(in.id));
    require(length_ok(in.L_mm), source, key + ".ball_mm.L",
            kLengthLimit + ", got " + text::significant(in.L_mm, 6));
    require(length_ok(in.D_mm), source, key + ".ball_mm.D",
            kLengthLimit + ", got " + text::significant(in.D_mm, 6));
    require(length_ok(in.H_mm), source, key + ".ball_mm.H",
            kLengthLimit + ", got " + text::significant(in.H_mm, 6));
    // On the "C" shorthand L is the ball's radial distance; in the general form it is the
    // coordinate along the reference, which on a trunnion may put the ball below the axis line.
    if (d.axis.table() && !d.axis.shorthand().empty()) {
      require(in.L_mm >= 0, source, key + ".ball_mm.L",
              "the radial distance L of a ball on a table must be >= 0 mm");
    }
    require(in.reading_sign == 1 || in.reading_sign == -1, source, key + ".reading_sign",
            "must be +1 or -1, got " + std::to_string(in.reading_sign));
    if (!in.probe_channel() && !table_ball_beyond_tool(d.axis, in.direction, in.sign)) {
      throw InputError(
          source, key + ".sign",
          "installation " + in.id + " (" + in.direction.label() + ", sign " +
              std::to_string(in.sign) +
              ") puts the table ball on the pivot's side of the spindle ball (F = P - s bar u): "
              "on a head the table ball lies beyond the tool tip; the sign is geometry, so write "
              "sign " +
              std::to_string(-in.sign) +
              " (and, for data recorded with the other count, \"reading_sign\": -1)");
    }
    if (!d.axis.has_H()) {
      require(in.H_mm == 0.0, source, key + ".ball_mm.H",
              "H is not used for the swinging head B (ball at (L sin b, D, L cos b))");
    }
    const double norm = in.direction.body.norm();
    require(finite(norm) && std::abs(norm - 1.0) <= tol::kUnitVectorTolerance, source,
            key + ".direction",
            "an explicit direction must be a unit vector (|v| = " + std::to_string(norm) + ")");
    require(in.sign == 1 || in.sign == -1, source, key + ".sign",
            "must be +1 or -1, got " + std::to_string(in.sign));
    if (in.bar_mm) {
      require(length_ok(*in.bar_mm) && *in.bar_mm >= kMinBar_mm, source, key + ".bar_mm",
              "must be a length from 25 mm (two balls and their cups) to 10000 mm, got " +
                  text::significant(*in.bar_mm, 6));
    }
    if (!in.bar_parts_mm.empty()) {
      require(in.bar_mm.has_value(), source, key + ".bar_parts_mm",
              "the parts of a bar need its length bar_mm");
      double sum = 0;
      for (size_t k = 0; k < in.bar_parts_mm.size(); ++k) {
        require(length_ok(in.bar_parts_mm[k]) && in.bar_parts_mm[k] > 0, source,
                key + ".bar_parts_mm[" + std::to_string(k) + "]",
                "must be a positive length in mm, at most 10000 mm");
        sum += in.bar_parts_mm[k];
      }
      require(std::abs(sum - *in.bar_mm) <= kAssemblyTolerance_mm, source, key + ".bar_parts_mm",
              "the parts add up to " + std::to_string(sum) +
                  " mm, not bar_mm = " + std::to_string(*in.bar_mm) + " mm");
    }
    if (in.cup_mm) {
      require(d.axis.table(), source, key + ".stack_mm",
              "a cup on cushion blocks stands on a table: axis " + d.axis.label() +
                  " carries the head");
      require(length_ok(*in.cup_mm) && *in.cup_mm >= 0, source, key + ".stack_mm.cup",
              "must be a length >= 0 mm, at most 10000 mm");
      double sum = *in.cup_mm;
      for (size_t k = 0; k < in.blocks_mm.size(); ++k) {
        require(length_ok(in.blocks_mm[k]) && in.blocks_mm[k] > 0, source,
                key + ".stack_mm.blocks[" + std::to_string(k) + "]",
                "must be a positive length in mm, at most 10000 mm");
        sum += in.blocks_mm[k];
      }
      require(std::abs(sum - in.H_mm) <= kAssemblyTolerance_mm, source, key + ".stack_mm",
              "the cup and its blocks add up to " + std::to_string(sum) +
                  " mm, not H = " + std::to_string(in.H_mm) + " mm");
    } else {
      require(in.blocks_mm.empty(), source, key + ".stack_mm", "blocks need the cup's height");
    }
  }
  validate_installation_angles(d, source);
}

std::vector<double> DesignMachine::angles_at(double tested_deg) const {
  std::vector<double> a = park_angles();
  a[static_cast<std::size_t>(axis)] = tested_deg;
  return a;
}

std::vector<DesignMachine::AxisAngle> DesignMachine::angles_with(double tested_deg) const {
  const std::vector<double> a = angles_at(tested_deg);
  std::vector<AxisAngle> out;
  for (std::size_t k = 0; k < a.size(); ++k) out.push_back({machine->rotary[k].letter, a[k]});
  return out;
}

std::vector<DesignMachine::AxisAngle> DesignMachine::others() const {
  std::vector<AxisAngle> out;
  for (const AxisAngle& a : angles_with(0))
    if (a.letter != letter()) out.push_back(a);
  return out;
}

}  // namespace dbbkit
