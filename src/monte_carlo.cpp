#include "dbbkit/monte_carlo.hpp"

#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

#include "dbbkit/error.hpp"
#include "dbbkit/parallel.hpp"
#include "dbbkit/setup.hpp"
#include "random.hpp"

namespace dbbkit {

namespace {

// A value that does not scatter (std 0) gets a window of half-width kDegenerateWindow |mean|
// (at least the smallest normal double) around its mean.
constexpr double kDegenerateWindow = 1e-12;

}  // namespace

namespace {

using detail::interval_ranks;
using detail::splitmix64;
using detail::Xoshiro256pp;

// Trials per random stream; the streams are independent of the thread count.
constexpr long kChunk = 1000;
constexpr long kFactoredSlab = 50;  // trials per product when the gain is not formed
constexpr int kBins = 4096;         // bins of a quantile window

struct Stats {
  double mean = 0, std = 0, low = 0, high = 0;
};

// Exact statistics of one batch (the adaptive rule's batch estimates, JCGM 101 §7.9).
Stats batch_stats(std::vector<float> x, double p) {
  Stats s;
  const long M = static_cast<long>(x.size());
  double sum = 0, sum2 = 0;
  for (float v : x) sum += v;
  s.mean = sum / M;
  for (float v : x) sum2 += (v - s.mean) * (v - s.mean);
  s.std = std::sqrt(sum2 / (M - 1));
  const auto [lo, hi] = interval_ranks(M, p);
  std::nth_element(x.begin(), x.begin() + lo, x.end());
  s.low = x[lo];
  std::nth_element(x.begin() + lo, x.begin() + hi, x.end());  // hi >= lo: the rest is above x[lo]
  s.high = x[hi];
  return s;
}

// A histogram over [a, a + kBins w) with the count below it: where an interval endpoint
// lies, to within w, without keeping the trials.
struct Window {
  double a = 0, w = 0, inv_w = 0;
  std::uint64_t below = 0;
  std::vector<std::uint32_t> counts;
  void reset(double lo, double hi) {
    a = lo;
    w = (hi - lo) / kBins;
    inv_w = 1.0 / w;
    below = 0;
    counts.assign(kBins, 0);
  }
  void add(double x) {
    const double t = (x - a) * inv_w;
    if (t < 0) {
      ++below;
    } else if (t < kBins) {
      ++counts[std::min(kBins - 1, static_cast<int>(t))];
    }
  }
  // The value of rank k (0-based) when it falls inside, by linear interpolation within its
  // bin (the order statistic lies in that bin: the error is below w).
  std::optional<double> locate(std::uint64_t k, std::pair<double, double>* bin = nullptr) const {
    if (k < below) return std::nullopt;
    std::uint64_t before = below;
    for (int b = 0; b < kBins; ++b) {
      if (k < before + counts[b]) {
        if (bin) *bin = {a + b * w, a + (b + 1) * w};
        return a + w * (b + (static_cast<double>(k - before) + 0.5) / counts[b]);
      }
      before += counts[b];
    }
    return std::nullopt;
  }
};

// Everything kept of one value: moments merged batch by batch (Chan, Golub and LeVeque),
// the range seen, and a window around each endpoint (0: low, 1: high).
struct Accumulator {
  std::uint64_t n = 0;
  double mean = 0, m2 = 0;
  double min = std::numeric_limits<double>::infinity(),
         max = -std::numeric_limits<double>::infinity();
  std::array<Window, 2> windows;

  void add_batch(const float* x, long m) {
    // One pass: the moments about the first sample (four partial sums in a fixed order),
    // the range, and each window's counts (the few trials inside binned, branch rarely taken).
    const double shift = x[0];
    double s1[4] = {0, 0, 0, 0}, s2[4] = {0, 0, 0, 0};
    double lo = x[0], hi = x[0];
    Window &low = windows[0], &high = windows[1];
    std::uint64_t low_below = 0, high_below = 0;
    const double la = low.a, li = low.inv_w, ha = high.a, hi_w = high.inv_w;
    const double kb = kBins;
    for (long t = 0; t < m; ++t) {
      const double v = x[t];
      const double d = v - shift;
      s1[t & 3] += d;
      s2[t & 3] += d * d;
      lo = v < lo ? v : lo;
      hi = v > hi ? v : hi;
      const double tl = (v - la) * li, th = (v - ha) * hi_w;
      low_below += tl < 0;
      high_below += th < 0;
      if (tl >= 0 && tl < kb) ++low.counts[std::min(kBins - 1, static_cast<int>(tl))];
      if (th >= 0 && th < kb) ++high.counts[std::min(kBins - 1, static_cast<int>(th))];
    }
    low.below += low_below;
    high.below += high_below;
    min = std::min(min, lo);
    max = std::max(max, hi);
    const double sum = (s1[0] + s1[1]) + (s1[2] + s1[3]), sum2 = (s2[0] + s2[1]) + (s2[2] + s2[3]);
    const double bm = shift + sum / m;
    const double bm2 = std::max(0.0, sum2 - sum * sum / m);
    const double n1 = static_cast<double>(n), n2 = static_cast<double>(m), nt = n1 + n2;
    const double delta = bm - mean;
    mean += delta * n2 / nt;
    m2 += bm2 + delta * delta * n1 * n2 / nt;
    n += static_cast<std::uint64_t>(m);
  }
};

// The half-width of a window around an endpoint first estimated from the first batch: the
// estimate's own scatter is about sqrt(p (1 - p) / M) / f, a few hundredths of a standard
// deviation for M = 10^4; half a standard deviation keeps the endpoint inside in practice,
// and when it does not, a refinement pass finds it (below).
double window_half_width(double std, double mean) {
  const double h = 0.5 * std;
  return h > 0 ? h : std::max(kDegenerateWindow * std::abs(mean), 1e-300);
}

}  // namespace

double numerical_tolerance(double u, int significant_digits) {
  if (!(u > 0)) return 0.0;
  const int l = static_cast<int>(std::floor(std::log10(u))) - (significant_digits - 1);
  return 0.5 * std::pow(10.0, l);
}

MonteCarloResult monte_carlo(const Design& design, const Parameterisation& param,
                             const LinearModel& model, const WlsSolver& solver, const Estimate& est,
                             const Budget& budget, const MonteCarloOptions& options,
                             const SetupSolver* setup) {
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
    return res;
  }
  // The trials of one batch are kept (4 bytes per value and trial), never more: the memory
  // does not grow with the number of trials.
  {
    const double bytes = static_cast<double>(options.batch_trials) * n_out * sizeof(float);
    if (bytes > static_cast<double>(options.max_sample_bytes)) {
      const long fits = static_cast<long>(static_cast<double>(options.max_sample_bytes) /
                                          (n_out * sizeof(float)));
      throw InputError(
          "Monte Carlo", "batch_trials",
          std::to_string(options.batch_trials) + " trials per batch of " + std::to_string(n_out) +
              " values would keep " + std::to_string(static_cast<long long>(bytes / (1 << 20))) +
              " MiB of samples, beyond the " + std::to_string(options.max_sample_bytes >> 20) +
              " MiB limit: at most " + std::to_string(fits / kChunk * kChunk) +
              " trials per batch for this design (--mc-batch)");
    }
  }

  // Outputs: values = C theta; A = C G maps readings to values.
  const FunctionRows C = budget_functions(param, budget);
  const Eigen::MatrixXd AS =
      setup ? setup->setup_draw_map(C) : Eigen::MatrixXd();  // per N(0, 1) set-up draw
  // Per-angle values read a handful of the readings: a sparse A saves most of the products
  // (and, without a set-up part, A is formed sparse: memory linear in the values).
  // With a set-up part, A is dense (values x readings); beyond max_dense_gain_bytes it is
  // not formed and A V is taken as a product (SetupSolver::left_gain_times).
  Eigen::MatrixXd A, L;
  Eigen::SparseMatrix<double, Eigen::RowMajor> A_sparse;
  const double a_size = static_cast<double>(n_out) * n;
  const bool factored = setup && setup->any() &&
                        a_size * sizeof(double) > static_cast<double>(options.max_dense_gain_bytes);
  if (factored) {
    L = setup->left_gain_setup(C);
  } else if (setup && setup->any()) {
    A = setup->left_gain(C);
    A_sparse = A.sparseView(1.0, 1e-300);
  } else {
    A_sparse = solver.J_theta_reading().left(C);
  }
  const bool sparse = !factored && static_cast<double>(A_sparse.nonZeros()) < a_size / 4;
  if (!factored && !sparse && A.size() == 0) A = Eigen::MatrixXd(A_sparse);
  const Eigen::VectorXd fitted = model.J * est.theta;
  const Eigen::VectorXd base = factored ? Eigen::VectorXd(setup->left_gain_times(C, L, fitted))
                                        : Eigen::VectorXd(A_sparse * fitted);
  const std::vector<SetupInput> inputs = setup_inputs(design);
  Eigen::MatrixXd AD;
  if (!inputs.empty()) {
    const Eigen::MatrixXd D = J_reading_setup(design, param, model, inputs, est.theta);
    AD = factored ? setup->left_gain_times(C, L, D) : Eigen::MatrixXd(A_sparse * D);
  }
  const int q_setup = static_cast<int>(AS.cols());

  const bool type_a = budget.type_a_scale.has_value();
  const NoiseModel& noise = design.noise;
  const double nu = type_a ? static_cast<double>(est.dof) : 0.0;

  // Trials [first_chunk, first_chunk + n_chunks) x kChunk, each chunk from its own stream,
  // into buffer (n_out x n_chunks kChunk, value-major).
  const long M = options.batch_trials;
  std::vector<float> buffer(static_cast<std::size_t>(n_out) * static_cast<std::size_t>(M));
  auto run_chunks = [&](long first_chunk, long n_chunks) {
    const long width = n_chunks * kChunk;
    parallel_for(n_chunks, res.threads, [&](long c) {
      thread_local Eigen::MatrixXd V, Q, out;  // per-thread buffers, reused across chunks
      V.resize(n, kChunk);
      Xoshiro256pp rng(
          splitmix64(options.seed ^ splitmix64(static_cast<std::uint64_t>(first_chunk + c))));
      const detail::NormalZiggurat n01;
      const detail::ChiSquared chi2(nu > 0 ? nu : 1.0);
      if (type_a) {
        for (long t = 0; t < kChunk; ++t) {
          const double scale = noise.sigma_um() * *budget.type_a_scale * std::sqrt(nu / chi2(rng));
          for (int i = 0; i < n; ++i) V(i, t) = scale * n01(rng);
        }
      } else if (noise.distribution == NoiseModel::Distribution::kUniform) {
        const double a2 = 2.0 * noise.half_width_um, a = noise.half_width_um;
        double* v = V.data();
        for (long k = 0; k < n * kChunk; ++k) v[k] = a2 * rng.uniform01() - a;
      } else {
        double* v = V.data();
        for (long k = 0; k < n * kChunk; ++k) v[k] = noise.std_um * n01(rng);
      }
      if (factored) {  // in slabs of trials: G0 V is unknowns x slab
        out.resize(n_out, kChunk);
        for (long t = 0; t < kChunk; t += kFactoredSlab) {
          const long w = std::min(kFactoredSlab, kChunk - t);
          out.middleCols(t, w) = setup->left_gain_times(C, L, V.middleCols(t, w));
        }
      } else if (sparse) {
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
      for (int v = 0; v < n_out; ++v) {
        float* dst = buffer.data() + static_cast<std::size_t>(v) * width + c * kChunk;
        for (long t = 0; t < kChunk; ++t) dst[t] = static_cast<float>(base(v) + out(v, t));
      }
    });
  };

  const double p = budget.coverage_probability;
  std::vector<Accumulator> acc(n_out);
  std::vector<std::vector<Stats>> history(n_out);
  long total = 0;
  while (total < options.max_trials) {
    const long batch = std::min(M, options.max_trials - total) / kChunk * kChunk;
    if (batch <= 0) break;
    run_chunks(total / kChunk, batch / kChunk);
    const bool first = total == 0;
    parallel_for(n_out, res.threads, [&](long v) {
      const float* x = buffer.data() + static_cast<std::size_t>(v) * batch;
      if (first || options.adaptive) {
        const Stats s = batch_stats(std::vector<float>(x, x + batch), p);
        if (options.adaptive) history[v].push_back(s);
        if (first) {  // the windows, around the first batch's endpoints
          const double h = window_half_width(s.std, s.mean);
          acc[v].windows[0].reset(s.low - h, s.low + h);
          acc[v].windows[1].reset(s.high - h, s.high + h);
        }
      }
      acc[v].add_batch(x, batch);
    });
    total += batch;
    if (options.progress) options.progress(total);
    if (!options.adaptive) continue;
    const long h = static_cast<long>(history[0].size());
    if (h < 2) continue;
    bool stable = true;
    for (int v = 0; v < n_out && stable; ++v) {
      const double delta = numerical_tolerance(
          detail::batch_spread(history[v], [](const Stats& s) { return s.std; }).mean,
          options.significant_digits);
      for (double Stats::*q : {&Stats::mean, &Stats::std, &Stats::low, &Stats::high}) {
        stable = stable && detail::batch_spread(history[v], [q](const Stats& s) {
                             return s.*q;
                           }).spread <= delta;
      }
    }
    if (stable) {
      res.converged = true;
      break;
    }
  }
  res.trials = total;

  // The endpoints: the order statistics of ranks r and r + q among all the trials, found in
  // their windows to within the bin width. Where one lies outside its window, or the bin is
  // wider than a tenth of the numerical tolerance, the trials are replayed (each chunk's
  // stream again) into a window over the bin or the range that holds it, until it is found
  // that finely: the memory stays that of one batch and the windows whatever the trials.
  const std::pair<long, long> ranks = interval_ranks(total, p);
  const std::array<std::uint64_t, 2> rank = {static_cast<std::uint64_t>(ranks.first),
                                             static_cast<std::uint64_t>(ranks.second)};
  struct Endpoint {
    double value = 0;
    bool found = false;
  };
  std::vector<std::array<Endpoint, 2>> endpoint(n_out);  // per value: low, high
  std::vector<double> resolution(n_out);
  for (int v = 0; v < n_out; ++v) {
    const double sd = acc[v].n > 1 ? std::sqrt(acc[v].m2 / (acc[v].n - 1)) : 0.0;
    const double tol =
        std::min(numerical_tolerance(sd, options.significant_digits),
                 numerical_tolerance(budget.values[v].u_c, options.significant_digits));
    resolution[v] = tol > 0 ? 0.1 * tol : 0.0;
  }
  // Where endpoint e (0 low, 1 high) of value v stands: found, or the interval to replay.
  auto settle = [&](int v, int e, std::vector<std::pair<double, double>>& replay) {
    const Window& w = acc[v].windows[e];
    const std::uint64_t k = rank[e];
    Endpoint& out = endpoint[v][e];
    std::pair<double, double> bin;
    if (const std::optional<double> x = w.locate(k, &bin)) {
      if (w.w <= resolution[v] || acc[v].min == acc[v].max) {
        out = {*x, true};
        return;
      }
      replay[2 * v + e] = bin;
    } else if (k < w.below) {
      replay[2 * v + e] = {acc[v].min, w.a};
    } else {
      replay[2 * v + e] = {w.a + kBins * w.w,
                           std::nextafter(acc[v].max, std::numeric_limits<double>::infinity())};
    }
  };
  for (int pass = 0; pass < 8; ++pass) {
    std::vector<std::pair<double, double>> replay(2 * n_out, {0.0, 0.0});
    bool any = false;
    for (int v = 0; v < n_out; ++v) {
      for (int e = 0; e < 2; ++e) {
        if (endpoint[v][e].found) continue;
        settle(v, e, replay);
        any = any || !endpoint[v][e].found;
      }
    }
    if (!any) break;
    // Replay: windows over the intervals to refine (the others left as they are).
    for (int v = 0; v < n_out; ++v) {
      for (int e = 0; e < 2; ++e) {
        if (endpoint[v][e].found) continue;
        const auto [lo, hi] = replay[2 * v + e];
        acc[v].windows[e].reset(lo, hi > lo ? hi : std::nextafter(lo, hi + 1.0));
      }
    }
    for (long done = 0; done < total;) {
      const long batch = std::min(M, total - done);
      run_chunks(done / kChunk, batch / kChunk);
      parallel_for(n_out, res.threads, [&](long v) {
        const float* x = buffer.data() + static_cast<std::size_t>(v) * batch;
        for (int e = 0; e < 2; ++e) {
          if (endpoint[v][e].found) continue;
          for (long t = 0; t < batch; ++t) acc[v].windows[e].add(x[t]);
        }
      });
      done += batch;
    }
    ++res.refinement_passes;
  }
  std::vector<float>().swap(buffer);

  for (int v = 0; v < n_out; ++v) {
    const ValueBudget& b = budget.values[v];
    MonteCarloValue mv;
    mv.station = b.station;
    mv.angle_deg = b.angle_deg;
    mv.error = b.error;
    mv.mean = acc[v].mean;
    mv.std = acc[v].n > 1 ? std::sqrt(acc[v].m2 / (acc[v].n - 1)) : 0.0;
    mv.low = endpoint[v][0].value;
    mv.high = endpoint[v][1].value;
    mv.linear_value = b.value;
    mv.linear_u = b.u_c;
    mv.linear_U = b.U;
    mv.delta = numerical_tolerance(b.u_c, options.significant_digits);
    mv.d_low = std::abs(b.value - b.U - mv.low);
    mv.d_high = std::abs(b.value + b.U - mv.high);
    mv.validated = endpoint[v][0].found && endpoint[v][1].found && mv.d_low <= mv.delta &&
                   mv.d_high <= mv.delta;
    res.n_validated += mv.validated;
    res.values.push_back(mv);
  }
  res.adaptive = options.adaptive;
  for (int v = 0; v < n_out; ++v)
    res.unplaced_endpoints += !endpoint[v][0].found + !endpoint[v][1].found;
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
  for (Installation& in : no_placement.installations)
    in.setup_std.L_mm = in.setup_std.D_mm = in.setup_std.H_mm = std::nullopt;
  const SetupSolver setup(solver, setup_effects(no_placement, model, true));
  const Estimate est = setup.solve(model.y_um);
  const Budget budget = uncertainty_budget(no_placement, param, model, solver, est, b, &setup);
  return monte_carlo(no_placement, param, model, solver, est, budget, options, &setup);
}

}  // namespace dbbkit
