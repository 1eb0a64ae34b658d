#include "dbbkit/monte_carlo.hpp"

#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "dbbkit/error.hpp"
#include "dbbkit/parallel.hpp"
#include "dbbkit/setup.hpp"
#include "dbbkit/user_text.hpp"
#include "factorised.hpp"
#include "random.hpp"
#include "setup_solver.hpp"
#include "wls_solver.hpp"

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
constexpr long kChunk = 1000;       // a multiple of 8
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

// The float at or above x: for a float v, v < x exactly when v < float_at_or_above(x).
float float_at_or_above(double x) {
  if (!(x < static_cast<double>(std::numeric_limits<float>::max())))
    return std::numeric_limits<float>::infinity();
  if (!(x > -static_cast<double>(std::numeric_limits<float>::max())))
    return -std::numeric_limits<float>::max();
  float f = static_cast<float>(x);
  if (static_cast<double>(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

// A histogram over [a, a + kBins w) with the count below it: where an interval endpoint
// lies, to within w, without keeping the trials. A trial x (a float) is below when x < a and
// binned when it is not below and x < a + kBins w, both compared exactly (lo_f, hi_f).
struct Window {
  double a = 0, w = 0, inv_w = 0;
  float lo_f = 0, hi_f = 0;
  std::uint64_t below = 0;
  std::vector<std::uint32_t> counts;
  // Trials inside, not yet binned: binning them a few thousand at a time finds the counts in
  // the cache (a trial binned as it comes misses it: the windows of every value are touched
  // between two trials of one value).
  std::vector<float> pending;
  void reset(double lo, double hi) {
    a = lo;
    w = (hi - lo) / kBins;
    inv_w = 1.0 / w;
    lo_f = float_at_or_above(lo);
    hi_f = std::max(lo_f, float_at_or_above(a + kBins * w));
    below = 0;
    counts.assign(kBins, 0);
    pending.clear();
  }
  void flush() {
    for (float v : pending) bin(v);
    pending.clear();
  }
  bool inside(float x) const { return x >= lo_f && x < hi_f; }
  void bin(float x) {
    const double t = (static_cast<double>(x) - a) * inv_w;
    ++counts[std::clamp(static_cast<int>(t), 0, kBins - 1)];
  }
  void add(float x) {
    if (x < lo_f) {
      ++below;
    } else if (x < hi_f) {
      bin(x);
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

// Where the trials of one batch inside each window begin among the pending ones, and how
// many of the batch lay below it (for the batch's own endpoints).
struct Kept {
  std::array<std::size_t, 2> first{};
  std::array<std::uint64_t, 2> below{};
  double mean = 0, std = 0;
};

// Vectors of the GCC and Clang vector extensions: SIMD registers on any instruction set that
// has them (SSE2, NEON), plain scalar code otherwise.
using F4 = float __attribute__((vector_size(16)));
using I4 = std::int32_t __attribute__((vector_size(16)));
using D2 = double __attribute__((vector_size(16)));

// Bit l set when lane l of a comparison's mask (all ones or zero) is set.
inline int lane_bits(I4 mask) {
#if defined(__SSE2__)
  return _mm_movemask_ps(reinterpret_cast<__m128>(mask));
#else
  return (mask[0] & 1) | (mask[1] & 2) | (mask[2] & 4) | (mask[3] & 8);
#endif
}
// The four lanes of a float vector as two double vectors.
inline void widen(F4 f, D2& lo, D2& hi) {
#if defined(__SSE2__)
  const __m128 v = reinterpret_cast<__m128>(f);
  lo = reinterpret_cast<D2>(_mm_cvtps_pd(v));
  hi = reinterpret_cast<D2>(_mm_cvtps_pd(_mm_movehl_ps(v, v)));
#else
  lo = D2{f[0], f[1]};
  hi = D2{f[2], f[3]};
#endif
}
// Lane by lane minimum and maximum.
inline F4 vmin(F4 a, F4 b) {
#if defined(__SSE2__)
  return reinterpret_cast<F4>(_mm_min_ps(reinterpret_cast<__m128>(a), reinterpret_cast<__m128>(b)));
#else
  const I4 m = a < b;
  return reinterpret_cast<F4>((reinterpret_cast<I4>(a) & m) | (reinterpret_cast<I4>(b) & ~m));
#endif
}
inline F4 vmax(F4 a, F4 b) {
#if defined(__SSE2__)
  return reinterpret_cast<F4>(_mm_max_ps(reinterpret_cast<__m128>(a), reinterpret_cast<__m128>(b)));
#else
  const I4 m = a > b;
  return reinterpret_cast<F4>((reinterpret_cast<I4>(a) & m) | (reinterpret_cast<I4>(b) & ~m));
#endif
}
inline int ctz(int bits) { return __builtin_ctz(static_cast<unsigned>(bits)); }
constexpr std::size_t kFlush = 4096;  // pending trials of a window binned at once

// Everything kept of one value: moments merged batch by batch (Chan, Golub and LeVeque),
// the range seen, and a window around each endpoint (0: low, 1: high).
struct Accumulator {
  std::uint64_t n = 0;
  double mean = 0, m2 = 0;
  double min = std::numeric_limits<double>::infinity(),
         max = -std::numeric_limits<double>::infinity();
  std::array<Window, 2> windows;

  // One batch: the moments, the range, and each window's counts (its trials inside pending);
  // `kept` (when given) gets the batch's moments, where its trials inside each window begin
  // and the count below it.
  //
  // One pass on vectors of the GCC and Clang vector extensions (SSE2, NEON or plain scalar
  // code, whatever the target): the sums about the first trial in double (eight partial sums
  // in a fixed order: the result does not depend on the threads), the range, the counts below
  // each window, and which trials of each block of eight lie inside a window (a few per
  // cent): only those are touched one by one, kept pending.
  void add_batch(const float* x, long m, Kept* kept) {
    const double shift = x[0];
    Window &wl = windows[0], &wh = windows[1];
    const float l0 = wl.lo_f, l1 = wl.hi_f, h0 = wh.lo_f, h1 = wh.hi_f;
    if (kept) kept->first = {wl.pending.size(), wh.pending.size()};
    auto splat = [](float f) { return F4{f, f, f, f}; };
    const F4 L0 = splat(l0), L1 = splat(l1), H0 = splat(h0), H1 = splat(h1);
    const D2 S = {shift, shift};
    D2 s1[2] = {}, s2[2] = {};
    F4 lo = splat(x[0]), hi = lo;
    I4 below_low = {0, 0, 0, 0}, below_high = below_low;  // minus the counts
    long t = 0;
    for (; t + 8 <= m; t += 8) {
      F4 a, b;
      std::memcpy(&a, x + t, sizeof a);
      std::memcpy(&b, x + t + 4, sizeof b);
      for (const F4& f : {a, b}) {
        D2 d[2];
        widen(f, d[0], d[1]);
        for (int k = 0; k < 2; ++k) {
          d[k] -= S;
          s1[k] += d[k];
          s2[k] += d[k] * d[k];
        }
      }
      lo = vmin(vmin(a, b), lo);
      hi = vmax(vmax(a, b), hi);
      const I4 al = a < L0, bl = b < L0, ah = a < H0, bh = b < H0;
      below_low += al + bl;
      below_high += ah + bh;
      const int in_low = lane_bits(~al & (a < L1)) | lane_bits(~bl & (b < L1)) << 4;
      const int in_high = lane_bits(~ah & (a < H1)) | lane_bits(~bh & (b < H1)) << 4;
      if (in_low | in_high) {
        for (int bits = in_low; bits; bits &= bits - 1) wl.pending.push_back(x[t + ctz(bits)]);
        for (int bits = in_high; bits; bits &= bits - 1) wh.pending.push_back(x[t + ctz(bits)]);
      }
    }
    double sum = 0, sum2 = 0;
    for (int k = 0; k < 2; ++k) {
      sum += s1[k][0] + s1[k][1];
      sum2 += s2[k][0] + s2[k][1];
    }
    std::uint64_t bl = 0, bh = 0;
    for (; t < m; ++t) {
      const float v = x[t];
      const double d = static_cast<double>(v) - shift;
      sum += d;
      sum2 += d * d;
      lo[0] = std::min(lo[0], v);
      hi[0] = std::max(hi[0], v);
      bl += v < l0;
      bh += v < h0;
      if (wl.inside(v)) wl.pending.push_back(v);
      if (wh.inside(v)) wh.pending.push_back(v);
    }
    for (int l = 0; l < 4; ++l) {
      min = std::min(min, static_cast<double>(lo[l]));
      max = std::max(max, static_cast<double>(hi[l]));
      bl += static_cast<std::uint64_t>(-static_cast<std::int64_t>(below_low[l]));
      bh += static_cast<std::uint64_t>(-static_cast<std::int64_t>(below_high[l]));
    }
    wl.below += bl;
    wh.below += bh;
    if (kept) {
      kept->below = {bl, bh};
      kept->mean = shift + sum / m;
      kept->std = std::sqrt(std::max(0.0, sum2 - sum * sum / m) / (m - 1));
    }
    const double bm = shift + sum / m;
    const double bm2 = std::max(0.0, sum2 - sum * sum / m);
    const double n1 = static_cast<double>(n), n2 = static_cast<double>(m), nt = n1 + n2;
    const double delta = bm - mean;
    mean += delta * n2 / nt;
    m2 += bm2 + delta * delta * n1 * n2 / nt;
    n += static_cast<std::uint64_t>(m);
  }
};

// The statistics of one batch after add_batch: the moments from its sums, the endpoints
// among the trials kept inside the windows when their ranks fall there, else by selection
// over the whole batch (exact either way).
Stats kept_batch_stats(const float* x, long m, Accumulator& acc, const Kept& kept, double p) {
  Stats s;
  s.mean = kept.mean;
  s.std = kept.std;
  const auto [lo, hi] = interval_ranks(m, p);
  const std::array<long, 2> rank = {lo, hi};
  for (int e = 0; e < 2; ++e) {
    std::vector<float>& pending = acc.windows[e].pending;
    const auto in = pending.begin() + static_cast<std::ptrdiff_t>(kept.first[e]);
    const long k = rank[e] - static_cast<long>(kept.below[e]);
    if (!(k >= 0 && k < pending.end() - in)) {  // outside the window: the whole batch
      const Stats whole = batch_stats(std::vector<float>(x, x + m), p);
      s.low = whole.low;
      s.high = whole.high;
      return s;
    }
    std::nth_element(in, in + k, pending.end());  // reorders this batch's pending trials only
    (e == 0 ? s.low : s.high) = in[k];
  }
  return s;
}

// The half-width of a window around an endpoint first estimated from the first batch of M
// trials. The estimate's own scatter is sqrt(P (1 - P) / M) / f, P the tail probability and
// f the density at the endpoint, estimated from the batch's trials within a quarter of a
// standard deviation; eight times that (at least 0.02 and at most 0.5 standard deviations)
// keeps the endpoint of all the trials inside in practice, and when it does not, a refinement
// pass finds it (below). A narrow window bins few trials and places the endpoint finely.
double window_half_width(const std::vector<float>& x, double endpoint, double std, double mean,
                         double p) {
  if (!(std > 0)) return std::max(kDegenerateWindow * std::abs(mean), 1e-300);
  const double d = 0.25 * std;
  long near = 0;
  for (float v : x) near += std::abs(static_cast<double>(v) - endpoint) <= d;
  const double M = static_cast<double>(x.size());
  if (near < 20) return 0.5 * std;
  const double f = static_cast<double>(near) / (2.0 * d * M);
  const double tail = 0.5 * (1.0 - p);
  const double se = std::sqrt(tail * (1.0 - tail) / M) / f;
  return std::clamp(8.0 * se, 0.02 * std, 0.5 * std);
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
              " trials per batch for this design (" + option_name("--mc-batch") + ")");
    }
  }

  // Outputs: values = C theta; A = C G maps readings to values.
  const FunctionRows C = budget_functions(param, budget);
  const Eigen::MatrixXd AS =
      setup ? setup->setup_draw_map(C) : Eigen::MatrixXd();  // per N(0, 1) set-up draw
  // Per-angle values read a handful of the readings: a sparse A saves most of the products
  // (and, without a set-up part, A is formed sparse: memory linear in the values).
  // With a set-up part, A = A0 - L N with A0 = C G0 the map without it (as sparse) and a
  // correction of rank q (SetupSolver::setup_noise_map): A v costs A0's products plus
  // q (n + values), where the formed A (values x readings, dense) cost values x readings
  // (on a 0.5 deg C design of 7 installations, 5,040 readings and 4,320 values, q = 28:
  // 0.3 M against 21.8 M multiply-adds a trial). The correction's L is the set-up draws'
  // map (AS = L diag(1 / u)): both go through one product. Where A0 is dense and would take
  // more than max_dense_gain_bytes (a long series), it is not formed either and A V is a
  // product (SetupSolver::left_gain_times).
  Eigen::MatrixXd A, L, N;
  Eigen::SparseMatrix<double, Eigen::RowMajor> A_sparse;
  const double a_size = static_cast<double>(n_out) * n;
  const bool with_setup = setup && setup->any();
  A_sparse = solver.J_theta_reading().left(C);
  const bool factored = with_setup && static_cast<double>(A_sparse.nonZeros()) >= a_size / 4 &&
                        a_size * sizeof(double) > static_cast<double>(options.max_dense_gain_bytes);
  if (factored) {
    L = setup->left_gain_setup(C);
  } else if (with_setup) {
    L = setup->left_gain_setup(C);
    N = setup->setup_noise_map();
  }
  const bool sparse = !factored && static_cast<double>(A_sparse.nonZeros()) < a_size / 4;
  if (!factored && !sparse) A = Eigen::MatrixXd(A_sparse);
  const Eigen::VectorXd fitted = model.J * est.theta;
  const Eigen::VectorXd base =
      factored ? Eigen::VectorXd(setup->left_gain_times(C, L, fitted))
               : Eigen::VectorXd(A_sparse * fitted - (N.size() ? Eigen::VectorXd(L * (N * fitted))
                                                               : Eigen::VectorXd::Zero(n_out)));
  const std::vector<SetupInput> inputs = setup_inputs(design);
  Eigen::MatrixXd AD;
  if (!inputs.empty()) {
    const Eigen::MatrixXd D = J_reading_setup(design, param, model, inputs, est.theta);
    if (factored) {
      AD = setup->left_gain_times(C, L, D);
    } else {
      AD = A_sparse * D;
      if (N.size()) AD.noalias() -= L * (N * D);
    }
  }
  const int q_setup = static_cast<int>(AS.cols());
  Eigen::VectorXd setup_scale(q_setup);  // AS = L diag(setup_scale)
  for (int j = 0; j < q_setup; ++j) setup_scale(j) = 1.0 / setup->column_prior_std(j);

  const bool type_a = budget.type_a_scale.has_value();
  const NoiseModel& noise = design.noise;
  const double nu = type_a ? static_cast<double>(est.dof) : 0.0;

  // Trials [first_chunk, first_chunk + n_chunks) x kChunk, each chunk from its own stream,
  // into buffer (n_out x n_chunks kChunk, value-major). The draws are laid out reading by
  // reading (a row of kChunk trials each), so that every product is a sum of contiguous rows.
  using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  A_sparse.makeCompressed();
  const long M = options.batch_trials;
  std::vector<float> buffer(static_cast<std::size_t>(n_out) * static_cast<std::size_t>(M));
  auto run_chunks = [&](long first_chunk, long n_chunks) {
    const long width = n_chunks * kChunk;
    parallel_for(n_chunks, res.threads, [&](long c) {
      thread_local RowMatrix V, Q, out;  // per-thread buffers, reused across chunks
      thread_local std::vector<std::uint64_t> words;
      V.resize(n, kChunk);
      detail::BlockXoshiro rng(
          splitmix64(options.seed ^ splitmix64(static_cast<std::uint64_t>(first_chunk + c))));
      const detail::NormalZiggurat n01;
      auto normals = [&](RowMatrix& X, const auto& row_scale) {
        for (Eigen::Index i = 0; i < X.rows(); ++i) {
          double* x = X.row(i).data();
          const double s = row_scale(i);
          for (long t = 0; t < kChunk; ++t) x[t] = s * n01(rng);
        }
      };
      if (type_a) {
        // Each trial's noise is normal scaled by sqrt(nu / chi2_nu): Student t marginals.
        const detail::ChiSquared chi2(nu > 0 ? nu : 1.0);
        std::array<double, kChunk> scale;
        for (long t = 0; t < kChunk; ++t)
          scale[t] = noise.sigma_um() * *budget.type_a_scale * std::sqrt(nu / chi2(rng));
        normals(V, [](Eigen::Index) { return 1.0; });
        for (int i = 0; i < n; ++i) {
          double* x = V.row(i).data();
          for (long t = 0; t < kChunk; ++t) x[t] *= scale[t];
        }
      } else if (noise.distribution == NoiseModel::Distribution::kUniform) {
        const double a2 = 2.0 * noise.half_width_um, a = noise.half_width_um;
        words.resize(kChunk);
        for (int i = 0; i < n; ++i) {
          rng.fill(words.data(), kChunk);
          double* x = V.row(i).data();
          for (long t = 0; t < kChunk; ++t) x[t] = a2 * detail::unit_interval(words[t]) - a;
        }
      } else {
        normals(V, [&](Eigen::Index) { return noise.std_um; });
      }
      out.resize(n_out, kChunk);
      if (factored) {  // in slabs of trials: G0 V is unknowns x slab
        for (long t = 0; t < kChunk; t += kFactoredSlab) {
          const long w = std::min(kFactoredSlab, kChunk - t);
          out.middleCols(t, w) = setup->left_gain_times(C, L, Eigen::MatrixXd(V.middleCols(t, w)));
        }
      } else if (sparse) {
        // Each value's row is the sum of its readings' rows, each times its weight, taken
        // eight trials at a time in registers; without set-up draws the sum goes straight
        // into the batch as floats.
        const int* outer = A_sparse.outerIndexPtr();
        const int* inner = A_sparse.innerIndexPtr();
        const double* weight = A_sparse.valuePtr();
        const bool direct = inputs.empty() && q_setup == 0;
        for (int v = 0; v < n_out; ++v) {
          double* o = out.row(v).data();
          float* dst = buffer.data() + static_cast<std::size_t>(v) * width + c * kChunk;
          for (long t = 0; t < kChunk; t += 8) {
            D2 sum[4] = {};
            for (int k = outer[v]; k < outer[v + 1]; ++k) {
              const D2 a = {weight[k], weight[k]};
              const double* x = V.row(inner[k]).data() + t;
              for (int j = 0; j < 4; ++j) {
                D2 xj;
                std::memcpy(&xj, x + 2 * j, sizeof xj);
                sum[j] += a * xj;
              }
            }
            if (direct) {
              const double b = base(v);
              for (int j = 0; j < 4; ++j) {
                dst[t + 2 * j] = static_cast<float>(b + sum[j][0]);
                dst[t + 2 * j + 1] = static_cast<float>(b + sum[j][1]);
              }
            } else {
              std::memcpy(o + t, sum, sizeof sum);
            }
          }
        }
        if (direct) return;
      } else {
        out.noalias() = A * V;
      }
      if (!inputs.empty()) {
        Q.resize(static_cast<Eigen::Index>(inputs.size()), kChunk);
        normals(Q, [&](Eigen::Index j) { return inputs[static_cast<size_t>(j)].std_mm; });
        out.noalias() += AD * Q;
      }
      if (q_setup > 0) {
        Q.resize(q_setup, kChunk);
        normals(Q, [](Eigen::Index) { return 1.0; });
        if (N.size()) {  // the draws' and the noise's set-up parts through L at once
          Q = setup_scale.asDiagonal() * Q;
          Q.noalias() -= N * V;
          out.noalias() += L * Q;
        } else {
          out.noalias() += AS * Q;
        }
      }
      for (int v = 0; v < n_out; ++v) {
        float* dst = buffer.data() + static_cast<std::size_t>(v) * width + c * kChunk;
        const double* o = out.row(v).data();
        const double b = base(v);
        for (long t = 0; t < kChunk; ++t) dst[t] = static_cast<float>(b + o[t]);
      }
    });
  };

  const double p = budget.coverage_probability;
  std::vector<Accumulator> acc(n_out);
  std::vector<std::vector<Stats>> history(n_out);
  std::vector<Kept> kept(options.adaptive ? n_out : 0);
  long total = 0;
  while (total < options.max_trials) {
    const long batch = std::min(M, options.max_trials - total) / kChunk * kChunk;
    if (batch <= 0) break;
    run_chunks(total / kChunk, batch / kChunk);
    const bool first = total == 0;
    parallel_for(n_out, res.threads, [&](long v) {
      const float* x = buffer.data() + static_cast<std::size_t>(v) * batch;
      if (first) {  // the windows, around the first batch's endpoints
        std::vector<float> sample(x, x + batch);
        const Stats s = batch_stats(sample, p);
        if (options.adaptive) history[v].push_back(s);
        for (int e = 0; e < 2; ++e) {
          const double at = e == 0 ? s.low : s.high;
          const double h = window_half_width(sample, at, s.std, s.mean, p);
          acc[v].windows[e].reset(at - h, at + h);
        }
      }
      // After the first batch, an adaptive run's batch estimates come from the trials kept.
      Kept* k = !first && options.adaptive ? &kept[static_cast<std::size_t>(v)] : nullptr;
      acc[v].add_batch(x, batch, k);
      if (k) history[v].push_back(kept_batch_stats(x, batch, acc[v], *k, p));
      for (Window& w : acc[v].windows) {
        if (w.pending.size() >= kFlush) w.flush();
      }
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
  for (Accumulator& a : acc) {
    for (Window& w : a.windows) w.flush();
  }

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
  const WlsSolver solver(model);
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
