#pragma once
// What makes a stated uncertainty unreliable for these inputs (formats.md, "Results:
// warnings"): identify, diagnose and evaluate carry a list of them, empty when nothing does;
// the terminal and the reports show them first, and each says what to do.
//   residual          the residual contradicts the declared noise (chi2 test at kWarningLevel)
//   first_order       the neglected second-order term can bias an error by a standard
//                     uncertainty or more (FirstOrderCheck)
//   setup_undeclared  set-up effects without a declared tolerance that the readings cannot
//                     tell from the axis errors move determined errors, unseen in the residual
//   noise_scale       (diagnose) after the effects found, the residual is still too large

#include <optional>
#include <string>
#include <vector>

#include "dbbkit/estimate.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/setup.hpp"
#include "dbbkit/warning.hpp"

namespace dbbkit {

// The false-alarm rate of the residual warning on data that follow the model at the declared
// noise: the chi2 test's level (diagnose's default level).
inline constexpr double kWarningLevel = 0.01;

// The residual of `est` against the declared noise; type_a: the uncertainties are stated from
// the scatter (identify --type-a).
std::optional<Warning> residual_warning(const Estimate& est, bool type_a);
std::optional<Warning> first_order_warning(const FirstOrderCheck& check);
// A set-up effect without a declared tolerance that the readings cannot tell from the axis
// errors in some direction v (the fit of its columns X_e by the model leaves W^1/2 (X_e v -
// J G X_e v) = 0), and the most that direction moves a determined error: |c'G X_e V_null| per
// um (angular errors at the reference length), where.
struct HiddenSetupEffect {
  std::string label;
  double bias_um_per_um = 0;
  int error = 0;
  double angle_deg = 0;
  // The effect's parameters: of several, the bias is that of the direction no reading sees (the
  // set-up checks state the largest over every direction, which may be more).
  int parameters = 1;
};
// instrument: the design's (the keys of its set-up tolerances in the text).
std::optional<Warning> setup_undeclared_warning(const std::vector<HiddenSetupEffect>& hidden,
                                                double reference_length_mm,
                                                InstrumentKind instrument);

// diagnose's warnings: the residual after the effects found (noise_scale when no check explains
// it, residual otherwise). Declared in diagnose.hpp's terms to keep this header light.
struct DiagnoseResult;
std::vector<Warning> diagnose_warnings(const DiagnoseResult& result);

// identify's warnings (residual, first order, undeclared set-up).
std::vector<Warning> identify_warnings(const Design& design, const IdentifyResult& result);

}  // namespace dbbkit
