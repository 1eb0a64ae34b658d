#pragma once
// The library's computations on a factorised model (WlsSolver, src/wls_solver.hpp; SetupSolver,
// src/setup_solver.hpp): internal. The installed headers offer the same through a design or an
// identify result (identify.hpp, observability.hpp).

#include <Eigen/Core>
#include <vector>

#include "dbbkit/monte_carlo.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/uncertainty.hpp"
#include "dbbkit/warnings.hpp"
#include "setup_solver.hpp"

namespace dbbkit {

class WlsSolver;

// Criteria of the design's information M = J' Sigma^-1 J (DesignCriteria, observability.hpp).
DesignCriteria design_criteria(const WlsSolver& solver);

// Throws InputError when Type A is asked for and the residual has no degrees of freedom.
// With `setup` (declared length offset and centring tolerances), `est` is its estimate
// and the noise and set-up parts are its own.
Budget uncertainty_budget(const Design& design, const Parameterisation& param,
                          const LinearModel& model, const WlsSolver& solver, const Estimate& est,
                          const BudgetOptions& options, const SetupSolver* setup = nullptr);

// The joint covariance of the budget's values (values x values, in the order of
// budget.values, each in its unit): the components of every u_c with the correlations
// between values, i.e. reading noise (times the Type A factor squared), the set-up
// length offsets and centrings (with `setup`) and the set-up inputs L, D, H (through
// the same sensitivities as the budget). Its diagonal is u_c^2. Dense: values^2 doubles.
Eigen::MatrixXd budget_covariance(const Design& design, const Parameterisation& param,
                                  const LinearModel& model, const WlsSolver& solver,
                                  const Estimate& est, const Budget& budget,
                                  const SetupSolver* setup = nullptr);

// With `setup` (declared length offset and centring tolerances, setup.hpp) the
// estimate is its own and every trial also draws the set-up effects from their priors.
MonteCarloResult monte_carlo(const Design& design, const Parameterisation& param,
                             const LinearModel& model, const WlsSolver& solver, const Estimate& est,
                             const Budget& budget, const MonteCarloOptions& options,
                             const SetupSolver* setup = nullptr);

// Every such effect of the design (setup_effects), most biasing first: the undeclared effects'
// columns through the model's factorisation in one product (effect_columns).
std::vector<HiddenSetupEffect> hidden_setup_effects(const Design& design,
                                                    const Parameterisation& param,
                                                    const LinearModel& model,
                                                    const WlsSolver& solver,
                                                    double reference_length_mm);
// The same among `effects` (those with a declared tolerance passed over), their columns formed
// with `solver` (effect_columns(solver, effects)), the determined functions of its a-priori
// estimate given (determined_functions).
std::vector<HiddenSetupEffect> hidden_setup_effects(
    const Parameterisation& param, const WlsSolver& solver, const std::vector<SetupEffect>& effects,
    const EffectColumns& columns, const DeterminedFunctions& functions, double reference_length_mm);

}  // namespace dbbkit
