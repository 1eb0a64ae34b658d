#include "dbbkit/effects.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/kinematics.hpp"
#include "number_text.hpp"
#include "tolerances.hpp"

namespace dbbkit {

namespace {
struct KindInfo {
  EffectKind kind;
  const char* name;
  const char* unit;
  bool shared;
};
constexpr KindInfo kKinds[] = {
    {EffectKind::kLengthOffset, "length_offset", "um", false},
    {EffectKind::kCentring, "centring", "um", false},
    {EffectKind::kDrift, "drift", "um/min", false},
    {EffectKind::kReversal, "reversal", "um", false},
    {EffectKind::kScale, "scale", "um/m", true},
    {EffectKind::kSquareness, "squareness", "urad", true},
    {EffectKind::kPeriodic, "periodic", "um", false},
    {EffectKind::kStep, "step", "um", false},
    {EffectKind::kThermal, "thermal", "um", false},
};
const KindInfo& info(EffectKind k) {
  for (const KindInfo& i : kKinds) {
    if (i.kind == k) return i;
  }
  return kKinds[0];
}
}  // namespace

const char* effect_name(EffectKind kind) { return info(kind).name; }
const char* effect_unit(EffectKind kind) { return info(kind).unit; }
bool effect_is_shared(EffectKind kind) { return info(kind).shared; }
bool effect_has_whole_test_form(EffectKind kind) {
  return kind == EffectKind::kLengthOffset || kind == EffectKind::kDrift ||
         kind == EffectKind::kReversal || kind == EffectKind::kThermal;
}

EffectKind effect_kind(const std::string& name, const std::string& source, const std::string& key) {
  for (const KindInfo& i : kKinds) {
    if (name == i.name) return i.kind;
  }
  throw InputError(source, key,
                   "unknown effect '" + name +
                       "' (expected length_offset, centring, drift, reversal, step, thermal, "
                       "scale, squareness or periodic)");
}

namespace {
// A position in a label: up to 6 significant digits.
std::string short_number(double x) { return text::significant(x, 6); }

// Parameters of an effect: three components for the vector effects, else one.
int effect_parameter_count(EffectKind kind) {
  return kind == EffectKind::kCentring || kind == EffectKind::kScale ||
                 kind == EffectKind::kSquareness
             ? 3
             : 1;
}
}  // namespace

std::vector<std::string> effect_parameter_names(EffectKind kind) {
  switch (kind) {
    case EffectKind::kCentring:
      return {"cx", "cy", "cz"};
    case EffectKind::kScale:
      return {"x", "y", "z"};
    case EffectKind::kSquareness:
      return {"xy", "yz", "zx"};
    default:
      return {"value"};
  }
}

std::string EffectCandidate::label(const Design& design) const {
  std::string s = effect_name(kind);
  if (component >= 0) s += "." + effect_parameter_names(kind)[component];
  if (installation >= 0) s += "[" + design.installations[installation].id + "]";
  if (installation < 0 && effect_has_whole_test_form(kind)) s += "[all]";
  if (kind == EffectKind::kPeriodic) s += "(" + std::to_string(harmonic) + "/turn)";
  if (kind == EffectKind::kStep && std::isfinite(at_s)) s += "(t=" + short_number(at_s) + "s)";
  if (kind == EffectKind::kThermal) s += "(tau=" + short_number(tau_min) + "min)";
  return s;
}

namespace {

// Each installation's earliest reading time (NaN without one), the readings' installations
// given (-1: none of the design's).
std::vector<double> start_times(const Design& design, const std::vector<Reading>& readings,
                                const std::vector<int>& installation) {
  std::vector<double> t0(design.installations.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < readings.size(); ++k) {
    const int i = installation[k];
    const Reading& r = readings[k];
    if (i >= 0 && r.time_s && !(t0[static_cast<std::size_t>(i)] <= *r.time_s))
      t0[static_cast<std::size_t>(i)] = *r.time_s;
  }
  return t0;
}

}  // namespace

std::vector<double> installation_start_times(const Design& design,
                                             const std::vector<Reading>& readings) {
  const auto index = design.installation_index();
  std::vector<int> installation;
  installation.reserve(readings.size());
  for (const Reading& r : readings) {
    const auto it = index.find(r.installation);
    installation.push_back(it == index.end() ? -1 : it->second);
  }
  return start_times(design, readings, installation);
}

double test_start_time(const std::vector<Reading>& readings) {
  double t0 = std::numeric_limits<double>::quiet_NaN();
  for (const Reading& r : readings) {
    if (r.time_s && !(t0 <= *r.time_s)) t0 = *r.time_s;
  }
  return t0;
}

Eigen::Vector3d centring_row(const AxisFrame& axis, const Installation& in, double angle_deg) {
  return -in.sign * direction_machine(axis, in, angle_deg);
}

Eigen::VectorXd J_reading_effect(const Design& design, const Reading& r, double t0_s,
                                 const EffectCandidate& e) {
  return J_reading_effect(design, r, design.find_installation(r.installation), t0_s, e);
}

namespace {

// J_reading_effect's row without a heap allocation (at most three parameters): effect_block
// forms one per reading and effect.
using EffectRow = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3, 1>;
EffectRow effect_row(const Design& design, const Reading& r, int inst, double t0_s,
                     const EffectCandidate& e);

}  // namespace

Eigen::VectorXd J_reading_effect(const Design& design, const Reading& r, int inst, double t0_s,
                                 const EffectCandidate& e) {
  return effect_row(design, r, inst, t0_s, e);
}

namespace {

EffectRow effect_row(const Design& design, const Reading& r, int inst, double t0_s,
                     const EffectCandidate& e) {
  EffectRow row = EffectRow::Zero(effect_parameter_count(e.kind));
  if (e.installation >= 0 && e.installation != inst) return row;
  const Installation& in = design.installations[inst];
  switch (e.kind) {
    case EffectKind::kLengthOffset:
      row(0) = kLengthOffsetRow;
      break;
    case EffectKind::kCentring:
      row = centring_row(design.axis, in, r.angle_deg);
      break;
    case EffectKind::kDrift:
      if (r.time_s && std::isfinite(t0_s)) row(0) = (*r.time_s - t0_s) / 60.0;
      break;
    case EffectKind::kReversal:
      if (r.sweep) row(0) = *r.sweep == Sweep::kCW ? 0.5 : -0.5;
      break;
    case EffectKind::kScale:
    case EffectKind::kSquareness: {
      if (!in.bar_mm) break;
      const Eigen::Vector3d u = direction_machine(design.axis, in, r.angle_deg);
      const Eigen::Vector3d F =
          ball_position_mm(design.axis, in, r.angle_deg) - in.sign * *in.bar_mm * u;
      const Eigen::Vector3d w =
          -in.sign * 1e-3 * u;  // reading per um of following-ball motion, per mm of F
      if (e.kind == EffectKind::kScale) {
        row = w.cwiseProduct(F);
      } else {
        row << w.x() * F.y(), w.y() * F.z(), w.z() * F.x();
      }
      break;
    }
    case EffectKind::kStep:
      if (r.time_s && *r.time_s >= e.at_s) row(0) = 1.0;
      break;
    case EffectKind::kThermal:
      if (r.time_s && std::isfinite(t0_s) && e.tau_min > 0)
        row(0) = -std::expm1(-(*r.time_s - t0_s) / (60.0 * e.tau_min));
      break;
    case EffectKind::kPeriodic: {
      double s, c;
      sincos_deg(e.harmonic * r.angle_deg - e.phase_deg, s, c);
      row(0) = c;
      break;
    }
  }
  return row;
}

}  // namespace

ReadingLayout::ReadingLayout(const Design& design, const std::vector<Reading>& readings)
    : test_start_s(test_start_time(readings)) {
  const auto index = design.installation_index();  // each reading's installation, looked up once
  installation.reserve(readings.size());
  for (const Reading& r : readings) installation.push_back(index.at(r.installation));
  start_s = start_times(design, readings, installation);
}

EffectBlock effect_block(const Design& design, const std::vector<Reading>& readings,
                         const EffectCandidate& e) {
  return effect_block(design, readings, ReadingLayout(design, readings), e);
}

EffectBlock effect_block(const Design& design, const std::vector<Reading>& readings,
                         const ReadingLayout& layout, const EffectCandidate& e) {
  EffectBlock b;
  b.effect = e;
  b.label = e.label(design);
  b.unit = effect_unit(e.kind);
  const std::vector<std::string> names = effect_parameter_names(e.kind);
  // Zero where the effect does not apply (another installation's readings): effect_row's own
  // value there.
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(readings.size()),
                                               static_cast<Eigen::Index>(names.size()));
  bool time_missing = false, cw = false, ccw = false, bar_missing = false;
  for (std::size_t i = 0; i < readings.size(); ++i) {
    const Reading& r = readings[i];
    const int inst = layout.installation[i];
    if (e.installation >= 0 && e.installation != inst) continue;  // does not apply
    time_missing = time_missing || !r.time_s;
    cw = cw || (r.sweep && *r.sweep == Sweep::kCW);
    ccw = ccw || (r.sweep && *r.sweep == Sweep::kCCW);
    bar_missing = bar_missing || !design.installations[inst].bar_mm;
    const double start = e.installation < 0 ? layout.test_start_s : layout.start_s[inst];
    full.row(static_cast<Eigen::Index>(i)) = effect_row(design, r, inst, start, e).transpose();
  }
  if ((e.kind == EffectKind::kDrift || e.kind == EffectKind::kThermal) && time_missing)
    b.applicability.why = NotApplicable::kNeedsTimes;
  if (e.kind == EffectKind::kReversal && !(cw && ccw))
    b.applicability.why = NotApplicable::kNeedsBothSweeps;
  if ((e.kind == EffectKind::kScale || e.kind == EffectKind::kSquareness) && bar_missing) {
    b.applicability.why = NotApplicable::kNeedsBar;
  }
  std::vector<int> keep;
  for (int j = 0; j < full.cols(); ++j) {
    if ((e.component < 0 || e.component == j) &&
        full.col(j).cwiseAbs().maxCoeff() > tol::kSeenValue)
      keep.push_back(j);
  }
  if (keep.empty() && b.applicability.applicable())
    b.applicability.why = NotApplicable::kChangesNoReading;
  for (int j : keep) b.parameters.push_back(names[static_cast<std::size_t>(j)]);
  if (static_cast<Eigen::Index>(keep.size()) == full.cols()) {  // every column kept, in order
    b.J_reading_effect = std::move(full);
    return b;
  }
  b.J_reading_effect.resize(full.rows(), static_cast<Eigen::Index>(keep.size()));
  for (std::size_t j = 0; j < keep.size(); ++j)
    b.J_reading_effect.col(static_cast<Eigen::Index>(j)) = full.col(keep[j]);
  return b;
}

std::vector<EffectBlock> candidate_effects(const Design& design,
                                           const std::vector<Reading>& readings) {
  std::vector<EffectBlock> out;
  const ReadingLayout layout(design, readings);
  for (EffectKind k : {EffectKind::kLengthOffset, EffectKind::kCentring, EffectKind::kDrift,
                       EffectKind::kReversal}) {
    for (std::size_t i = 0; i < design.installations.size(); ++i) {
      out.push_back(effect_block(design, readings, layout, {k, static_cast<int>(i)}));
    }
    // The same effect once for the whole test: a length change common to every reading (the
    // bar's own length), one drift on the test's clock, one reversal of every installation.
    if (effect_has_whole_test_form(k))
      out.push_back(effect_block(design, readings, layout, {k, -1}));
  }
  // Shared effects one parameter at a time: part of a scale or squareness can be
  // confounded (an isotropic scale is a length offset) while the rest is not.
  for (EffectKind k : {EffectKind::kScale, EffectKind::kSquareness}) {
    for (int c = 0; c < 3; ++c) out.push_back(effect_block(design, readings, layout, {k, -1, c}));
  }
  return out;
}

EffectBlock ScanFamily::alternative(const Design& design, const std::vector<Reading>& readings,
                                    int k) const {
  if (effect.kind != EffectKind::kStep) return alternatives.at(static_cast<std::size_t>(k));
  EffectBlock b;
  b.effect = effect;
  const Reading& first =
      readings.at(static_cast<std::size_t>(rows.at(static_cast<std::size_t>(k))));
  if (timed) b.effect.at_s = *first.time_s;
  b.label = b.effect.label(design);
  if (!timed)
    b.label +=
        "(from reading " + std::to_string(k + 1) + " of " + std::to_string(rows.size()) + ")";
  b.unit = effect_unit(effect.kind);
  b.parameters = {"value"};
  b.J_reading_effect = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(readings.size()), 1);
  for (std::size_t j = static_cast<std::size_t>(k); j < rows.size(); ++j)
    b.J_reading_effect(rows[j], 0) = 1.0;
  return b;
}

std::vector<ScanFamily> scan_families(const Design& design, const std::vector<Reading>& readings) {
  std::vector<ScanFamily> out;
  const auto index = design.installation_index();
  std::vector<std::vector<int>> rows(design.installations.size());
  for (std::size_t j = 0; j < readings.size(); ++j)
    rows[index.at(readings[j].installation)].push_back(static_cast<int>(j));
  for (std::size_t i = 0; i < design.installations.size(); ++i) {
    ScanFamily f;
    f.effect.kind = EffectKind::kStep;
    f.effect.installation = static_cast<int>(i);
    f.label = f.effect.label(design);
    f.rows = rows[i];
    f.timed = !f.rows.empty() && std::all_of(f.rows.begin(), f.rows.end(),
                                             [&](int j) { return readings[j].time_s.has_value(); });
    if (f.timed) {
      std::stable_sort(f.rows.begin(), f.rows.end(),
                       [&](int a, int b) { return *readings[a].time_s < *readings[b].time_s; });
    }
    if (static_cast<int>(f.rows.size()) < 2 * f.min_segment) {
      f.applicability = {NotApplicable::kTooFewReadings, 2 * f.min_segment};
    }
    out.push_back(f);
  }
  ScanFamily th;
  th.effect.kind = EffectKind::kThermal;
  th.label = th.effect.label(design);
  th.label = th.label.substr(0, th.label.find('('));
  double t0 = std::numeric_limits<double>::infinity(), t1 = -t0;
  bool all_timed = !readings.empty();
  for (const Reading& r : readings) {
    if (!r.time_s) {
      all_timed = false;
      break;
    }
    t0 = std::min(t0, *r.time_s), t1 = std::max(t1, *r.time_s);
  }
  if (!all_timed) {
    th.applicability.why = NotApplicable::kNeedsEveryTime;
  } else if (!(t1 > t0)) {
    th.applicability.why = NotApplicable::kNeedsSeveralTimes;
  } else {
    const double T_min = (t1 - t0) / 60.0;
    const ReadingLayout layout(design, readings);
    for (int k = 0; k < kThermalTaus; ++k) {
      EffectCandidate c = th.effect;
      c.tau_min = T_min / 20.0 * std::pow(40.0, k / double(kThermalTaus - 1));
      th.alternatives.push_back(effect_block(design, readings, layout, c));
    }
  }
  out.push_back(th);
  return out;
}

}  // namespace dbbkit
