#pragma once
// Output of `optimize`: the design file it writes, the result JSON
// (`dbbkit.optimize/1`), the terminal summary and the Pareto front as CSV.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "dbbkit/io/text.hpp"
#include "dbbkit/kit.hpp"
#include "dbbkit/optimize.hpp"

namespace dbbkit::io {

// A design the kit's best candidate stands for, with its prediction and a
// description of how it was found (identify and evaluate accept it as it is).
Design optimized_design(const Kit& kit, const OptimizeResult& res, const std::string& kit_file);

nlohmann::json optimize_to_json(const Kit& kit, const OptimizeResult& res,
                                const std::string& kit_file, double seconds,
                                const std::optional<Reference>& reference);
// optimize's first screen: the best design (installations, step, readings, time), its worst
// standard uncertainty (with the kit's set-up tolerances, or what typical ones would make it),
// against the reference, the angle step's meaning, and what to do next; at most six sentences.
std::vector<BriefItem> optimize_brief(const Kit& kit, const OptimizeResult& res,
                                      const std::optional<Reference>& reference);
std::string optimize_summary(const Kit& kit, const OptimizeResult& res, const std::string& kit_file,
                             double seconds, const std::optional<Reference>& reference,
                             bool pareto);
std::string pareto_csv(const Kit& kit, const OptimizeResult& res);
// What became of a choice, in words: "searched", or which constraint binds with its figures
// ("over the time budget (2100 s > 1800 s)").
std::string choice_status_text(const Kit& kit, const ChoiceResult& cr);
// Why no design fits the kit, in one line (binding_constraints in words): "the shortest design,
// 7 installations x 240 s + 63 readings x 3 s = 1869 s, already exceeds the time budget of
// 1000 s"; with several constraints, each with its count of choices.
std::string binding_text(const Kit& kit, const OptimizeResult& res);
// The same from constraints already found (binding_constraints(kit, res)).
std::string binding_text(const Kit& kit, const OptimizeResult& res,
                         const std::vector<BindingConstraint>& binding);
// What rounding the best to the kit's resolution changed, in one sentence; empty without it.
std::string rounding_text(const OptimizeResult& res);
// How a design's time adds up: "[3 positions x 60 s + ]7 installations x 240 s + 63 readings
// x 3 s".
std::string time_sum(const Kit& kit, int positions, int installations, int readings);
// The kit's set-up detection requirement as met by a candidate, in words (one sentence).
std::string detection_text(const Candidate::Detection& d);
// A drift over the whole test (the best design's, on the kit's clock: OptimizeResult::
// best_evaluation): its detection limit and what 1 um of it undetected moves most (setup.hpp,
// DriftCheck); a probe's: not checked (its file has no time column).
std::string drift_text(const DriftChecks& d, InstrumentKind instrument = InstrumentKind::kBallbar);

// Why the design found stays at rank 5 (OptimizeResult::rank_five), in words; empty when it
// does not.
std::string rank_five_note(const Kit& kit, const OptimizeResult& res);

}  // namespace dbbkit::io
