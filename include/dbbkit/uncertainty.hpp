#pragma once
// Uncertainty budget of every identified value after JCGM 100 (GUM):
//   reading noise, Type B from the declared instrument (rectangular +-a ->
//   a/sqrt(3), infinite degrees of freedom) or, on request, Type A from the
//   residual (u scaled by sqrt(chi2 / nu), nu = n - rank degrees of freedom);
//   set-up length offsets and centrings (Type B, declared tolerances): the set-up
//   part of the estimate that carries them (setup.hpp), split per group;
//   set-up inputs L, D, H of every installation (Type B, design.setup_std),
//   propagated through the model at the identified errors;
//   u_c^2 = sum u_i^2, nu_eff by Welch-Satterthwaite, U = k u_c with k the
//   Student t quantile at nu_eff for the stated coverage probability.

#include <optional>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/parameterisation.hpp"

namespace dbbkit {

// A Type A evaluation needs a residual: its scale sqrt(chi2 / dof) (the scatter against the
// declared noise) is at least this, or the evaluation is refused (InputError "--type-a").
inline constexpr double kMinTypeAScale = 1e-6;

struct BudgetOptions {
  bool type_a = false;  // evaluate the reading noise from the residual
  double coverage_probability = 0.95;
  // Per reading, a Type A standard uncertainty of its repeatability (Reading::u_a_um) and its
  // degrees of freedom, beside the declared instrument (empty: none). The model's weights then
  // hold both (model.sigma_um); the budget states the reading noise (Type B) and the readings'
  // repeatability (Type A, Welch-Satterthwaite over the readings) as two components.
  std::vector<double> reading_u_a_um;
  std::vector<int> reading_u_a_dof;
};

struct BudgetComponent {
  std::string name;  // "reading noise", "set-up length offset", "set-up centring", "set-up L",
                     // "set-up D", "set-up H"
  std::string type;  // "A" or "B"
  double u = 0;      // standard uncertainty contribution, in the value's unit
  std::optional<double> dof;  // absent: infinite
};

struct ValueBudget {
  int station = 0;
  double angle_deg = 0;
  int error = 0;  // 0..5
  double value = 0;
  std::vector<BudgetComponent> components;
  double u_c = 0;
  std::optional<double> nu_eff;  // absent: infinite
  double k = 0;
  double U = 0;
};

struct Budget {
  double coverage_probability = 0.95;
  // The reading noise: Type A from the residual (type_a_dof degrees of freedom, type_a_scale =
  // sqrt(chi2 / nu)), or Type B from the declared instrument (declared_noise).
  std::optional<int> type_a_dof;
  std::optional<double> type_a_scale;
  NoiseModel declared_noise;
  // Each reading's repeatability is a Type A component beside the declared noise
  // (BudgetOptions::reading_u_a_um).
  bool reading_type_a = false;
  std::vector<ValueBudget> values;  // determined values only, station-major
};

// k such that P(|T_nu| <= k) = p; the normal quantile when nu is absent (infinite).
double coverage_factor(std::optional<double> nu, double p);

// The expansion of uncertainties stated before or without a Type A evaluation (declared
// noise and set-up tolerances: infinite degrees of freedom): U = k u, k the normal quantile
// for the coverage probability.
struct Expansion {
  double coverage_probability = 0.95;
  double k = 0;
};
Expansion a_priori_expansion(double coverage_probability = BudgetOptions{}.coverage_probability);

// The degrees of freedom behind the ISO 230 quantities' uncertainties (their k and the
// multivariate t of the error motions): with a Type A evaluation from the residual, its
// degrees of freedom; with the readings' own Type A parts (reading_type_a), the least
// effective degrees of freedom of the budget's values (each a Welch-Satterthwaite pooling of
// the same readings; a quantity pooling more of them has at least as many: the least errs on
// the wide side); otherwise none (Type B: infinite).
std::optional<double> iso_degrees_of_freedom(const Budget& budget);

// nu_eff = u_c^4 / sum(u_i^4 / nu_i) over components with finite nu (Welch-Satterthwaite).
std::optional<double> welch_satterthwaite(const std::vector<BudgetComponent>& components);

// The functions c.theta of the budget's values, one row each (values x parameters), sparse.
FunctionRows budget_functions(const Parameterisation& param, const Budget& budget);

}  // namespace dbbkit
