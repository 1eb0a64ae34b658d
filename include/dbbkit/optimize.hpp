#pragma once
// The design search over a kit (model.md §7, formats.md "Kit file"): discrete
// choices (cushion-block stacks, angle step, whether a B design has its
// off-axis position) are enumerated; the continuous ball positions of each are
// searched by NLopt, a global derivative-free stage (DIRECT-L, deterministic; a
// point outside the travel, separation or detection constraints is scored as
// unscorable) followed by a local polish under the constraints (COBYLA). The minimax objective
// worst_std_um is non-smooth; both stages are derivative-free and never differentiate it.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/kit.hpp"
#include "dbbkit/observability.hpp"

namespace dbbkit {

// What is minimised. Worst: worst_std_um (evaluate); D: -log det M; A: trace
// M^-1; E: -(smallest eigenvalue of M); Condition: condition number of the
// equilibrated whitened Jacobian. Designs that leave more undetermined always
// rank behind designs that leave less, whatever the criterion.
// WorstTotal: worst_total_std_um, the worst case of the total (noise and the kit's
// declared set-up tolerances, setup.hpp).
enum class Criterion { kWorst, kD, kA, kE, kCondition, kWorstTotal };
const char* criterion_name(Criterion c);
// The criterion a command line or script names: worst, worst_total, D, A, E, condition.
// Throws InputError(source, "", ...) for any other name.
Criterion criterion_from_name(const std::string& name, const std::string& source);
// The criterion of a search over `kit` as a command line or a script asks for it: `name` (an
// empty one is no criterion's), or (none asked) worst_total where the kit declares set-up
// tolerances and worst elsewhere; with
// require_setup_detection, the kit is marked to require it. Throws InputError(kit_source,
// "setup_std", ...) when worst_total or set-up detection is asked of a kit that declares no set-up
// tolerance; `criterion_option` and `detection_option` are how the caller names the two
// ("--criterion", "require_setup_detection").
Criterion search_criterion(Kit& kit, const std::optional<std::string>& name,
                           bool require_setup_detection, const std::string& kit_source,
                           const std::string& criterion_option,
                           const std::string& detection_option);

// The continuous variables of a choice: names ("L1", "D3", ...) and bounds in mm.
struct PatternSpace {
  std::vector<std::string> names;
  std::vector<double> lower, upper;
};

// One discrete choice of the kit's pattern (kit.hpp, Pattern): the angle step, how many
// of the optional positions are added (the first n_optional offered, in order), and a
// height for each height variable of the positions included (C).
//   three_position, C: balls at (L1, D1, H1), (L2, D2, H1), (L3, D3, H3), radial +
//      tangential readings at each, the axial reading at (0, 0, H1); H1 != H3.
//   three_position, B: balls at (L1, 0) and (L2, 0) on the tool axis with radial,
//      tangential and axial readings; optionally a third at (L3, D3) off the axis with
//      radial + tangential (model.md §4: without it, rank 5 at every angle).
struct PatternChoice {
  double step_deg = 0;
  int n_optional = 0;
  struct Height {
    std::string variable;
    int stack = -1;  // index into block_stacks(kit)
    double height_mm = 0;
  };
  std::vector<Height> heights;  // in the order the variables first appear
  // Resolved once from the pattern (pattern_choices), so that a design is built without
  // looking names up: each position included, in pattern order, where its L, D and H come
  // from (an index into space, or -1: the position's fixed value, or on a table the
  // coordinate along its normal: `height`, the ball's coordinate for the height chosen); and
  // the continuous variables (the L variables first, then the D, then the H variables, each
  // in the order they first appear).
  struct Placement {
    int position = 0;  // index into kit.pattern.positions
    int L = -1, D = -1, H = -1;
    double height = 0;
  };
  std::vector<Placement> placements;
  PatternSpace space;
};

// A candidate design and how it scores.
struct Candidate {
  PatternChoice choice;
  std::vector<double> x;  // the continuous variables
  Design design;          // bars and signs fitted to the travel
  std::vector<int>
      installation_position;  // per installation: its position in kit.pattern.positions
  // <= 0: the following ball stays inside travel and the set-up clear of the kit's workspace
  // (kit.hpp installation_clashes), the larger of the two
  double travel_violation_mm = 0;
  double separation_violation_mm = 0;  // <= 0: ball positions at least min_separation apart
  // A kit that names its machine: why the machine's program refuses the design (its travel,
  // its table, a solid), or empty; travel_violation_mm then counts it as 1 mm outside.
  std::string machine_clash;
  double time_s = 0;
  bool feasible = false;  // inside travel, separation and the time budget
  WorstCase worst;
  int n_undetermined = 0;  // errors at angles the design cannot determine
  double objective = 0;    // of the criterion (smaller is better)
  bool objective_defined = false;
  // With kit.require_setup_detection (feasible only if every declared set-up effect is
  // detected at its declared size): the test the limits refer to (diagnose's level over
  // every candidate effect it could test on these readings, at least as many as it tests,
  // so evaluate's limits are at most these), and the effect with the largest ratio of its
  // detection limit to its declared standard uncertainty (infinity: the axis errors take it).
  struct Detection {
    DetectionSettings settings;
    double ratio = 0;
    std::string effect;              // its label, e.g. "centring[3t]"
    std::optional<double> limit_um;  // its detection limit
    double declared_std_um = 0;
    std::vector<std::string> undetectable;  // the effects the axis errors take
  };
  std::optional<Detection> detection;
};

// Searches the kit's discrete choices, the continuous positions of each, and
// returns the best per choice and overall. Deterministic: the same kit and
// options give the same result whatever the number of threads.
struct OptimizeOptions {
  Criterion criterion = Criterion::kWorst;
  int threads = 1;
  int global_evaluations_per_variable = 100;  // DIRECT-L budget: this x (variables + 1)
  int local_evaluations = 300;                // COBYLA budget per start
  // The most designs scored for one discrete choice (0: no limit beyond the two stage budgets
  // above). A choice whose search reaches it stops there and keeps its best point so far; its
  // ChoiceResult says so. The bound is per choice, so the result does not depend on the threads.
  long max_evaluations_per_choice = 0;
  // Called after each discrete choice is searched (from the worker threads, serialised).
  std::function<void(int done, int total, const Candidate* best_so_far)> progress;
};

// What became of a discrete choice. Only kSearched choices compete for the best; the others say
// which constraint binds, with the figures in ChoiceResult (io::choice_status_text in words).
enum class ChoiceState {
  kSearched,                // best: its best feasible design
  kOverTimeBudget,          // its shortest measurement (time_s) exceeds the kit's time budget
  kUndetectableEverywhere,  // the axis errors take a declared set-up effect at every position
                            // (best->detection->undetectable)
  kOutsideTravel,  // no position keeps the following ball inside travel (best->travel_violation_mm)
  kTooClose,       // no position keeps the balls min_separation_mm apart
  kSetupNotDetected,    // no position detects every declared set-up effect at its size
                        // (best->detection)
  kNoFeasiblePosition,  // none of the above, and no feasible position
};

// "searched", "over time budget", "undetectable everywhere", "outside travel", "too close",
// "set-up not detected", "no feasible position".
const char* choice_state_name(ChoiceState s);

struct ChoiceResult {
  PatternChoice choice;
  std::string label;  // e.g. "H1 = 45 mm, H3 = 145 mm (blocks 100), step 20 deg"
  ChoiceState state = ChoiceState::kNoFeasiblePosition;
  // The measurement time of the choice at its lower bounds [s] (kOverTimeBudget).
  double time_s = 0;
  std::optional<Candidate> best;
  bool budget_exhausted = false;  // the search stopped at max_evaluations_per_choice
};

struct OptimizeResult {
  Criterion criterion = Criterion::kWorst;
  std::vector<ChoiceResult> choices;
  // Absent when no choice is feasible. Between choices, objectives within 1e-4 (relative)
  // count as equal and the shorter measurement is taken; the Pareto front likewise.
  std::optional<Candidate> best;
  Evaluation best_evaluation;  // evaluate_design of the best (its drift on the kit's clock)
  std::vector<Candidate>
      pareto;            // non-dominated (time, objective) among the best's determination class
  long evaluations = 0;  // designs scored
  // Why a B design stays at rank 5 (a rotation about the tool axis unobservable): the kit
  // allows no lateral offset (kNoLateralOffset, the kit's D_mm range says so), or no design
  // with the off-axis position fits it (kNoOffAxisDesignFits).
  enum class RankFiveCause { kNone, kNoLateralOffset, kNoOffAxisDesignFits };
  RankFiveCause rank_five = RankFiveCause::kNone;
  // With the kit's resolution_mm: the best as searched (unrounded), and whether a rounded
  // design (each continuous position the multiple of the resolution below or above, inside
  // its bounds; every combination for up to 6 variables, else the nearest multiples and each
  // single change of them: `tried` designs checked and scored again) was feasible and
  // replaced it in `best`. Not applied: no rounded design is feasible (or a variable's range holds
  // no multiple of the resolution: tried = 0), and `best` is the unrounded one.
  struct Rounding {
    double resolution_mm = 0;
    Candidate unrounded;
    bool applied = false;
    int tried = 0;
  };
  std::optional<Rounding> rounding;
};

// Why no design fits a kit: one entry per state some choice ended in (never kSearched), most
// choices first, each with the choice closest to fitting (`closest`, an index into
// res.choices): the shortest for kOverTimeBudget (and how its time adds up), the least
// excursion for kOutsideTravel, the least shortfall for kTooClose, the smallest ratio of
// detection limit to declared size for kSetupNotDetected.
struct BindingConstraint {
  ChoiceState state = ChoiceState::kNoFeasiblePosition;
  int choices = 0;
  int closest = -1;
  double time_s = 0;  // kOverTimeBudget: the shortest design's time
  int positions = 0, installations = 0, readings = 0;
};
std::vector<BindingConstraint> binding_constraints(const Kit& kit, const OptimizeResult& res);

// The alternatives to the best a person would weigh: for each other set of block stacks (C;
// for B, each other angle step and number of optional positions) the best searched choice
// that determines as much as the best (as for the best, between objectives within 1e-4 of
// each other the shorter measurement), ordered by `better`; at most n, indices into
// res.choices. Their designs are as searched (not rounded to the kit's resolution).
std::vector<int> runner_up_choices(const OptimizeResult& res, int n);

// The discrete choices of a kit (each resolved: placements and continuous space), and the
// design for a choice and a point (bars and signs fitted; violations set).
std::vector<PatternChoice> pattern_choices(const Kit& kit);
std::string choice_label(const Kit& kit, const PatternChoice& choice);
Candidate make_candidate(const Kit& kit, const PatternChoice& choice, const std::vector<double>& x);
// Sets each installation's description (cup height and blocks, bar) for the person setting it up.
void describe_installations(const Kit& kit, Candidate& c);
// The installations of a candidate that come from optional positions of the pattern ("4a 5r 5t";
// "-": none).
std::string added_installations(const Kit& kit, const Candidate& c);
// Scores a candidate (its design evaluated for the criterion).
void score_candidate(const Kit& kit, Criterion criterion, Candidate& c);
// True when a is better than b: feasible first, then fewer undetermined, then
// the smaller objective, and between objectives equal to 1e-9 the shorter time.
bool better(const Candidate& a, const Candidate& b);

OptimizeResult optimize_kit(const Kit& kit, const OptimizeOptions& options = {});

// Every point of a grid with spacing grid_mm over each choice's continuous
// space (both bounds included): the reference the search is tested against.
OptimizeResult exhaustive_search(const Kit& kit, Criterion criterion, double grid_mm,
                                 int threads = 1);

// A reference design evaluated beside the optimised one.
struct Reference {
  std::string file;
  Design design;
  WorstCase worst;
  int rank = 0, n_unknowns = 0;
  // With set-up tolerances in the kit: the reference's total worst case under the same
  // tolerances (its own when it declares some, else the kit's).
  std::optional<WorstCase> worst_total;
};

// The reference for a kit: the design evaluated with the kit's reference length (and,
// with set-up tolerances in the kit, its total worst case). Throws InputError(file, key)
// when it is for another axis, another noise or another error model than the kit: the
// noise is the kit's when |sigma_ref - sigma_kit| <= 1e-12 sigma_kit (the same instrument
// written twice), anything else would compare instruments, not designs.
Reference make_reference(const Kit& kit, Design design, const std::string& file);

// The optimised design's worst case over the reference's (and the same for the totals with
// set-up tolerances); absent when there is no best design or either side leaves an error
// undetermined.
struct ReferenceRatios {
  std::optional<double> worst_std_um, worst_total_std_um;
};
ReferenceRatios reference_ratios(const OptimizeResult& res, const Reference& reference);

}  // namespace dbbkit
