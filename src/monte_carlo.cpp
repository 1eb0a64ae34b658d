#include "dbbkit/monte_carlo.hpp"
#include "dbbkit/setup.hpp"

#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <random>

#include "dbbkit/error.hpp"
#include "dbbkit/parallel.hpp"

namespace dbbkit {

namespace {

constexpr long kChunk =
    1000;  // trials per random stream; streams are independent of the thread count

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

struct Stats {
  double mean = 0, std = 0, low = 0, high = 0;
};

// Mean, standard deviation and the probabilistically symmetric p-interval of a sample (JCGM 101
// §7.7).
Stats stats_of(std::vector<float> x, double p) {
  Stats s;
  const long M = static_cast<long>(x.size());
  double sum = 0, sum2 = 0;
  for (float v : x) sum += v;
  s.mean = sum / M;
  for (float v : x) sum2 += (v - s.mean) * (v - s.mean);
  s.std = std::sqrt(sum2 / (M - 1));
  long q = static_cast<long>(std::floor(p * M + 0.5));
  q = std::min(q, M - 1);
  const long r = std::max(0L, (M - q) / 2);
  std::nth_element(x.begin(), x.begin() + r, x.end());
  s.low = x[r];
  std::nth_element(x.begin(), x.begin() + std::min(r + q, M - 1), x.end());
  s.high = x[std::min(r + q, M - 1)];
  return s;
}

}  // namespace

double numerical_tolerance(double u, int significant_digits) {
  if (!(u > 0)) return 0.0;
  const int l = static_cast<int>(std::floor(std::log10(u))) - (significant_digits - 1);
  return 0.5 * std::pow(10.0, l);
}

MonteCarloResult monte_carlo(const Design& design, const Parameterisation& param,
                             const LinearModel& model, const WlsSolver& solver, const Estimate& est,
                             const Budget& budget, const MonteCarloOptions& options, const SetupSolver* setup) {
  if (options.batch_trials < kChunk || options.batch_trials % kChunk != 0) {
    throw InputError("options", "batch_trials", "must be a positive multiple of 1000");
  }
  if (options.max_trials < options.batch_trials) {
    throw InputError("options", "max_trials", "must be at least one batch");
  }
  if (options.significant_digits < 1)
    throw InputError("options", "significant_digits", "must be >= 1");
  MonteCarloResult res;
  res.seed = options.seed;
  res.coverage_probability = budget.coverage_probability;
  res.significant_digits = options.significant_digits;
  res.threads =
      options.threads > 0 ? options.threads : std::max(1u, std::thread::hardware_concurrency());
  const int n = static_cast<int>(model.J.rows());
  const int n_out = static_cast<int>(budget.values.size());
  if (n_out == 0 || n == 0) {
    res.message = "no determined value to propagate";
    return res;
  }
  {
    const double bytes = static_cast<double>(options.max_trials) * n_out * sizeof(float);
    if (bytes > static_cast<double>(options.max_sample_bytes)) {
      const long fits = static_cast<long>(static_cast<double>(options.max_sample_bytes) / (n_out * sizeof(float)));
      throw InputError("Monte Carlo", "max_trials",
                       std::to_string(options.max_trials) + " trials of " + std::to_string(n_out) + " values would keep " +
                           std::to_string(static_cast<long long>(bytes / (1 << 20))) + " MiB of samples, beyond the " +
                           std::to_string(options.max_sample_bytes >> 20) + " MiB limit: at most " +
                           std::to_string(fits / kChunk * kChunk) + " trials for this design (--mc-max-trials)");
    }
  }

  // Outputs: values = C theta; A = C G maps readings to values.
  const Eigen::MatrixXd C = budget_functions(param, budget);
  const Eigen::MatrixXd A = setup ? setup->left_gain(C) : Eigen::MatrixXd(C * solver.gain());
  const Eigen::MatrixXd AS = setup ? setup->setup_draw_map(C) : Eigen::MatrixXd();  // per N(0, 1) set-up draw
  // Per-angle values read a handful of the readings: a sparse A saves most of the products.
  const Eigen::SparseMatrix<double> A_sparse = A.sparseView(1.0, 1e-300);
  const bool sparse = A_sparse.nonZeros() < A.size() / 4;
  const Eigen::VectorXd base = A * (model.J * est.theta);
  const std::vector<SetupInput> inputs = setup_inputs(design);
  Eigen::MatrixXd AD;
  if (!inputs.empty()) AD = A * setup_sensitivity(design, param, model, inputs, est.theta);
  const int q_setup = static_cast<int>(AS.cols());

  const bool type_a = budget.type_a_scale.has_value();
  const NoiseModel& noise = design.noise;
  const double nu = type_a ? static_cast<double>(est.dof) : 0.0;

  std::vector<std::vector<float>> samples(n_out);
  auto run_chunks = [&](long first_chunk, long n_chunks, long offset) {
    parallel_for(n_chunks, res.threads, [&](long c) {
      thread_local Eigen::MatrixXd V, Q, out;  // per-thread buffers, reused across chunks
      V.resize(n, kChunk);
      std::mt19937_64 rng(
          splitmix64(options.seed ^ splitmix64(static_cast<std::uint64_t>(first_chunk + c))));
      std::uniform_real_distribution<double> uni(-noise.half_width_um, noise.half_width_um);
      std::normal_distribution<double> n01;
      std::chi_squared_distribution<double> chi2(nu > 0 ? nu : 1.0);
      for (long t = 0; t < kChunk; ++t) {
        if (type_a) {
          const double scale = noise.sigma_um() * *budget.type_a_scale * std::sqrt(nu / chi2(rng));
          for (int i = 0; i < n; ++i) V(i, t) = scale * n01(rng);
        } else if (noise.distribution == NoiseModel::Distribution::Uniform) {
          for (int i = 0; i < n; ++i) V(i, t) = uni(rng);
        } else {
          for (int i = 0; i < n; ++i) V(i, t) = noise.std_um * n01(rng);
        }
      }
      if (sparse) {
        out.noalias() = A_sparse * V;
      } else {
        out.noalias() = A * V;
      }
      if (!inputs.empty()) {
        Q.resize(static_cast<Eigen::Index>(inputs.size()), kChunk);
        for (long t = 0; t < kChunk; ++t) {
          for (size_t j = 0; j < inputs.size(); ++j)
            Q(static_cast<Eigen::Index>(j), t) = inputs[j].std_mm * n01(rng);
        }
        out.noalias() += AD * Q;
      }
      if (q_setup > 0) {
        Q.resize(q_setup, kChunk);
        for (long t = 0; t < kChunk; ++t) {
          for (int j = 0; j < q_setup; ++j) Q(j, t) = n01(rng);
        }
        out.noalias() += AS * Q;
      }
      const long at = offset + c * kChunk;
      for (int v = 0; v < n_out; ++v) {
        float* dst = samples[v].data() + at;
        for (long t = 0; t < kChunk; ++t) dst[t] = static_cast<float>(base(v) + out(v, t));
      }
    });
  };

  const long M = options.batch_trials;
  const double p = budget.coverage_probability;
  std::vector<std::vector<Stats>> history(n_out);
  long total = 0;
  while (total < options.max_trials) {
    const long batch = options.adaptive ? M : options.max_trials;
    for (auto& s : samples) s.resize(total + batch);
    run_chunks(total / kChunk, batch / kChunk, total);
    total += batch;
    if (options.progress) options.progress(total);
    if (!options.adaptive) break;
    for (int v = 0; v < n_out; ++v) {
      history[v].push_back(
          stats_of(std::vector<float>(samples[v].end() - batch, samples[v].end()), p));
    }
    const long h = static_cast<long>(history[0].size());
    if (h < 2) continue;
    bool stable = true;
    for (int v = 0; v < n_out && stable; ++v) {
      double m[4] = {0, 0, 0, 0}, ss[4] = {0, 0, 0, 0};
      for (const Stats& s : history[v]) {
        const double q[4] = {s.mean, s.std, s.low, s.high};
        for (int i = 0; i < 4; ++i) m[i] += q[i] / h;
      }
      for (const Stats& s : history[v]) {
        const double q[4] = {s.mean, s.std, s.low, s.high};
        for (int i = 0; i < 4; ++i) ss[i] += (q[i] - m[i]) * (q[i] - m[i]);
      }
      const double delta = numerical_tolerance(m[1], options.significant_digits);
      for (int i = 0; i < 4; ++i)
        stable = stable && 2.0 * std::sqrt(ss[i] / (h * (h - 1.0))) <= delta;
    }
    if (stable) {
      res.converged = true;
      break;
    }
  }
  res.trials = total;

  // Final statistics per value, in parallel over values.
  std::vector<Stats> final_stats(n_out);
  parallel_for(n_out, res.threads, [&](long v) {
    final_stats[v] = stats_of(std::move(samples[v]), p);
    std::vector<float>().swap(samples[v]);
  });
  for (int v = 0; v < n_out; ++v) {
    const ValueBudget& b = budget.values[v];
    const Stats& s = final_stats[v];
    MonteCarloValue mv;
    mv.station = b.station;
    mv.angle_deg = b.angle_deg;
    mv.error = b.error;
    mv.mean = s.mean;
    mv.std = s.std;
    mv.low = s.low;
    mv.high = s.high;
    mv.linear_value = b.value;
    mv.linear_u = b.u_c;
    mv.linear_U = b.U;
    mv.delta = numerical_tolerance(b.u_c, options.significant_digits);
    mv.d_low = std::abs(b.value - b.U - s.low);
    mv.d_high = std::abs(b.value + b.U - s.high);
    mv.validated = mv.d_low <= mv.delta && mv.d_high <= mv.delta;
    res.n_validated += mv.validated;
    res.values.push_back(mv);
  }
  res.message = std::to_string(res.n_validated) + " of " + std::to_string(n_out) +
                " values: the linear (GUM) interval is validated by Monte Carlo within its "
                "numerical tolerance";
  if (options.adaptive && !res.converged) {
    res.message += "; the adaptive procedure stopped at max_trials before its tolerance was met";
  }
  return res;
}

MonteCarloResult monte_carlo_a_priori(const Design& design, double coverage_probability,
                                      const MonteCarloOptions& options) {
  const Parameterisation param(design);
  const LinearModel model = design_model(design, param);
  const WlsSolver solver(model.J, model.sigma_um);
  BudgetOptions b;
  b.coverage_probability = coverage_probability;
  // At zero errors the ball placement (L, D, H) changes no reading; the length offsets
  // and centrings do, and stay.
  Design no_placement = design;
  no_placement.setup_std.L_mm = no_placement.setup_std.D_mm = no_placement.setup_std.H_mm = 0;
  for (Installation& in : no_placement.installations) in.setup_std.L_mm = in.setup_std.D_mm = in.setup_std.H_mm = std::nullopt;
  const SetupSolver setup(solver, setup_effects(no_placement, model, true));
  const Estimate est = setup.solve(model.y_um);
  const Budget budget = uncertainty_budget(no_placement, param, model, solver, est, b, &setup);
  return monte_carlo(no_placement, param, model, solver, est, budget, options, &setup);
}

}  // namespace dbbkit
