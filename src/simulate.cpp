#include "dbbkit/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <random>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/iso230.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/parameterisation.hpp"
#include "dbbkit/program.hpp"
#include "dbbkit/setup_sheet.hpp"
#include "dbbkit/user_text.hpp"
#include "number_text.hpp"

namespace dbbkit {

Vector6d given_errors(const Truth& truth, const AxisFrame& axis, double angle_deg,
                      const std::string& source);

namespace {

// The errors the location of the axis adds at angle_deg (iso230.md); unknown names throw.
Vector6d location_errors(const Truth& truth, const AxisFrame& axis, double angle_deg,
                         const std::string& source) {
  Vector6d e = Vector6d::Zero();
  if (truth.location.empty()) return e;
  const IsoNames names = iso230_names(axis);
  const IsoFrame f = iso_frame(axis);
  std::array<double, 5> v{};
  for (const auto& [name, value] : truth.location) {
    const auto it = std::find(names.location.begin(), names.location.end(), name);
    if (it == names.location.end()) {
      std::string known;
      for (const std::string& n : names.location) known += (known.empty() ? "" : ", ") + n;
      const bool letter_o = name.size() == 3 && name[1] == 'O';
      throw InputError(source, "location." + name,
                       quote_value(name) + " is not a location error of axis " + axis.label() +
                           " (one of " + known + "; um for positions, urad for angles)" +
                           (letter_o ? "; ISO 230-1 writes the digit zero, not the letter O" : ""));
    }
    v[static_cast<std::size_t>(it - names.location.begin())] = value;
  }
  const Eigen::Matrix3d IR = Eigen::Matrix3d::Identity() - axis_rotation(axis, angle_deg);
  e.head<3>() = IR * (v[0] * f.p1 + v[1] * f.p2);
  e.tail<3>() = IR * (v[2] * f.p1 + v[3] * f.p2) + v[4] * f.q;
  return e;
}

}  // namespace

Vector6d truth_errors(const Truth& truth, const AxisFrame& axis, double angle_deg,
                      const std::string& source) {
  const Vector6d located = location_errors(truth, axis, angle_deg, source);
  if (!truth.errors_given) return located;
  return located + given_errors(truth, axis, angle_deg, source);
}

Vector6d given_errors(const Truth& truth, const AxisFrame& axis, double angle_deg,
                      const std::string& source) {
  if (truth.model.kind == ErrorModel::Kind::kPerAngle) {
    for (const auto& [a, e] : truth.per_angle) {
      if (same_position(axis, a, angle_deg)) return e;
    }
    std::ostringstream s;
    s << "no errors given at angle " << angle_deg << " deg, a position of the design";
    throw InputError(source, "errors.values", s.str());
  }
  Eigen::VectorXd f;
  if (truth.model.kind == ErrorModel::Kind::kFourier) {
    f = fourier_basis(truth.model.order, angle_deg);
  } else {
    const auto [lo, hi] = *truth.range_deg;
    f = legendre_basis(truth.model.order, 2.0 * (angle_deg - lo) / (hi - lo) - 1.0);
  }
  Vector6d e;
  for (int k = 0; k < 6; ++k) {
    e(k) = f.dot(Eigen::Map<const Eigen::VectorXd>(truth.coefficients[k].data(), f.size()));
  }
  return e;
}

void validate_truth(const Truth& truth, const Design& design, const std::string& source) {
  if (truth.repeats < 1) throw InputError(source, "repeats", "must be an integer >= 1");
  if (truth.exact) {
    if (truth.bar_mm && !(length_within_limits(*truth.bar_mm) && *truth.bar_mm > 0)) {
      throw InputError(source, "bar_mm", "must be a positive length in mm, at most 10000 mm");
    }
    if (design.instrument == InstrumentKind::kProbe &&
        (!truth.setup_given.empty() || truth.setup_draw.length_offset_um > 0 ||
         truth.setup_draw.centring_um > 0 || (truth.setup_draw.ball_mm.array() != 0).any()))
      throw InputError(source, "setup",
                       "a probe's set-up is simulated as its effects: placement[sphere] and "
                       "trigger_offset[sphere:x] in \"effects\"");
    for (size_t i = 0; i < design.installations.size(); ++i) {
      if (!design.installations[i].probe_channel() && !design.installations[i].bar_mm &&
          !truth.bar_mm) {
        throw InputError(source, "geometry",
                         "the exact geometry needs the bar: installation '" +
                             design.installations[i].id +
                             "' of the design has no bar_mm, and the truth gives no bar_mm");
      }
    }
  } else if (!truth.setup_given.empty() || truth.setup_draw.length_offset_um > 0 ||
             truth.setup_draw.centring_um > 0 || (truth.setup_draw.ball_mm.array() != 0).any()) {
    throw InputError(source, "setup", "set-up errors need \"geometry\": \"exact\"");
  }
  for (const auto& [id, given] : truth.setup_given) {
    if (design.find_installation(id) < 0) {
      throw InputError(source, "setup.installations." + id,
                       "installation " + quote_value(id) + " is not in the design");
    }
    if (!design.axis.has_H() && given.ball_mm(2) != 0) {
      throw InputError(source, "setup.installations." + id + ".ball_mm.H",
                       "H is not used for the swinging head B");
    }
  }
  if (truth.model.order > limits::kMaxSeriesOrder) {
    throw InputError(source, "errors.order",
                     "must be at most " + std::to_string(limits::kMaxSeriesOrder));
  }
  if (truth.noise) validate_noise_and_model(*truth.noise, ErrorModel{}, design.axis, source);
  // Every error value (um or urad) within +-1e6: a larger one leaves the first-order model.
  auto check_value = [&](double v, const std::string& key) {
    if (!std::isfinite(v) || std::abs(v) > 1e6)
      throw InputError(source, key, "must be a finite value within +-1e6 (um or urad)");
  };
  for (size_t i = 0; i < truth.per_angle.size(); ++i) {
    for (int k = 0; k < 6; ++k) {
      check_value(truth.per_angle[i].second(k),
                  "errors.values[" + std::to_string(i) + "]." + kErrorNames[k]);
    }
  }
  for (int k = 0; k < 6; ++k) {
    for (size_t i = 0; i < truth.coefficients[k].size(); ++i) {
      check_value(truth.coefficients[k][i], std::string("errors.coefficients.") + kErrorNames[k] +
                                                "[" + std::to_string(i) + "]");
    }
  }
  {
    // One value per position: an angle given twice (C: modulo 360) is ambiguous.
    std::vector<std::pair<double, size_t>> keys;
    for (size_t i = 0; i < truth.per_angle.size(); ++i) {
      double a = truth.per_angle[i].first;
      if (design.axis.full_turn()) a = std::fmod(std::fmod(a, 360.0) + 360.0, 360.0);
      keys.emplace_back(a, i);
    }
    std::sort(keys.begin(), keys.end());
    for (size_t k = 0; k < keys.size(); ++k) {
      const size_t j = k == 0 ? keys.size() - 1 : k - 1;
      const auto& a = truth.per_angle[keys[k].second];
      const auto& b = truth.per_angle[keys[j].second];
      if (keys.size() > 1 && j != k && same_position(design.axis, a.first, b.first) &&
          a.second != b.second) {
        const size_t hi = std::max(keys[k].second, keys[j].second),
                     lo = std::min(keys[k].second, keys[j].second);
        throw InputError(
            source, "errors.values[" + std::to_string(hi) + "].angle_deg",
            "the same position as errors.values[" + std::to_string(lo) + "] with other values");
      }
    }
  }
  if (truth.schedule) {
    const std::vector<Sweep>& sw = truth.schedule->sweeps;
    if (sw.size() > limits::kMaxSweeps) {
      throw InputError(
          source, "schedule.sweeps",
          "more than " + std::to_string(limits::kMaxSweeps) + " sweeps per installation");
    }
    if (!std::isfinite(truth.schedule->per_reading_s) ||
        !std::isfinite(truth.schedule->per_installation_s) || truth.schedule->per_reading_s > 1e6 ||
        truth.schedule->per_installation_s > 1e6) {
      throw InputError(source, "schedule", "times must be finite, at most 1e6 s");
    }
  }
  {
    const double sweeps = truth.schedule ? static_cast<double>(truth.schedule->sweeps.size()) : 1.0;
    const double n = static_cast<double>(design.readings_per_round()) * sweeps * truth.repeats;
    if (n > static_cast<double>(limits::kMaxReadings)) {
      throw InputError(source, "repeats",
                       "the simulation would make more than " +
                           std::to_string(limits::kMaxReadings) +
                           " readings (docs/formats.md, \"Limits\")");
    }
  }
  for (std::size_t i = 0; i < truth.effects.size(); ++i) {
    const TruthEffect& e = truth.effects[i];
    const std::string key = "effects[" + std::to_string(i) + "]";
    if (effect_is_shared(e.effect.kind) && !e.installation.empty()) {
      throw InputError(source, key + ".installation",
                       "a shared effect applies to every installation: no installation");
    }
    if (!effect_is_shared(e.effect.kind) && !effect_has_whole_test_form(e.effect.kind) &&
        e.installation.empty()) {
      throw InputError(source, key + ".installation",
                       "this effect needs the installation it applies to");
    }
    if (!e.installation.empty() && effect_installation(design, e.effect.kind, e.installation) < 0) {
      const bool sphere_given =
          !effect_info(e.effect.kind).per_sphere && find_sphere(design, e.installation) >= 0;
      throw InputError(source, key + ".installation",
                       (effect_info(e.effect.kind).per_sphere ? "sphere " : "installation ") +
                           quote_value(e.installation) + " is not in the design" +
                           (sphere_given ? " (a sphere: this effect is one channel's, e.g. " +
                                               probe_channel_id(e.installation, 0) + ")"
                                         : std::string()));
    }
    if (!effect_fits_instrument(e.effect.kind, design.instrument)) {
      throw InputError(source, key + ".name",
                       std::string(effect_name(e.effect.kind)) + " is not an effect of " +
                           instrument_info(design.instrument).noun);
    }
    const EffectInfo& info = effect_info(e.effect.kind);
    if (info.needs_bar) {
      for (const Installation& in : design.installations) {
        if (!in.bar_mm)
          throw InputError(source, key,
                           std::string(effect_name(e.effect.kind)) +
                               " needs bar_mm on every installation of the design");
      }
    }
    if (info.needs_times && !truth.schedule) {
      throw InputError(
          source, key,
          std::string(effect_name(e.effect.kind)) + " needs a schedule (the readings' times)");
    }
    if (info.whole_test_only && !e.installation.empty()) {
      throw InputError(source, key + ".installation",
                       std::string(effect_name(e.effect.kind)) + " is " + info.noun +
                           " of the whole test: no installation");
    }
    if (info.position == EffectPosition::kTime && !std::isfinite(e.effect.at_s)) {
      throw InputError(source, key + ".value.at_s",
                       std::string(info.noun) + " needs the time it happens (s, the test's clock)");
    }
    if (info.needs_both_sweeps && (!truth.schedule || truth.schedule->sweeps.size() < 2)) {
      throw InputError(
          source, key,
          std::string(effect_name(e.effect.kind)) + " needs a schedule with both sweeps");
    }
  }
  if (truth.schedule) {
    if (!(truth.schedule->per_reading_s >= 0) || !(truth.schedule->per_installation_s >= 0)) {
      throw InputError(source, "schedule", "times must be >= 0 s");
    }
    if (truth.schedule->sweeps.empty())
      throw InputError(source, "schedule.sweeps", "needs at least one sweep");
  }
  for (const auto& [name, v] : truth.location) check_value(v, "location." + name);
  if (!design.angles_deg.empty())
    location_errors(truth, design.axis, design.angles_deg.front(), source);
  if (!truth.errors_given) return;
  if (truth.model.kind == ErrorModel::Kind::kPerAngle) {
    for (double a : design.angles_deg) truth_errors(truth, design.axis, a, source);
    // A value at an angle the design never measures would be ignored without a word (a truth
    // of another design, or an angle mistyped).
    const Parameterisation positions(design);
    const auto [lo, hi] = std::minmax_element(design.angles_deg.begin(), design.angles_deg.end());
    for (std::size_t i = 0; i < truth.per_angle.size(); ++i) {
      const double a = truth.per_angle[i].first;
      if (positions.station_of(a) >= 0) continue;
      throw InputError(source, "errors.values[" + std::to_string(i) + "].angle_deg",
                       "angle " + text::significant(a, 12) +
                           " deg is not a position of the design (its " +
                           std::to_string(design.angles_deg.size()) + " angles, " +
                           text::significant(*lo, 12) + " .. " + text::significant(*hi, 12) +
                           " deg): a value there would be ignored; give values at the "
                           "design's angles alone");
    }
    return;
  }
  if (truth.model.kind == ErrorModel::Kind::kFourier && !design.axis.full_turn()) {
    throw InputError(source, "errors.model",
                     "a Fourier truth is for a full-turn axis; axis " + design.axis.label() +
                         " turns through an arc: use \"legendre\"");
  }
  if (truth.model.kind == ErrorModel::Kind::kLegendre) {
    if (!truth.range_deg || !(truth.range_deg->second > truth.range_deg->first)) {
      throw InputError(source, "errors.range_deg",
                       "a Legendre truth needs its range [min, max] with max > min");
    }
    // A series is a truth over its range only: beyond it a polynomial is extrapolated.
    for (double a : design.angles_deg) {
      if (a < truth.range_deg->first - kAngleTolerance_deg ||
          a > truth.range_deg->second + kAngleTolerance_deg) {
        throw InputError(source, "errors.range_deg",
                         "the design measures at " + text::significant(a, 12) +
                             " deg, outside the truth's range [" +
                             text::significant(truth.range_deg->first, 12) + ", " +
                             text::significant(truth.range_deg->second, 12) +
                             "] deg: a Legendre series is not extrapolated");
      }
    }
  }
  const size_t m = static_cast<size_t>(coefficients_per_error(truth.model));
  for (int k = 0; k < 6; ++k) {
    if (truth.coefficients[k].size() != m) {
      throw InputError(source, std::string("errors.coefficients.") + kErrorNames[k],
                       "expected " + std::to_string(m) + " coefficients for " +
                           truth.model.describe() + ", got " +
                           std::to_string(truth.coefficients[k].size()));
    }
  }
}

std::vector<SetupError> simulated_setup_errors(const Design& design, const Truth& truth,
                                               std::uint64_t seed) {
  std::vector<SetupError> out(design.installations.size());
  if (!truth.exact) return out;
  std::mt19937_64 rng(seed ^
                      0x5e7a9ull);  // a stream of its own: the noise draws stay as without set-up
  std::normal_distribution<double> n01;
  const Truth::SetupDraw& s = truth.setup_draw;
  for (SetupError& e : out) {
    e.length_offset_um = s.length_offset_um * n01(rng);
    for (int k = 0; k < 3; ++k) e.centring_um(k) = s.centring_um * n01(rng);
    for (int k = 0; k < 3; ++k) e.ball_mm(k) = s.ball_mm(k) * n01(rng);
    if (!design.axis.has_H()) e.ball_mm(2) = 0;
  }
  for (const auto& [id, given] : truth.setup_given) {
    const int i = design.find_installation(id);
    if (i >= 0) out[static_cast<size_t>(i)] = given;
  }
  return out;
}

std::vector<Reading> simulate(const Design& design, const Truth& truth, std::uint64_t seed) {
  validate_truth(truth, design);
  std::mt19937_64 rng(seed);
  const NoiseModel noise = truth.noise.value_or(design.noise);
  std::uniform_real_distribution<double> uniform(-noise.half_width_um, noise.half_width_um);
  std::normal_distribution<double> normal(0.0, noise.std_um);
  auto draw = [&]() -> double {
    if (truth.noiseless) return 0.0;
    return noise.distribution == NoiseModel::Distribution::kUniform ? uniform(rng) : normal(rng);
  };

  std::vector<Reading> out;
  double t = 0;
  const std::vector<Sweep> sweeps =
      truth.schedule ? truth.schedule->sweeps : std::vector<Sweep>{Sweep::kCCW};
  // The readings are written in design order; the clock runs the installations in the order a
  // program runs them (run_rank).
  std::vector<double> start(design.installations.size(), 0.0);
  if (truth.schedule) {
    std::vector<double> duration(design.installations.size());
    for (std::size_t i = 0; i < duration.size(); ++i) {
      const std::size_t n = design.angles_of(static_cast<int>(i)).size();
      const std::size_t per_sweep =
          n * static_cast<std::size_t>(truth.repeats) + (design.return_reading && n > 1 ? 1 : 0);
      duration[i] = static_cast<double>(per_sweep * sweeps.size()) * truth.schedule->per_reading_s +
                    truth.schedule->per_installation_s;
    }
    start = run_starts(design, duration);
  }
  for (std::size_t i = 0; i < design.installations.size(); ++i) {
    const Installation& inst = design.installations[i];
    t = start[i];
    // A sweep direction run again (ccw, cw, ccw) continues its repeats' numbering, so that no two
    // readings of one installation, angle and sweep share a repeat number.
    int ccw_runs = 0, cw_runs = 0;
    for (Sweep sweep : sweeps) {
      const int run = sweep == Sweep::kCW ? cw_runs++ : ccw_runs++;
      std::vector<double> angles = design.angles_of(static_cast<int>(i));
      if (sweep == Sweep::kCW) std::reverse(angles.begin(), angles.end());
      for (double a : angles) {
        for (int r = 0; r < truth.repeats; ++r) {
          Reading reading;
          reading.installation = inst.id;
          reading.angle_deg = a;
          if (truth.repeats > 1) reading.repeat = run * truth.repeats + r;
          if (truth.schedule) {
            reading.time_s = t;
            reading.sweep = sweep;
            t += truth.schedule->per_reading_s;
          }
          out.push_back(reading);
        }
      }
      if (design.return_reading && angles.size() > 1) {
        // The program's sweep's first angle once more, approached the other way
        // (sweep_readings: the smallest angle for ccw, whatever the design's order).
        Reading reading;
        reading.installation = inst.id;
        reading.angle_deg = sweep_readings(design, static_cast<int>(i), sweep).back().angle_deg;
        if (truth.schedule) {
          reading.time_s = t;
          reading.sweep = opposite(sweep);
          t += truth.schedule->per_reading_s;
        }
        out.push_back(reading);
      }
    }
  }
  const std::vector<double> t0 = installation_start_times(design, out);
  const double t_test = test_start_time(out);
  const auto index = design.installation_index();
  const std::vector<SetupError> setup = simulated_setup_errors(design, truth, seed);
  for (Reading& reading : out) {
    const int i = index.at(reading.installation);
    const Installation& inst = design.installations[i];
    const Vector6d errors = truth_errors(truth, design.axis, reading.angle_deg);
    double value = 0;
    if (truth.exact) {
      value =
          exact_instrument_reading_um(design.axis, inst, reading.angle_deg, errors,
                                      inst.bar_mm.value_or(truth.bar_mm.value_or(0.0)), setup[i]);
    } else {
      value = J_reading_error(design.axis, inst, reading.angle_deg) * errors;
    }
    for (const TruthEffect& e : truth.effects) {
      EffectCandidate c = e.effect;
      c.installation =
          e.installation.empty() ? -1 : effect_installation(design, c.kind, e.installation);
      value +=
          J_reading_effect(design, reading, i, c.installation < 0 ? t_test : t0[i], c).dot(e.value);
    }
    reading.reading_um = value + draw();
    if (inst.reading_sign != 1)
      reading.reading_um *= inst.reading_sign;  // as the instrument counts
    // What the instrument could not read is not a reading: the truth is too large for the
    // design's instrument (identify would refuse the file).
    const double range_um = 1000.0 * design.instrument_range_mm;
    if (!std::isfinite(reading.reading_um) || std::abs(reading.reading_um) > range_um) {
      std::ostringstream m;
      m << std::setprecision(6) << "the truth gives installation " << inst.id << " at "
        << reading.angle_deg << " deg a reading of " << reading.reading_um
        << " um, beyond the instrument's range of +-" << design.instrument_range_mm
        << " mm (the design's instrument.range_mm): smaller errors or effects";
      throw InputError("truth", "", m.str());
    }
  }
  return out;
}

}  // namespace dbbkit
