#pragma once
// Fixtures shared by the diagnose tests: truth effects, the check that an effect was
// added, and the placement of a step halfway through its installation.

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "dbbkit/diagnose.hpp"
#include "dbbkit/simulate.hpp"

namespace dbbkit::test {

inline TruthEffect effect(EffectKind kind, const std::string& inst, std::vector<double> value,
                          int harmonic = 0) {
  TruthEffect e;
  e.effect.kind = kind;
  e.effect.harmonic = harmonic;
  e.installation = inst;
  e.value = Eigen::Map<Eigen::VectorXd>(value.data(), static_cast<Eigen::Index>(value.size()));
  return e;
}

// An added effect of that label; a scanned one (step, thermal) whatever its position: "step[2t]"
// matches "step[2t](t=1234s)".
inline bool has(const DiagnoseResult& r, const std::string& label) {
  return std::any_of(r.added.begin(), r.added.end(), [&](const AddedEffect& a) {
    return a.block.label == label || a.block.label.rfind(label + "(", 0) == 0;
  });
}

inline TruthEffect step(const std::string& inst, double size_um, double at_s = std::nan("")) {
  TruthEffect e = effect(EffectKind::kStep, inst, {size_um});
  e.effect.at_s = at_s;
  return e;
}

inline TruthEffect thermal(double plateau_um, double tau_min) {
  TruthEffect e = effect(EffectKind::kThermal, "", {plateau_um});
  e.effect.tau_min = tau_min;
  return e;
}

// A step without a time is placed halfway through its installation's readings (by time).
inline std::vector<TruthEffect> placed(const Design& d, const Truth& t,
                                       std::vector<TruthEffect> effects) {
  for (TruthEffect& e : effects) {
    if (e.effect.kind != EffectKind::kStep || std::isfinite(e.effect.at_s)) continue;
    Truth quiet = t;
    quiet.effects.clear();
    std::vector<double> times;
    for (const Reading& r : simulate(d, quiet, 1)) {
      if (r.installation == e.installation) times.push_back(*r.time_s);
    }
    std::sort(times.begin(), times.end());
    e.effect.at_s = times.at(times.size() / 2);
  }
  return effects;
}

// Over `seeds` clean simulations (truth(rng) each, noise seeds seed0, seed0 + 1, ...): how many
// added nothing, and how many left a significant residual.
template <class TruthFn>
std::pair<int, int> clean_runs(const Design& d, TruthFn truth, std::mt19937_64& rng, int seeds,
                               std::uint64_t seed0) {
  int clean = 0, flagged = 0;
  for (int s = 0; s < seeds; ++s) {
    const DiagnoseResult r =
        diagnose(d, simulate(d, truth(d, rng), seed0 + static_cast<std::uint64_t>(s)));
    clean += r.added.empty();
    flagged += r.significant_after;
  }
  return {clean, flagged};
}

// Counts the determined errors after and those within 3 standard uncertainties of the truth.
inline void count_errors_within_3u(const DiagnoseResult& r, const Truth& t, const AxisFrame& axis,
                                   double& inside, double& total) {
  for (const ErrorsAtAngle& ea : r.errors_after) {
    const Vector6d truth = truth_errors(t, axis, ea.angle_deg);
    for (int k = 0; k < 6; ++k) {
      if (!ea.errors[k].determined) continue;
      inside += std::abs(ea.errors[k].value - truth(k)) <= 3 * ea.errors[k].std;
      ++total;
    }
  }
}

}  // namespace dbbkit::test
