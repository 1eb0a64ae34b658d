#pragma once
// Result JSON (formats.md "Keys every result JSON carries") and the
// human-readable summaries printed on the terminal.

#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/diagnose.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/measurement.hpp"
#include "dbbkit/monte_carlo.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/warning.hpp"

namespace dbbkit::io {

struct InputFiles {
  std::string design, data;
};

// The effects fitted with the errors (identify --effects) as terminal lines (empty without
// effects).
std::string fitted_effects_text(const std::vector<FittedEffect>& effects);

// `dbbkit.identify/1`. Without `with_readings` the per-reading rows (key "readings") are
// left out, for json_text to write them one at a time.
nlohmann::json identify_to_json(const Design& design, const std::vector<Reading>& readings,
                                const IdentifyResult& result, const InputFiles& inputs,
                                const MonteCarloResult* mc = nullptr, bool with_readings = true);
// Row i of the "readings" array of `dbbkit.identify/1`: the reading, the fitted value and
// the residual as the instrument counted (the installation's reading_sign).
nlohmann::json identify_reading_row(const Design& design, const std::vector<Reading>& readings,
                                    const Estimate& est, std::size_t i);

// j.dump(2) with an array of `count` rows, row(i) each, under `key` (absent from j): the
// same text as with the array in j, without holding the rows as JSON nodes at once (about
// 1.5 kB of nodes per reading row against 0.15 kB of text).
std::string json_text(const nlohmann::json& j, const std::string& key, std::size_t count,
                      const std::function<nlohmann::json(std::size_t)>& row);

// The JCGM 100 budget block and the JCGM 101 block.
nlohmann::json budget_to_json(const Design& design, const Budget& budget);
nlohmann::json monte_carlo_to_json(const MonteCarloResult& mc);
std::string monte_carlo_summary(const MonteCarloResult& mc);

// formats.md "Results: warnings": [{"kind", "text"}], empty when nothing makes a stated
// uncertainty unreliable.
nlohmann::json warnings_to_json(const std::vector<Warning>& warnings);
// "WARNING: <text>" per line, for the terminal's first lines; empty without warnings.
std::string warnings_text(const std::vector<Warning>& warnings);

// `dbbkit.evaluate/1`.
// What the design can tell of each set-up effect (setup.hpp) as JSON and as text.
nlohmann::json setup_checks_to_json(const std::vector<SetupEffectCheck>& checks,
                                    double reference_length_mm);
// What an undetected drift or warm-up over the whole test does (Evaluation::drift), and what a
// return reading would change; empty when the test has one time only.
std::string drift_checks_text(const Evaluation& ev);
nlohmann::json drift_checks_to_json(const DriftChecks& d, double reference_length_mm);
// " as a whole: the axis errors take (dL, dD, dH) = (0.13, -0.42, 0.9)" for a set-up effect of
// several parameters that is not detectable as a whole (SetupEffectCheck::hidden_directions);
// empty otherwise.
std::string hidden_directions_text(const SetupEffectCheck& c);
std::string setup_checks_text(const std::vector<SetupEffectCheck>& checks,
                              const DetectionSettings& detection);

nlohmann::json evaluate_to_json(const Design& design, const Evaluation& ev,
                                const std::string& design_file,
                                const MonteCarloResult* mc = nullptr);
std::string evaluate_summary(const Design& design, const Evaluation& ev);
// evaluate's first screen: whether the design determines every error, the worst standard
// uncertainty (with the declared set-up tolerances, or what typical ones would make it), and
// what to do next; at most six sentences (text.hpp).
std::vector<BriefItem> evaluate_brief(const Design& design, const Evaluation& ev);
// The effects a design can tell from the axis errors (effect_detectability): label, status, detail.
nlohmann::json effects_to_json(const std::vector<CandidateStatus>& effects);
// The effects a design can tell from the axis errors, on the terminal: one line per state.
std::string effects_summary(const Design& design, const std::vector<CandidateStatus>& effects);

// "rms .. um, chi2 .. on .. dof, p .." for the terminal.
std::string residual_text(const Estimate& est);

// Aligned tables with units.
std::string errors_table(const std::vector<ErrorsAtAngle>& errors, bool values);
std::string unidentifiable_text(const std::vector<Unidentifiable>& list);
std::string identify_summary(const Design& design, const IdentifyResult& result);
// identify's first screen: determined or not, the location errors with U (k = 2), the worst
// standard uncertainty, whether the residual bears the stated uncertainties out, and what to
// do next; at most six sentences (text.hpp).
std::vector<BriefItem> identify_brief(const Design& design, const IdentifyResult& result);
// "2.06 um (dy at 180 deg; angular errors x 100 mm)"; empty when nothing is determined.
std::string worst_phrase(const WorstCase& w, double reference_length_mm);
// The ISO 230-7 quantities of an identification (iso230.hpp): JSON and the terminal's text.
nlohmann::json iso230_to_json(const IdentifyResult& result);
std::string iso230_text(const Design& design, const IdentifyResult& result);
// The same of any ISO result (diagnose's corrected errors), with what its uncertainty holds.
nlohmann::json iso230_to_json(const IsoResult& iso, const std::string& uncertainty_note);
std::string iso230_text(const Design& design, const IsoResult& iso, const std::string& note);

// The words of the structured results (the library builds none):
// "full rank: 42 unknowns from 49 readings", "rank 40 of 42: 2 combination(s) ...".
std::string estimate_message(const Estimate& est);
// "12 of 12 values: the linear (GUM) interval is validated by Monte Carlo ...".
std::string monte_carlo_message(const MonteCarloResult& mc);
// What the uncertainties of identify, evaluate and the ISO 230-7 quantities include.
std::string identify_setup_note(const IdentifyResult& r);
std::string evaluation_setup_note(const Evaluation& ev);
std::string iso_uncertainty_note(const IdentifyResult& r);
// How the reading noise was evaluated: "Type A (residual, 25 degrees of freedom)" or "Type B
// (declared instrument: rectangular +-1.25 um ...)".
std::string noise_evaluation_text(const Budget& b);
// Why error motion value `index` (in the order of the component names) was not computed.
std::string iso_motion_reason(const IsoMotionValue& v, int index);
// How the error motion values were computed.
std::string iso_motion_note(const IsoMotionValues& mv);
// What a block of the ISO 230-7 fit could not determine; empty when nothing.
std::string iso_gaps_note(const IsoResult& iso);
// Why the first-order check was not computed.
std::string first_order_reason(const FirstOrderCheck& f);
// A combination no reading sees: "0.7071 ex - 0.7071 ez", and the rigid motion it stands for:
// "a rotation about the line through (0, 0, 0) mm along (0, 0, 1) (machine frame); ...".
std::string unidentifiable_expression(const Unidentifiable& u);
std::string rigid_motion_text(const RigidMotion& m);
std::string unidentifiable_interpretation(const Unidentifiable& u);  // empty without a motion

}  // namespace dbbkit::io
