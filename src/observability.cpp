#include "dbbkit/observability.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

#include "dbbkit/linear_model.hpp"

namespace dbbkit {

ObservabilityIndices observability_indices(const Eigen::VectorXd& s, int rank, int p, int n) {
  ObservabilityIndices o;
  if (p == 0 || n == 0 || rank < p) return o;  // a zero singular value makes every index 0
  double log_sum = 0, inv_sum = 0;
  for (int i = 0; i < p; ++i) {
    log_sum += std::log(s(i));
    inv_sum += 1.0 / s(i);
  }
  const double s1 = s(0), sp = s(p - 1);
  o.O1 = std::exp(log_sum / p) / std::sqrt(static_cast<double>(n));
  o.O2 = sp / s1;
  o.O3 = sp;
  o.O4 = sp * sp / s1;
  o.O5 = 1.0 / inv_sum;
  return o;
}

DesignCriteria design_criteria(const WlsSolver& solver) {
  DesignCriteria c;
  const Estimate& est = solver.a_priori();
  if (est.status == EstimateStatus::kNoReadings) return c;
  const int p = est.n_unknowns;
  if (est.rank == p) {
    // M = diag(c) Js' Js diag(c): log det M = 2 sum log s_i + 2 sum log c_j.
    c.D_logdet = 2.0 * est.singular_values.head(p).array().log().sum() + 2.0 * est.column_scale.array().log().sum();
    c.A_trace = est.covariance.trace();
    const Eigen::MatrixXd M =
        solver.J().transpose() * solver.sigma_um().cwiseAbs2().cwiseInverse().asDiagonal() * solver.J();
    c.E_min_eigenvalue = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M, Eigen::EigenvaluesOnly).eigenvalues()(0);
  }
  // Hat matrix H = J G (similar to the whitened one, same diagonal).
  c.G_max_leverage = (solver.J() * solver.gain()).diagonal().maxCoeff();
  return c;
}

WorstCase worst_case(const std::vector<ErrorsAtAngle>& errors, double reference_length_mm) {
  WorstCase w;
  double worst = -1;
  for (const ErrorsAtAngle& ea : errors) {
    for (int k = 0; k < 6; ++k) {
      if (!ea.errors[k].determined) {
        ++w.n_undetermined;
        continue;
      }
      const double u = k < 3 ? ea.errors[k].std : 1e-3 * reference_length_mm * ea.errors[k].std;
      if (u > worst) {
        worst = u;
        w.at_angle_deg = ea.angle_deg;
        w.at_error = k;
      }
    }
  }
  if (worst >= 0) w.worst_determined_std_um = worst;
  if (worst >= 0 && w.n_undetermined == 0) w.worst_std_um = worst;
  return w;
}

Evaluation evaluate_design(const Design& design, double reference_length_mm, const EstimateOptions& options) {
  const Parameterisation param(design);
  const LinearModel model = design_model(design, param);
  const WlsSolver solver(model.J, model.sigma_um, options);
  Evaluation ev;
  ev.prior = solver.a_priori();
  ev.reference_length_mm = reference_length_mm;
  ev.indices = observability_indices(ev.prior.singular_values, ev.prior.rank, ev.prior.n_unknowns, ev.prior.n_readings);
  ev.criteria = design_criteria(solver);
  ev.prior.theta = Eigen::VectorXd::Zero(ev.prior.n_unknowns);
  ev.errors = errors_at_stations(param, ev.prior);
  ev.unidentifiable = describe_null_space(design, param, ev.prior);
  ev.worst = worst_case(ev.errors, reference_length_mm);
  return ev;
}

std::vector<SweepPoint> sweep_design(const Design& design, const std::vector<SweepVariable>& variables,
                                     double reference_length_mm) {
  std::vector<SweepPoint> out;
  std::vector<size_t> index(variables.size(), 0);
  for (const SweepVariable& v : variables) {
    if (v.values.empty()) return out;
  }
  while (true) {
    Design d = design;
    SweepPoint p;
    for (size_t i = 0; i < variables.size(); ++i) {
      const double x = variables[i].values[index[i]];
      p.values.push_back(x);
      for (int inst : variables[i].installations) {
        Installation& in = d.installations[inst];
        (variables[i].coord == 0 ? in.L_mm : variables[i].coord == 1 ? in.D_mm : in.H_mm) = x;
      }
    }
    validate_design(d, "--sweep");
    const Evaluation ev = evaluate_design(d, reference_length_mm);
    p.rank = ev.prior.rank;
    p.n_unknowns = ev.prior.n_unknowns;
    p.condition_number = ev.prior.condition_number;
    p.worst_std_um = ev.worst.worst_std_um;
    p.worst_determined_std_um = ev.worst.worst_determined_std_um;
    out.push_back(p);
    int i = static_cast<int>(variables.size()) - 1;
    while (i >= 0 && ++index[i] == variables[i].values.size()) index[i--] = 0;
    if (i < 0) break;
  }
  return out;
}

}  // namespace dbbkit
