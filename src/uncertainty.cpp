#include "dbbkit/uncertainty.hpp"

#include <algorithm>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>

#include "dbbkit/error.hpp"
#include "dbbkit/setup.hpp"
#include "dbbkit/user_text.hpp"
#include "factorised.hpp"
#include "number_text.hpp"
#include "setup_solver.hpp"
#include "wls_solver.hpp"

namespace dbbkit {

double coverage_factor(std::optional<double> nu, double p) {
  const double q = 0.5 * (1.0 + p);
  if (!nu) return boost::math::quantile(boost::math::normal(), q);
  return boost::math::quantile(boost::math::students_t(*nu), q);
}

Expansion a_priori_expansion(double coverage_probability) {
  return {coverage_probability, coverage_factor(std::nullopt, coverage_probability)};
}

std::optional<double> iso_degrees_of_freedom(const Budget& budget) {
  if (budget.type_a_dof) return static_cast<double>(*budget.type_a_dof);
  if (!budget.reading_type_a) return std::nullopt;
  std::optional<double> least;
  for (const ValueBudget& v : budget.values)
    if (v.nu_eff && (!least || *v.nu_eff < *least)) least = v.nu_eff;
  return least;
}

std::optional<double> welch_satterthwaite(const std::vector<BudgetComponent>& components) {
  double uc2 = 0, denom = 0;
  for (const BudgetComponent& c : components) {
    uc2 += c.u * c.u;
    if (c.dof) denom += std::pow(c.u, 4) / *c.dof;
  }
  if (denom <= 0) return std::nullopt;
  return uc2 * uc2 / denom;
}

FunctionRows budget_functions(const Parameterisation& param, const Budget& budget) {
  // Row by row, each row's entries in column order (an error function's): appended in order
  // into compressed storage.
  FunctionRows C(static_cast<Eigen::Index>(budget.values.size()), param.n_parameters());
  C.reserve(static_cast<Eigen::Index>(budget.values.size()) * param.coefficients_per_error());
  int station = -1;
  Eigen::SparseMatrix<double> E;
  for (std::size_t v = 0; v < budget.values.size(); ++v) {
    if (budget.values[v].station != station) {
      station = budget.values[v].station;
      E = param.error_functions(station);
    }
    const auto row = static_cast<Eigen::Index>(v);
    C.startVec(row);
    for (Eigen::SparseMatrix<double>::InnerIterator it(E, budget.values[v].error); it; ++it)
      C.insertBack(row, it.row()) = it.value();
  }
  C.finalize();
  return C;
}

namespace {
// d(theta_hat)/d(input) [theta units per mm] for the set-up inputs L, D, H (p x inputs).
Eigen::MatrixXd input_gain(const Design& design, const Parameterisation& param,
                           const LinearModel& model, const WlsSolver& solver, const Estimate& est,
                           const SetupSolver* setup, const std::vector<SetupInput>& inputs) {
  if (inputs.empty()) return {};
  const Eigen::MatrixXd D = J_reading_setup(design, param, model, inputs, est.theta);
  return setup ? setup->gain_times(D) : Eigen::MatrixXd(solver.J_theta_reading() * D);
}
}  // namespace

Budget uncertainty_budget(const Design& design, const Parameterisation& param,
                          const LinearModel& model, const WlsSolver& solver, const Estimate& est,
                          const BudgetOptions& options, const SetupSolver* setup) {
  if (!(options.coverage_probability > 0 && options.coverage_probability < 1)) {
    throw InputError("options", "coverage_probability", "must lie strictly between 0 and 1");
  }
  Budget b;
  b.coverage_probability = options.coverage_probability;
  double noise_scale = 1.0;
  std::optional<double> noise_dof;
  if (options.type_a) {
    if (est.dof <= 0) {
      throw InputError(option_name("--type-a"), "",
                       "the residual has no degrees of freedom: a Type A evaluation is impossible");
    }
    noise_scale = std::sqrt(est.chi2 / est.dof);
    // A residual a millionth of the declared noise or less is no scatter to state an
    // uncertainty from (all readings zero, a stopped instrument): u would be 0.
    if (!(noise_scale >= kMinTypeAScale)) {
      throw InputError(option_name("--type-a"), "",
                       "the residual is " + std::string(est.chi2 > 0 ? "all but " : "") +
                           "zero (chi2 " + text::significant(est.chi2, 3) + " on " +
                           std::to_string(est.dof) +
                           " dof): a Type A uncertainty stated from it would be 0. The readings "
                           "are explained exactly (all zero? an instrument that did not count?): "
                           "check them, or state the declared noise (without " +
                           option_name("--type-a") + ")");
    }
    noise_dof = est.dof;
    b.type_a_scale = noise_scale;
    b.type_a_dof = est.dof;
  }
  b.declared_noise = design.noise;

  const std::vector<SetupInput> inputs = setup_inputs(design);
  const Eigen::MatrixXd GD = input_gain(design, param, model, solver, est, setup, inputs);
  const bool nuisance = setup && setup->any();
  const bool per_reading = !options.reading_u_a_um.empty();
  if (per_reading && (options.type_a ||
                      options.reading_u_a_um.size() != static_cast<std::size_t>(model.J.rows()) ||
                      options.reading_u_a_dof.size() != options.reading_u_a_um.size()))
    throw std::logic_error("uncertainty_budget: per-reading Type A needs one value per reading");
  b.reading_type_a = per_reading;
  // The reading noise of value c' theta: one component, or with per-reading Type A, the
  // declared noise and the readings' repeatability through the value's gain on each reading.
  const double sigma_b = design.noise.sigma_um();
  auto noise_components = [&](ValueBudget& v, const Estimate::Function& c, double u_noise) {
    if (!per_reading) {
      v.components.push_back({"reading noise", options.type_a ? "A" : "B", u_noise, noise_dof});
      return;
    }
    FunctionRows C(1, c.size());
    for (Estimate::Function::InnerIterator it(c); it; ++it) C.insert(0, it.index()) = it.value();
    const Eigen::MatrixXd g =
        nuisance ? setup->left_gain(C) : Eigen::MatrixXd(solver.J_theta_reading().left(C));
    double b2 = 0, a2 = 0, den = 0;
    for (Eigen::Index i = 0; i < g.cols(); ++i) {
      const double g2 = g(0, i) * g(0, i);
      const double a = g2 * options.reading_u_a_um[static_cast<std::size_t>(i)] *
                       options.reading_u_a_um[static_cast<std::size_t>(i)];
      b2 += g2 * sigma_b * sigma_b;
      a2 += a;
      den += a * a / options.reading_u_a_dof[static_cast<std::size_t>(i)];
    }
    v.components.push_back({"reading noise", "B", std::sqrt(b2), std::nullopt});
    v.components.push_back({"reading repeatability", "A", std::sqrt(a2),
                            den > 0 ? std::optional<double>(a2 * a2 / den) : std::nullopt});
  };
  static const char* kSetupNames[3] = {"set-up L", "set-up D", "set-up H"};

  for (int s = 0; s < param.n_stations(); ++s) {
    const Eigen::SparseMatrix<double> E = param.error_functions(s);
    for (int k = 0; k < 6; ++k) {
      const Estimate::Function c = E.col(k);
      const Determined d = est.evaluate(c);
      if (!d.determined) continue;
      ValueBudget v;
      v.station = s;
      v.angle_deg = param.station_angle_deg(s);
      v.error = k;
      v.value = d.value;
      if (nuisance) {
        const SetupSolver::Parts parts = setup->parts(c);
        noise_components(v, c, std::sqrt(parts.noise) * noise_scale);
        // One component per kind of set-up effect, in the table's order ("set-up length offset",
        // "set-up centring"; a probe's "set-up trigger offset", "set-up placement").
        std::vector<double> u2(effect_kinds().size(), 0.0);
        for (int j = 0; j < setup->n_columns(); ++j)
          u2[static_cast<std::size_t>(setup->column_kind(j))] += parts.setup_by_column(j);
        for (EffectKind kind : effect_kinds()) {
          const double x = u2[static_cast<std::size_t>(kind)];
          if (!(x > 0)) continue;
          std::string name = effect_name(kind);
          std::replace(name.begin(), name.end(), '_', ' ');
          v.components.push_back({"set-up " + name, "B", std::sqrt(x), std::nullopt});
        }
      } else {
        noise_components(v, c, d.std * noise_scale);
      }
      if (!inputs.empty()) {
        double u2[3] = {0, 0, 0};
        const Eigen::VectorXd sens = GD.transpose() * c;  // d(value)/d(input)
        for (size_t j = 0; j < inputs.size(); ++j)
          u2[inputs[j].coord] += std::pow(sens(j) * inputs[j].std_mm, 2);
        for (int q = 0; q < 3; ++q) {
          if (u2[q] > 0)
            v.components.push_back({kSetupNames[q], "B", std::sqrt(u2[q]), std::nullopt});
        }
      }
      double uc2 = 0;
      for (const BudgetComponent& comp : v.components) uc2 += comp.u * comp.u;
      v.u_c = std::sqrt(uc2);
      v.nu_eff = welch_satterthwaite(v.components);
      v.k = coverage_factor(v.nu_eff, options.coverage_probability);
      v.U = v.k * v.u_c;
      b.values.push_back(v);
    }
  }
  return b;
}

Eigen::MatrixXd budget_covariance(const Design& design, const Parameterisation& param,
                                  const LinearModel& model, const WlsSolver& solver,
                                  const Estimate& est, const Budget& budget,
                                  const SetupSolver* setup) {
  const Eigen::SparseMatrix<double> C = budget_functions(param, budget).transpose();  // p x values
  const double scale2 = budget.type_a_scale ? *budget.type_a_scale * *budget.type_a_scale : 1.0;
  Eigen::MatrixXd cov;
  if (setup && setup->any()) {
    const SetupSolver::JointParts parts = setup->joint_parts(C);
    cov = scale2 * parts.noise + parts.setup;
  } else {
    cov = scale2 * Eigen::MatrixXd(Eigen::SparseMatrix<double>(C.transpose() * est.covariance) * C);
  }
  const std::vector<SetupInput> inputs = setup_inputs(design);
  if (!inputs.empty()) {
    Eigen::VectorXd u(static_cast<Eigen::Index>(inputs.size()));
    for (size_t j = 0; j < inputs.size(); ++j) u(static_cast<Eigen::Index>(j)) = inputs[j].std_mm;
    // d(value)/d(input) times the input's u: one column per input
    const Eigen::MatrixXd A = C.transpose() *
                              input_gain(design, param, model, solver, est, setup, inputs) *
                              u.asDiagonal();
    cov += A * A.transpose();
  }
  return cov;
}

}  // namespace dbbkit
