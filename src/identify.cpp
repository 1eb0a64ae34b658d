#include "dbbkit/identify.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>
#include <stdexcept>

#include "dbbkit/effects.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/setup.hpp"
#include "dbbkit/user_text.hpp"
#include "dbbkit/warnings.hpp"
#include "factorised.hpp"
#include "number_text.hpp"
#include "setup_solver.hpp"
#include "wls_solver.hpp"

namespace dbbkit {

namespace {

// The rigid motion of a direction no reading sees (an unidentifiable motion):
//   a ball lies on the motion's line when its distance |(P - Q) x a| <= kOnLine_mm;
//   the motion is a pure rotation when its pitch |h| <= kNoPitch (|d| + 1e-3 |e|);
//   the line is the tool axis when it passes within kOnLine_mm of the origin and
//   |a x z_tool| < kParallel.
constexpr double kOnLine_mm = 1e-6;
constexpr double kNoPitch = 1e-9;
constexpr double kParallel = 1e-9;

// A null direction confined to one station is a small rigid motion (d, e): a screw about an
// axis (RigidMotion).
RigidMotion rigid_motion(const Design& design, double angle_deg, const Eigen::Vector3d& d,
                         const Eigen::Vector3d& e) {
  RigidMotion m;
  if (e.norm() == 0.0) {
    m.kind = RigidMotion::Kind::kTranslation;
    m.direction = d.normalized();
    return m;
  }
  const Eigen::Vector3d a = e.normalized();
  // dP = 1e-3 e x (P - Q) + h a: the line through Q (mm) along a, pitch h.
  const Eigen::Vector3d Q_mm = 1e3 * e.cross(d) / e.squaredNorm();
  const double h = d.dot(a);
  m.direction = a;
  m.point_mm = Q_mm;
  m.on_all_balls = true;
  m.instrument = design.instrument;
  for (const Installation& inst : design.installations) {
    const Eigen::Vector3d P = ball_position_mm(design.axis, inst, angle_deg);
    if ((P - Q_mm).cross(a).norm() > kOnLine_mm) m.on_all_balls = false;
  }
  m.kind = std::abs(h) <= kNoPitch * (d.norm() + 1e-3 * e.norm()) ? RigidMotion::Kind::kRotation
                                                                  : RigidMotion::Kind::kScrew;
  m.tool_axis =
      design.axis.head() && Q_mm.norm() < kOnLine_mm &&
      a.cross(axis_rotation(design.axis, angle_deg) * design.axis.reference()).norm() < kParallel;
  return m;
}

}  // namespace

Eigen::SparseMatrix<double> error_functions(const Parameterisation& param, int station,
                                            Eigen::Index n_unknowns) {
  return param.error_functions(station, n_unknowns);
}

namespace {

// The errors at every station: whether each is determined and its estimate, and with_std its
// standard uncertainty from the estimate's covariance (identify takes the budget's instead).
std::vector<ErrorsAtAngle> at_stations(const Parameterisation& param, const Estimate& est,
                                       bool with_std) {
  std::vector<ErrorsAtAngle> out;
  out.reserve(static_cast<std::size_t>(param.n_stations()));
  for (int s = 0; s < param.n_stations(); ++s) {
    ErrorsAtAngle ea;
    ea.station = s;
    ea.angle_deg = param.station_angle_deg(s);
    const Eigen::SparseMatrix<double> C = error_functions(param, s, est.n_unknowns);
    for (int k = 0; k < 6; ++k) {
      const Estimate::Function c = C.col(k);
      if (with_std) {
        ea.errors[k] = est.evaluate(c);
      } else if (est.determined(c)) {
        ea.errors[k].determined = true;
        if (est.theta.size() > 0) {
          for (Estimate::Function::InnerIterator a(c); a; ++a)
            ea.errors[k].value += a.value() * est.theta(a.index());
        }
      }
    }
    out.push_back(ea);
  }
  return out;
}

}  // namespace

std::vector<ErrorsAtAngle> errors_at_stations(const Parameterisation& param, const Estimate& est) {
  return at_stations(param, est, true);
}

std::vector<Unidentifiable> describe_null_space(const Design& design, const Parameterisation& param,
                                                const Estimate& est) {
  std::vector<Unidentifiable> out;
  const Eigen::MatrixXd N = est.null_directions();
  const bool per_angle = param.model().kind == ErrorModel::Kind::kPerAngle;
  for (int c = 0; c < N.cols(); ++c) {
    Unidentifiable u;
    int station = -2;  // -2: none seen yet, -1: several
    for (int j = 0; j < N.rows(); ++j) {
      if (N(j, c) == 0.0) continue;
      const int s = param.parameter_station(j);
      station = (station == -2 || station == s) ? s : -1;
    }
    const bool local = per_angle && station >= 0;
    Eigen::Vector3d d = Eigen::Vector3d::Zero(), e = Eigen::Vector3d::Zero();
    for (int j = 0; j < N.rows(); ++j) {
      if (N(j, c) == 0.0) continue;
      const int k = param.parameter_error(j);
      if (k < 0) {  // an effect fitted with the errors (IdentifyOptions::effects)
        u.terms.emplace_back(param.parameter_name(j), N(j, c));
        continue;
      }
      u.terms.emplace_back(local ? std::string(kErrorNames[k]) : param.parameter_name(j), N(j, c));
      if (k < 3) {
        d(k) = N(j, c);
      } else {
        e(k - 3) = N(j, c);
      }
    }
    if (local) {
      u.angle_deg = param.station_angle_deg(station);
      u.motion = rigid_motion(design, *u.angle_deg, d, e);
    }
    out.push_back(u);
  }
  return out;
}

namespace {

// The effects' columns appended to the model and their parameters to the unknowns; the
// blocks, in the order given. Throws InputError(options.effects_source) for an effect given
// twice or one the readings cannot form.
std::vector<EffectBlock> append_effects(const Design& design, const std::vector<Reading>& readings,
                                        const IdentifyOptions& options, Parameterisation& param,
                                        LinearModel& model) {
  std::vector<EffectBlock> blocks;
  if (options.effects.empty()) return blocks;
  const ReadingLayout layout(design, readings);
  std::vector<std::string> names;
  Eigen::Index columns = 0;
  for (const EffectCandidate& e : options.effects) {
    EffectBlock b = effect_block(design, readings, layout, e);
    for (const EffectBlock& o : blocks) {
      if (o.label == b.label)
        throw InputError(options.effects_source, b.label, "the effect is given twice");
      // One effect whole and one of its components (placement[s1], placement.dL[s1]).
      if (o.effect.kind == e.kind && o.effect.installation == e.installation &&
          (o.effect.component < 0) != (e.component < 0) && !effect_is_shared(e.kind))
        throw InputError(options.effects_source, b.label,
                         "overlaps " + o.label + " (a component of the same effect)");
    }
    if (!b.applicability.applicable() || b.parameters.empty()) {
      throw InputError(options.effects_source, b.label,
                       "cannot be fitted on these readings: " +
                           (b.applicability.applicable() ? std::string("it changes no reading")
                                                         : not_applicable_text(b.applicability)));
    }
    for (const std::string& q : b.parameters)
      names.push_back(b.parameters.size() > 1 ? b.label + "." + q : b.label);
    columns += b.J_reading_effect.cols();
    blocks.push_back(std::move(b));
  }
  Eigen::MatrixXd X(model.J.rows(), columns);
  Eigen::Index c = 0;
  for (const EffectBlock& b : blocks) {
    X.middleCols(c, b.J_reading_effect.cols()) = b.J_reading_effect;
    c += b.J_reading_effect.cols();
  }
  model.J = append_columns(model.J, X);
  model.series = nullptr;  // the factored rows are the axis errors' alone
  param.append_unknowns(names);
  return blocks;
}

// The set-up effects with a declared tolerance, less those fitted freely (an effect fitted with
// the errors replaces its set-up prior: its value is then the whole offset, not what the prior
// leaves). `fitted`: anything with a label.
template <typename Fitted>
std::vector<SetupEffect> declared_setup(const Design& design, const LinearModel& model,
                                        const std::vector<Fitted>& fitted) {
  std::vector<SetupEffect> out;
  for (SetupEffect& e : setup_effects(design, model, true)) {
    const bool free = std::any_of(fitted.begin(), fitted.end(),
                                  [&](const Fitted& f) { return f.label == e.label; });
    if (!free) out.push_back(std::move(e));
  }
  return out;
}

// Each fitted effect's equivalents among the library's candidates (FittedEffect::equivalent_to):
// a candidate of as many columns that lies in the span of the fitted model and, in the effect's
// place, keeps its rank spans the same space, so the readings fit either exactly as well.
void find_equivalents(const Design& design, const std::vector<Reading>& readings,
                      const std::vector<EffectBlock>& blocks, const Eigen::VectorXd& sigma_um,
                      const EstimateOptions& options, std::vector<FittedEffect>& effects) {
  if (blocks.empty()) return;
  const Parameterisation param(design);
  LinearModel base = build_linear_model(design, param, readings);
  base.sigma_um = sigma_um;  // the fit's own weights (with each reading's Type A)
  auto fit = [&](const std::vector<const Eigen::MatrixXd*>& xs) {
    Eigen::Index cols = 0;
    for (const Eigen::MatrixXd* x : xs) cols += x->cols();
    Eigen::MatrixXd X(base.J.rows(), cols);
    Eigen::Index c = 0;
    for (const Eigen::MatrixXd* x : xs) X.middleCols(c, x->cols()) = *x, c += x->cols();
    return WlsSolver(append_columns(base.J, X), base.sigma_um, options).solve(base.y_um);
  };
  std::vector<const Eigen::MatrixXd*> chosen_blocks;
  for (const EffectBlock& b : blocks) chosen_blocks.push_back(&b.J_reading_effect);
  const Estimate chosen = fit(chosen_blocks);
  const std::vector<ErrorsAtAngle> chosen_errors = at_stations(param, chosen, false);
  for (const EffectBlock& candidate : candidate_effects(design, readings)) {
    if (!candidate.applicability.applicable() || candidate.parameters.empty()) continue;
    if (std::any_of(blocks.begin(), blocks.end(),
                    [&](const EffectBlock& b) { return b.label == candidate.label; }))
      continue;
    std::vector<const Eigen::MatrixXd*> with = chosen_blocks;
    with.push_back(&candidate.J_reading_effect);
    if (fit(with).rank != chosen.rank) continue;  // it adds something: not in the span
    for (std::size_t e = 0; e < blocks.size(); ++e) {
      if (blocks[e].J_reading_effect.cols() != candidate.J_reading_effect.cols()) continue;
      std::vector<const Eigen::MatrixXd*> swapped = chosen_blocks;
      swapped[e] = &candidate.J_reading_effect;
      const Estimate other = fit(swapped);
      if (other.rank != chosen.rank) continue;
      const std::vector<ErrorsAtAngle> other_errors = at_stations(param, other, false);
      FittedEffect& f = effects[e];
      f.equivalent_to.push_back(candidate.label);
      for (std::size_t s = 0; s < chosen_errors.size() && s < other_errors.size(); ++s) {
        for (int k = 0; k < 6; ++k) {
          const Determined &a = chosen_errors[s].errors[k], &b = other_errors[s].errors[k];
          if (a.determined && b.determined)
            f.largest_change[k] = std::max(f.largest_change[k], std::abs(a.value - b.value));
        }
      }
    }
  }
}

}  // namespace

BudgetOptions with_reading_type_a(BudgetOptions options, const std::vector<Reading>& readings,
                                  const std::string& source, const std::string& option) {
  if (options.type_a)
    throw InputError(option, "",
                     "the readings' own Type A and a Type A from the residual (" +
                         option_name("--type-a") + ") are two evaluations of one noise: give one");
  options.reading_u_a_um.clear();
  options.reading_u_a_dof.clear();
  for (std::size_t i = 0; i < readings.size(); ++i) {
    const Reading& r = readings[i];
    if (!r.u_a_um || !r.u_a_dof) {
      throw InputError(
          source, r.line > 0 ? "line " + std::to_string(r.line) : "reading " + std::to_string(i),
          "reading of " + quote_value(r.installation) + " at " + text::significant(r.angle_deg, 6) +
              " deg has no u_a_um and u_a_dof, which " + option +
              " needs (a measurement file of dbbkit readings carries them for every dwell of at "
              "least two 0.1 s batches)");
    }
    options.reading_u_a_um.push_back(*r.u_a_um);
    options.reading_u_a_dof.push_back(*r.u_a_dof);
  }
  return options;
}

IdentifyResult identify(const Design& design, const std::vector<Reading>& readings,
                        const IdentifyOptions& options) {
  Parameterisation param(design);
  LinearModel model = build_linear_model(design, param, readings);
  const std::vector<EffectBlock> blocks = append_effects(design, readings, options, param, model);
  if (!options.budget.reading_u_a_um.empty()) {
    // Each reading weighted by its whole noise: the declared instrument and its repeatability.
    const double b = design.noise.sigma_um();
    for (Eigen::Index i = 0; i < model.sigma_um.size(); ++i) {
      const double a = options.budget.reading_u_a_um[static_cast<std::size_t>(i)];
      model.sigma_um(i) = std::sqrt(b * b + a * a);
    }
  }
  auto solver = std::make_shared<const WlsSolver>(model, options.estimate);
  IdentifyResult res{std::move(param),
                     std::move(model),
                     std::move(solver),
                     {},
                     {},
                     {},
                     {},
                     false,
                     false,
                     {},
                     {},
                     {},
                     {},
                     {}};
  res.instrument = design.instrument;
  // The set-up solver refers to *res.solver, shared with the result.
  const std::vector<SetupEffect> declared = declared_setup(design, res.model, blocks);
  const SetupSolver setup(*res.solver, declared);
  res.estimate = setup.solve(res.model.y_um);
  res.budget = uncertainty_budget(design, res.param, res.model, *res.solver, res.estimate,
                                  options.budget, &setup);
  // Every determined value has its entry in the budget, whose u_c is its standard uncertainty.
  res.errors = at_stations(res.param, res.estimate, false);
  std::size_t budgeted = 0;
  for (const ValueBudget& v : res.budget.values) {
    Determined& d = res.errors[static_cast<std::size_t>(v.station)].errors[v.error];
    budgeted += d.determined;
    d.std = v.u_c;
  }
  std::size_t determined = 0;
  for (const ErrorsAtAngle& ea : res.errors) {
    for (const Determined& d : ea.errors) determined += d.determined;
  }
  if (budgeted != determined || budgeted != res.budget.values.size())
    throw std::logic_error("identify: the budget's values are not the determined errors");
  res.unidentifiable = describe_null_space(design, res.param, res.estimate);
  res.setup_included = setup.any();
  IsoMotionOptions motion = options.iso_motion;
  motion.coverage_probability = options.budget.coverage_probability;
  motion.dof = iso_degrees_of_freedom(res.budget);
  res.iso = iso230_quantities(design, res.param, res.estimate,
                              res.budget.type_a_scale.value_or(1.0), motion);
  bool placement = false;
  for (int i = 0; i < static_cast<int>(design.installations.size()); ++i)
    placement = placement || design.setup_of(i).placement();
  res.placement_declared = placement;
  res.first_order = first_order_check(design, res.param, res.estimate.theta);
  bound_first_order_bias(res.first_order, setup, res.param, res.budget);
  if (setup.any()) {
    const Eigen::VectorXd b = setup.beta(res.model.y_um);
    for (int j = 0; j < setup.n_columns(); ++j) {
      const auto [e, c] = setup.column_of()[j];
      res.setup_estimates.push_back({declared[e].label, declared[e].parameters[c], b(j),
                                     std::sqrt(setup.beta_covariance()(j, j)), declared[e].std_um});
    }
  }
  // The effects' values, with the budget's noise scale (Type A) on the estimate's covariance.
  const double scale = res.budget.type_a_scale.value_or(1.0);
  int j = res.param.n_axis_parameters();
  for (const EffectBlock& b : blocks) {
    FittedEffect f;
    f.label = b.label;
    f.unit = b.unit;
    f.parameters = b.parameters;
    for (std::size_t q = 0; q < b.parameters.size(); ++q, ++j) {
      Estimate::Function c(res.estimate.n_unknowns);
      c.insert(j) = 1.0;
      Determined d = res.estimate.evaluate(c);
      d.std *= scale;
      f.values.push_back(d);
    }
    res.effects.push_back(std::move(f));
  }
  find_equivalents(design, readings, blocks, res.model.sigma_um, options.estimate, res.effects);
  res.warnings = identify_warnings(design, res);
  return res;
}

Eigen::MatrixXd budget_covariance(const Design& design, const IdentifyResult& result) {
  const SetupSolver setup(*result.solver, declared_setup(design, result.model, result.effects));
  return budget_covariance(design, result.param, result.model, *result.solver, result.estimate,
                           result.budget, &setup);
}

MonteCarloResult monte_carlo(const Design& design, const IdentifyResult& result,
                             const MonteCarloOptions& options) {
  const SetupSolver setup(*result.solver, declared_setup(design, result.model, result.effects));
  return monte_carlo(design, result.param, result.model, *result.solver, result.estimate,
                     result.budget, options, &setup);
}

std::vector<ExpandedErrorsAtAngle> expanded_errors(const std::vector<ErrorsAtAngle>& errors,
                                                   double k) {
  std::vector<ExpandedErrorsAtAngle> out;
  out.reserve(errors.size());
  for (const ErrorsAtAngle& ea : errors) {
    ExpandedErrorsAtAngle x{ea.angle_deg, ea.station, {}};
    for (int e = 0; e < 6; ++e) {
      const Determined& d = ea.errors[e];
      x.errors[e] = {d.determined, d.value, d.determined ? k * d.std : 0.0};
    }
    out.push_back(x);
  }
  return out;
}

std::vector<ExpandedErrorsAtAngle> expanded_errors(const std::vector<ErrorsAtAngle>& errors,
                                                   const Budget& budget) {
  std::map<std::pair<int, int>, double> U;
  for (const ValueBudget& v : budget.values) U[{v.station, v.error}] = v.U;
  std::vector<ExpandedErrorsAtAngle> out = expanded_errors(errors, 0.0);
  for (ExpandedErrorsAtAngle& ea : out) {
    for (int e = 0; e < 6; ++e) {
      if (!ea.errors[e].determined) continue;
      const auto it = U.find({ea.station, e});
      if (it == U.end())
        throw std::logic_error("expanded_errors: a determined value has no budget entry");
      ea.errors[e].U = it->second;
    }
  }
  return out;
}

}  // namespace dbbkit
