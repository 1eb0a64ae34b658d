// Gain::left_l1 of a series' implicit gain: |c'G|_1 for each function c, G = Cov J' W, with
// J's rows factored as J(i, k m + a) = g_i(k) phi_a(angle_i) (SeriesRows). The entry of c'G
// at reading i is w_i g_i' s(angle_i), with s_k(b) = phi(b)' z_k and z = Cov c; nothing
// readings x parameters or values x readings is formed.
//
// A budget's functions are the errors' values at the readings' own angles, c = e_k (x) phi(a).
// For them s_e(b) = phi(a)' Cov_ke phi(b) = S_ke(a, b), and S_ke(a, b) = S_ek(b, a): one tile
// of S_ke(A, B) (A, B two blocks of angles) serves both the values at A against the readings
// at B and the values at B against the readings at A, so every pair of angles is formed once.
// Other functions take one dense product per function and angle.

#include "series_l1.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cstring>
#include <map>
#include <stdexcept>
#include <vector>

#include "cost_counters.hpp"
#include "dbbkit/estimate.hpp"
#include "dbbkit/linear_model.hpp"
#include "function_rows.hpp"
#include "simd.hpp"

#if defined(__SSE2__) || DBBKIT_WIDE_VECTORS
#include <immintrin.h>

#include "wls_solver.hpp"
#endif

// The kernels pass vectors by value only to functions always inlined into their caller, so no
// call's ABI depends on AVX (which -Wpsabi warns of); popped at the end of the file (a unity
// batch goes on with other files).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"

namespace dbbkit {

namespace {

// The two kernels, on GCC and Clang vector extensions of V (two doubles in the portable
// build, four where the processor has AVX: use_wide_vectors). Each lane sums in the same
// order as the scalar tail, with separate multiplies and adds, so that every width gives the
// same bits (EstimateTest: SeriesL1IsTheSameOnEveryVectorWidth).
template <class V>
constexpr int kLanes = static_cast<int>(sizeof(V) / sizeof(double));

// x in every lane, loaded on its own (a broadcast, not a pair of neighbours shuffled).
template <class V>
__attribute__((always_inline)) inline void broadcast(V& v, const double* x) {
  if constexpr (kLanes<V> == 2) {
    v = V{*x, *x};
  } else {
#if DBBKIT_WIDE_VECTORS && !defined(__clang__)
    // One vbroadcastsd from memory: GCC's own choice for AVX without AVX2 is a vmovddup and
    // a vinsertf128, two shuffles that cap the kernels' rate. (Clang emits the broadcast by
    // itself, and rejects a 256-bit operand here, outside the AVX function it is inlined into.)
    asm("vbroadcastsd %1, %0" : "=x"(v) : "m"(*x));
#else
    v = V{*x, *x, *x, *x};
#endif
  }
}

// v to p (unaligned), from a copy: the accumulators' own addresses are never taken, so that
// they stay in registers.
template <class V>
__attribute__((always_inline)) inline void store(double* p, V v) {
  std::memcpy(p, &v, sizeof(V));
}

// P = Z B' (Z: n x m, column-major, leading dimension ldz; B: nb x m, row-major, leading
// dimension ldb; P: n x nb, column-major, leading dimension n): the sum over the m
// coefficients in their order, for U vectors of rows of Z and two rows of B at a time. B is
// read by rows so that the two rows' entries are far apart, each a broadcast of its own.
template <class V, int U>
__attribute__((always_inline)) inline void product_block(const double* Z, Eigen::Index ldz,
                                                         Eigen::Index n, const double* B,
                                                         Eigen::Index ldb, Eigen::Index m,
                                                         Eigen::Index a, Eigen::Index t,
                                                         double* P) {
  constexpr int L = kLanes<V>;
  V acc0[U], acc1[U];
  for (int u = 0; u < U; ++u) acc0[u] = V{}, acc1[u] = V{};
  for (Eigen::Index j = 0; j < m; ++j) {
    V b0, b1;
    broadcast(b0, B + a * ldb + j);
    broadcast(b1, B + (a + 1) * ldb + j);
    const double* z = Z + j * ldz + t;
    for (int u = 0; u < U; ++u) {
      V zu;
      std::memcpy(&zu, z + u * L, sizeof(V));
#if DBBKIT_WIDE_VECTORS && !defined(__clang__)
      // One load for both products: GCC folds it into each (two loads), and loads, not
      // arithmetic, then bound the kernel.
      asm("" : "+x"(zu));
#endif
      acc0[u] += b0 * zu;
      acc1[u] += b1 * zu;
    }
  }
  for (int u = 0; u < U; ++u) {
    store(P + a * n + t + u * L, acc0[u]);
    store(P + (a + 1) * n + t + u * L, acc1[u]);
  }
}

template <class V>
__attribute__((always_inline)) inline void products(const double* Z, Eigen::Index ldz,
                                                    Eigen::Index n, const double* B,
                                                    Eigen::Index ldb, Eigen::Index nb,
                                                    Eigen::Index m, double* P) {
  constexpr int L = kLanes<V>, U = 4;
  auto one = [&](Eigen::Index a, Eigen::Index t) {  // one row of Z, one of B, lanes' order
    double acc = 0;
    for (Eigen::Index j = 0; j < m; ++j) acc += B[a * ldb + j] * Z[j * ldz + t];
    P[a * n + t] = acc;
  };
  Eigen::Index a = 0;
  for (; a + 2 <= nb; a += 2) {
    Eigen::Index t = 0;
    for (; t + U * L <= n; t += U * L) product_block<V, U>(Z, ldz, n, B, ldb, m, a, t, P);
    for (; t + L <= n; t += L) product_block<V, 1>(Z, ldz, n, B, ldb, m, a, t, P);
    for (; t < n; ++t) one(a, t), one(a + 1, t);
  }
  for (; a < nb; ++a) {
    for (Eigen::Index t = 0; t < n; ++t) one(a, t);
  }
}

// One angle's readings, each as its six weighted factors w_i g_i(k) (row-major, 6 a reading).
struct AngleReadings {
  const double* wg = nullptr;
  Eigen::Index count = 0;
};

// out(t) += sum over the angle's readings i of |sum_k w_i g_i(k) p_k(t)|, t < n: the
// functions on vector lanes, two vectors of them at a time (two independent sums), the
// six values loaded once for all the readings; each lane sums in the scalar tail's order.
template <class V, int U>
__attribute__((always_inline)) inline void abs_sums_block(const double* const* p, AngleReadings r,
                                                          Eigen::Index t, double* out) {
  constexpr int L = kLanes<V>;
  using Mask = decltype(V{} < V{});
  Mask magnitude;  // every bit but the sign's
  for (int l = 0; l < L; ++l) magnitude[l] = 0x7fffffffffffffffLL;
  V e[U][6], sum[U];
  for (int u = 0; u < U; ++u) {
    for (int k = 0; k < 6; ++k) std::memcpy(&e[u][k], p[k] + t + u * L, sizeof(V));
    sum[u] = V{};
  }
  for (Eigen::Index i = 0; i < r.count; ++i) {
    const double* g = r.wg + 6 * i;
    V gk, h[U];
    broadcast(gk, g);
    for (int u = 0; u < U; ++u) h[u] = gk * e[u][0];
    for (int k = 1; k < 6; ++k) {
      broadcast(gk, g + k);
      for (int u = 0; u < U; ++u) h[u] += gk * e[u][k];
    }
    for (int u = 0; u < U; ++u) sum[u] += (V)((Mask)h[u] & magnitude);
  }
  for (int u = 0; u < U; ++u) {
    V o;
    std::memcpy(&o, out + t + u * L, sizeof(V));
    store(out + t + u * L, o + sum[u]);
  }
}

template <class V>
__attribute__((always_inline)) inline void abs_sums(const double* const* p, Eigen::Index n,
                                                    AngleReadings r, double* out) {
  constexpr int L = kLanes<V>;
  Eigen::Index t = 0;
  for (; t + 2 * L <= n; t += 2 * L) abs_sums_block<V, 2>(p, r, t, out);
  for (; t + L <= n; t += L) abs_sums_block<V, 1>(p, r, t, out);
  for (; t < n; ++t) {
    double sum = 0;
    for (Eigen::Index i = 0; i < r.count; ++i) {
      const double* g = r.wg + 6 * i;
      double h = g[0] * p[0][t];
      for (int k = 1; k < 6; ++k) h += g[k] * p[k][t];
      sum += std::abs(h);
    }
    out[t] += sum;
  }
}

// to = from' (from: n x nb, column-major, leading dimension n; to: nb x n, leading dimension
// nb) on rows a0..a1 of from and its columns from b0 on: copies, the same bits at every width.
inline void transpose_part(const double* from, Eigen::Index n, Eigen::Index nb, double* to,
                           Eigen::Index a0, Eigen::Index a1, Eigen::Index b0) {
  for (Eigen::Index a = a0; a < a1; ++a) {
    for (Eigen::Index b = b0; b < nb; ++b) to[a * nb + b] = from[b * n + a];
  }
}

struct Kernels {
  void (*products)(const double*, Eigen::Index, Eigen::Index, const double*, Eigen::Index,
                   Eigen::Index, Eigen::Index, double*);
  void (*abs_sums)(const double* const*, Eigen::Index, AngleReadings, double*);
  void (*transpose)(const double*, Eigen::Index, Eigen::Index, double*);
};

using D2 = double __attribute__((vector_size(16)));

void products_portable(const double* Z, Eigen::Index ldz, Eigen::Index n, const double* B,
                       Eigen::Index ldb, Eigen::Index nb, Eigen::Index m, double* P) {
  products<D2>(Z, ldz, n, B, ldb, nb, m, P);
}

void abs_sums_portable(const double* const* p, Eigen::Index n, AngleReadings r, double* out) {
  abs_sums<D2>(p, n, r, out);
}

// Two by two blocks where SSE2 is the baseline (x86-64), element by element elsewhere.
void transpose_portable(const double* from, Eigen::Index n, Eigen::Index nb, double* to) {
#if defined(__SSE2__)
  Eigen::Index a = 0;
  for (; a + 2 <= n; a += 2) {
    Eigen::Index b = 0;
    for (; b + 2 <= nb; b += 2) {
      const __m128d c0 = _mm_loadu_pd(from + b * n + a), c1 = _mm_loadu_pd(from + (b + 1) * n + a);
      _mm_storeu_pd(to + a * nb + b, _mm_unpacklo_pd(c0, c1));
      _mm_storeu_pd(to + (a + 1) * nb + b, _mm_unpackhi_pd(c0, c1));
    }
    transpose_part(from, n, nb, to, a, a + 2, b);
  }
  transpose_part(from, n, nb, to, a, n, 0);
#else
  transpose_part(from, n, nb, to, 0, n, 0);
#endif
}

#if DBBKIT_WIDE_VECTORS
using D4 = double __attribute__((vector_size(32)));

__attribute__((target("avx"))) void products_avx(const double* Z, Eigen::Index ldz, Eigen::Index n,
                                                 const double* B, Eigen::Index ldb, Eigen::Index nb,
                                                 Eigen::Index m, double* P) {
  products<D4>(Z, ldz, n, B, ldb, nb, m, P);
}

__attribute__((target("avx"))) void abs_sums_avx(const double* const* p, Eigen::Index n,
                                                 AngleReadings r, double* out) {
  abs_sums<D4>(p, n, r, out);
}

// Four by four blocks: four columns' rows a..a+3 loaded, paired within lanes, then halves.
__attribute__((target("avx"))) void transpose_avx(const double* from, Eigen::Index n,
                                                  Eigen::Index nb, double* to) {
  Eigen::Index a = 0;
  for (; a + 4 <= n; a += 4) {
    Eigen::Index b = 0;
    for (; b + 4 <= nb; b += 4) {
      const __m256d c0 = _mm256_loadu_pd(from + b * n + a),
                    c1 = _mm256_loadu_pd(from + (b + 1) * n + a),
                    c2 = _mm256_loadu_pd(from + (b + 2) * n + a),
                    c3 = _mm256_loadu_pd(from + (b + 3) * n + a);
      const __m256d t0 = _mm256_unpacklo_pd(c0, c1), t1 = _mm256_unpackhi_pd(c0, c1),
                    t2 = _mm256_unpacklo_pd(c2, c3), t3 = _mm256_unpackhi_pd(c2, c3);
      _mm256_storeu_pd(to + a * nb + b, _mm256_permute2f128_pd(t0, t2, 0x20));
      _mm256_storeu_pd(to + (a + 1) * nb + b, _mm256_permute2f128_pd(t1, t3, 0x20));
      _mm256_storeu_pd(to + (a + 2) * nb + b, _mm256_permute2f128_pd(t0, t2, 0x31));
      _mm256_storeu_pd(to + (a + 3) * nb + b, _mm256_permute2f128_pd(t1, t3, 0x31));
    }
    transpose_part(from, n, nb, to, a, a + 4, b);
  }
  transpose_part(from, n, nb, to, a, n, 0);
}
#endif

// The kernels' width, chosen once a call (simd.hpp).
Kernels kernels() {
#if DBBKIT_WIDE_VECTORS
  if (detail::use_wide_vectors()) return {products_avx, abs_sums_avx, transpose_avx};
#endif
  return {products_portable, abs_sums_portable, transpose_portable};
}

// The readings angle by angle, their factors weighted: wg (6 a reading, in angle order).
struct ByAngle {
  std::vector<double> wg;
  std::vector<Eigen::Index> first;  // angle a's readings: [first[a], first[a + 1])
  AngleReadings at(Eigen::Index a) const {
    const auto i = static_cast<std::size_t>(a);
    return {wg.data() + 6 * first[i], first[i + 1] - first[i]};
  }
};

ByAngle readings_by_angle(const SeriesRows& s, const Eigen::VectorXd& weight) {
  const Eigen::Index na = s.basis.rows(), n = s.g.rows();
  ByAngle b;
  b.first.assign(static_cast<std::size_t>(na + 1), 0);
  for (Eigen::Index i = 0; i < n; ++i) ++b.first[static_cast<std::size_t>(s.angle[i] + 1)];
  for (std::size_t a = 0; a < static_cast<std::size_t>(na); ++a) b.first[a + 1] += b.first[a];
  std::vector<Eigen::Index> next(b.first.begin(), b.first.end() - 1);
  b.wg.resize(static_cast<std::size_t>(6 * n));
  for (Eigen::Index i = 0; i < n; ++i) {  // readings of one angle in their order
    const Eigen::Index at = next[static_cast<std::size_t>(s.angle[i])]++;
    for (int k = 0; k < 6; ++k) b.wg[static_cast<std::size_t>(6 * at + k)] = weight(i) * s.g(i, k);
  }
  return b;
}

constexpr Eigen::Index kTile = 32;  // slots a tile: 2 x 36 tiles of 8 KB stay in L2

// The readings' angles in slots, tile by tile (tiles of kTile slots, the last shorter).
// Paired (the basis has odd functions, and enough angles pair): a tile of 2h slots holds h
// angles in its first h slots and, in the next h, each one's reflection: another of the
// readings' angles whose basis row is the first's with the odd functions negated (exactly,
// detail::reflection_pairs), or, for an angle without one (or its own reflection), a slot
// with that row and no readings.
// The basis functions are then ordered even first. Unpaired: a slot per angle, in order.
//
// With the even and odd parts of phi, S(a, b) = phi(a)' Cov_ke phi(b) is E(a, b) + O(a, b)
// (the sums over b's even and odd functions) and S(a, b') = E(a, b) - O(a, b) for the
// reflection b' of b: a tile's rows against the first halves of the other's give both halves,
// at half the products.
struct Slots {
  Eigen::MatrixXd basis;               // slots x m, the functions in `order`
  Eigen::MatrixXd basis_t;             // its transpose (each slot's row contiguous)
  std::vector<Eigen::Index> angle;     // slot -> the readings' angle, or -1 (no readings)
  std::vector<Eigen::Index> of_angle;  // angle -> its slot
  std::vector<int> order;              // column j is basis function order[j]
  std::vector<Eigen::Index> first;     // paired: the first slot of pair q
  Eigen::Index even = 0;               // paired: the even functions (the first columns)
  bool paired = false;
};

Slots make_slots(const SeriesRows& s, const Eigen::MatrixXd& basis_t) {
  const Eigen::Index m = s.per_error, na = s.basis.rows();
  Slots out;
  const detail::Reflection reflection = detail::reflection_pairs(s);
  const std::vector<int>&even = reflection.even, &odd = reflection.odd;
  const std::vector<std::pair<Eigen::Index, Eigen::Index>>& pairs = reflection.pairs;
  // Pairing halves the products and adds a slot per unpaired angle: taken at up to 1.25 slots
  // an angle (the absolute sums grow with the slots).
  out.paired = !odd.empty() && 4 * 2 * static_cast<Eigen::Index>(pairs.size()) <= 5 * na;
  if (!out.paired) {
    out.basis = s.basis;
    out.basis_t = basis_t;
    out.angle.resize(static_cast<std::size_t>(na));
    out.order.resize(static_cast<std::size_t>(m));
    for (Eigen::Index a = 0; a < na; ++a) out.angle[static_cast<std::size_t>(a)] = a;
    for (int j = 0; j < static_cast<int>(m); ++j) out.order[static_cast<std::size_t>(j)] = j;
    out.of_angle = out.angle;
    return out;
  }
  out.order = even;
  out.order.insert(out.order.end(), odd.begin(), odd.end());
  out.even = static_cast<Eigen::Index>(even.size());
  const Eigen::Index np = static_cast<Eigen::Index>(pairs.size()), ns = 2 * np;
  constexpr Eigen::Index h_full = kTile / 2;
  out.basis.resize(ns, m);
  out.angle.assign(static_cast<std::size_t>(ns), -1);
  out.of_angle.assign(static_cast<std::size_t>(na), -1);
  for (Eigen::Index q = 0; q < np; ++q) {
    const Eigen::Index t = q / h_full, h = std::min(h_full, np - t * h_full), i = q - t * h_full;
    const Eigen::Index first = t * kTile + i, second = first + h;
    const auto [a, partner] = pairs[static_cast<std::size_t>(q)];
    for (Eigen::Index j = 0; j < m; ++j) {
      const int f = out.order[static_cast<std::size_t>(j)];
      out.basis(first, j) = s.basis(a, f);
      out.basis(second, j) = s.parity[static_cast<std::size_t>(f)] * s.basis(a, f);
    }
    out.first.push_back(first);
    out.angle[static_cast<std::size_t>(first)] = a;
    out.of_angle[static_cast<std::size_t>(a)] = first;
    if (partner >= 0) {
      out.angle[static_cast<std::size_t>(second)] = partner;
      out.of_angle[static_cast<std::size_t>(partner)] = second;
    }
  }
  out.basis_t = out.basis.transpose();
  return out;
}

// l1(a, k): |c'G|_1 of error k's value at the readings' angle a, for every angle and error
// (the tiles of the file's comment); basis_t is the basis row-major (m x na).
Eigen::MatrixXd values_l1(const SeriesRows& s, const Eigen::MatrixXd& basis_t,
                          const Eigen::MatrixXd& cov, const ByAngle& by, const Kernels& kern) {
  const Eigen::Index m = s.per_error, na = s.basis.rows(), p = 6 * m;
  const Slots slots = make_slots(s, basis_t);
  const Eigen::Index ns = slots.basis.rows(), even = slots.even;
  const double* basis = slots.basis_t.data();
  auto readings = [&](Eigen::Index slot) {
    const Eigen::Index a = slots.angle[static_cast<std::size_t>(slot)];
    return a >= 0 ? by.at(a) : AngleReadings{};
  };
  // Cov with each error's functions in the slots' order.
  Eigen::MatrixXd cov_ordered;
  if (slots.paired) {
    cov_ordered.resize(p, p);
    for (Eigen::Index y = 0; y < p; ++y) {
      const Eigen::Index fy = (y / m) * m + slots.order[static_cast<std::size_t>(y % m)];
      for (Eigen::Index x = 0; x < p; ++x)
        cov_ordered(x, y) = cov((x / m) * m + slots.order[static_cast<std::size_t>(x % m)], fy);
    }
  }
  const Eigen::MatrixXd& cov_o = slots.paired ? cov_ordered : cov;
  // X_k = Phi Cov_k,: (slots x p): z of error k's value at every slot; Cov_k,: read by rows is
  // Cov_:,k by columns (Cov is symmetric).
  // Paired: the even and odd sums for the pairs' first slots, the second's their difference.
  std::array<Eigen::MatrixXd, 6> X;
  const Eigen::Index np = static_cast<Eigen::Index>(slots.first.size());
  Eigen::MatrixXd firsts(np, m), xe(np, p), xo(np, p);
  for (Eigen::Index q = 0; q < np; ++q)
    firsts.row(q) = slots.basis.row(slots.first[static_cast<std::size_t>(q)]);
  for (int k = 0; k < 6; ++k) {
    X[k].resize(ns, p);
    if (!slots.paired) {
      kern.products(slots.basis.data(), ns, ns, cov_o.data() + k * m, p, p, m, X[k].data());
      continue;
    }
    kern.products(firsts.data(), np, np, cov_o.data() + k * m, p, p, even, xe.data());
    kern.products(firsts.data() + even * np, np, np, cov_o.data() + k * m + even, p, p, m - even,
                  xo.data());
    // Tile by tile the pairs' first and second slots run on from the tile's start and middle.
    for (Eigen::Index c = 0; c < p; ++c) {
      const double* e_c = xe.col(c).data();
      const double* o_c = xo.col(c).data();
      double* x_c = X[k].col(c).data();
      for (Eigen::Index q0 = 0; q0 < np; q0 += kTile / 2) {
        const Eigen::Index h = std::min(kTile / 2, np - q0);
        double* first = x_c + slots.first[static_cast<std::size_t>(q0)];
        double* second = first + h;
        for (Eigen::Index i = 0; i < h; ++i) {
          first[i] = e_c[q0 + i] + o_c[q0 + i];
          second[i] = e_c[q0 + i] - o_c[q0 + i];
        }
      }
    }
  }
  std::vector<double> S(static_cast<std::size_t>(36 * kTile * kTile));
  std::vector<double> St(S.size()), odd(static_cast<std::size_t>(kTile * kTile / 2));
  auto tile = [](std::vector<double>& v, int k, int e) {
    return v.data() + (6 * k + e) * kTile * kTile;
  };
  Eigen::MatrixXd l1 = Eigen::MatrixXd::Zero(ns, 6);
  for (Eigen::Index A = 0; A < ns; A += kTile) {
    const Eigen::Index nA = std::min(kTile, ns - A);
    for (Eigen::Index B = A; B < ns; B += kTile) {
      const Eigen::Index nB = std::min(kTile, ns - B);
      for (int k = 0; k < 6; ++k) {  // S_ke(A, B), nA x nB
        for (int e = 0; e < 6; ++e) {
          double* to = tile(S, k, e);
          const double* x = X[k].data() + e * m * ns + A;
          if (!slots.paired) {
            kern.products(x, ns, nA, basis + B * m, m, nB, m, to);
            continue;
          }
          // Against B's first halves: the even sums into S's first half, the odd aside; then
          // S(:, b) = E + O and S(:, b') = E - O.
          const Eigen::Index hB = nB / 2;
          kern.products(x, ns, nA, basis + B * m, m, hB, even, to);
          kern.products(x + even * ns, ns, nA, basis + B * m + even, m, hB, m - even, odd.data());
          for (Eigen::Index b = 0; b < hB; ++b) {
            double* first = to + b * nA;
            double* second = to + (hB + b) * nA;
            const double* o = odd.data() + b * nA;
            for (Eigen::Index r = 0; r < nA; ++r) {
              const double ev = first[r];
              first[r] = ev + o[r];
              second[r] = ev - o[r];
            }
          }
        }
      }
      // The values at A against the readings at B.
      for (int k = 0; k < 6; ++k) {
        for (Eigen::Index b = 0; b < nB; ++b) {
          const AngleReadings r = readings(B + b);
          if (r.count == 0) continue;
          const double* col[6];
          for (int e = 0; e < 6; ++e) col[e] = tile(S, k, e) + b * nA;
          kern.abs_sums(col, nA, r, l1.col(k).data() + A);
        }
      }
      if (B == A) continue;
      // The values at B against the readings at A: S_ek(B, A) = S_ke(A, B)'.
      for (int k = 0; k < 6; ++k) {
        for (int e = 0; e < 6; ++e) kern.transpose(tile(S, k, e), nA, nB, tile(St, e, k));
      }
      for (int e = 0; e < 6; ++e) {
        for (Eigen::Index a = 0; a < nA; ++a) {
          const AngleReadings r = readings(A + a);
          if (r.count == 0) continue;
          const double* col[6];
          for (int k = 0; k < 6; ++k) col[k] = tile(St, e, k) + a * nB;
          kern.abs_sums(col, nB, r, l1.col(e).data() + B);
        }
      }
    }
  }
  Eigen::MatrixXd at_angles(na, 6);
  for (Eigen::Index a = 0; a < na; ++a)
    at_angles.row(a) = l1.row(slots.of_angle[static_cast<std::size_t>(a)]);
  return at_angles;
}

// Which rows of C are one error's value at one of the readings' angles: (error, angle), or
// (-1, -1). The values must be the basis row to the bit.
std::vector<std::pair<int, Eigen::Index>> values_at_angles(const FunctionRows& C,
                                                           const SeriesRows& s) {
  const Eigen::Index m = s.per_error, na = s.basis.rows();
  std::map<std::vector<double>, Eigen::Index> angle_of;
  for (Eigen::Index a = 0; a < na; ++a) {
    std::vector<double> row(static_cast<std::size_t>(m));
    for (Eigen::Index j = 0; j < m; ++j) row[static_cast<std::size_t>(j)] = s.basis(a, j);
    angle_of.emplace(std::move(row), a);
  }
  std::vector<std::pair<int, Eigen::Index>> out(static_cast<std::size_t>(C.rows()), {-1, -1});
  std::vector<double> row(static_cast<std::size_t>(m));
  for (Eigen::Index v = 0; v < C.rows(); ++v) {
    std::fill(row.begin(), row.end(), 0.0);
    int error = -1;
    bool one_error = true;
    for (FunctionRows::InnerIterator it(C, v); it; ++it) {
      if (it.value() == 0.0) continue;
      const int k = static_cast<int>(it.col() / m);
      if (error >= 0 && k != error) one_error = false;
      error = k;
      row[static_cast<std::size_t>(it.col() % m)] = it.value();
    }
    if (!one_error || error < 0) continue;
    const auto found = angle_of.find(row);
    if (found != angle_of.end()) out[static_cast<std::size_t>(v)] = {error, found->second};
  }
  return out;
}

}  // namespace

detail::Reflection detail::reflection_pairs(const SeriesRows& s) {
  const Eigen::Index m = s.per_error, na = s.basis.rows();
  Reflection out;
  if (static_cast<Eigen::Index>(s.parity.size()) == m) {
    for (int j = 0; j < static_cast<int>(m); ++j)
      (s.parity[static_cast<std::size_t>(j)] > 0 ? out.even : out.odd).push_back(j);
  }
  if (out.odd.empty()) return out;
  std::map<std::vector<double>, Eigen::Index> angle_of;
  std::vector<double> row(static_cast<std::size_t>(m));
  for (Eigen::Index a = na - 1; a >= 0; --a) {  // a row's first angle kept
    for (Eigen::Index j = 0; j < m; ++j) row[static_cast<std::size_t>(j)] = s.basis(a, j);
    angle_of[row] = a;
  }
  std::vector<char> taken(static_cast<std::size_t>(na), 0);
  for (Eigen::Index a = 0; a < na; ++a) {
    if (taken[static_cast<std::size_t>(a)]) continue;
    taken[static_cast<std::size_t>(a)] = 1;
    bool own = true;  // the row is its own reflection (every odd function zero)
    for (Eigen::Index j = 0; j < m; ++j) {
      row[static_cast<std::size_t>(j)] = s.parity[static_cast<std::size_t>(j)] * s.basis(a, j);
      own = own && row[static_cast<std::size_t>(j)] == s.basis(a, j);
    }
    Eigen::Index partner = -1;
    const auto found = own ? angle_of.end() : angle_of.find(row);
    if (found != angle_of.end() && !taken[static_cast<std::size_t>(found->second)]) {
      partner = found->second;
      taken[static_cast<std::size_t>(partner)] = 1;
    }
    out.pairs.emplace_back(a, partner);
  }
  return out;
}

Eigen::MatrixXd detail::series_times(const SeriesRows& s, const Eigen::MatrixXd& M) {
  const Eigen::Index m = s.per_error, c = M.cols(), n = s.g.rows();
  if (M.rows() != 6 * m) throw std::logic_error("series_times: not the series' unknowns");
  // Column 6 t + k of E: error k of column t at every distinct angle (M's column t is its six
  // errors' coefficients one after another).
  const Eigen::MatrixXd E = s.basis * Eigen::Map<const Eigen::MatrixXd>(M.data(), m, 6 * c);
  Eigen::MatrixXd out(n, c);
  for (Eigen::Index t = 0; t < c; ++t) {
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Index a = s.angle[static_cast<std::size_t>(i)];
      double v = 0;
      for (int k = 0; k < 6; ++k) v += s.g(i, k) * E(a, 6 * t + k);
      out(i, t) = v;
    }
  }
  return out;
}

Eigen::MatrixXd detail::series_transpose_times(const SeriesRows& s, const Eigen::MatrixXd& M) {
  const Eigen::Index m = s.per_error, c = M.cols(), n = s.g.rows();
  if (M.rows() != n) throw std::logic_error("series_transpose_times: not the series' readings");
  // H(angle, 6 t + k): sum over the readings at the angle of g_i(k) M(i, t); then phi' H.
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(s.basis.rows(), 6 * c);
  for (Eigen::Index t = 0; t < c; ++t) {
    for (Eigen::Index i = 0; i < n; ++i) {
      const double v = M(i, t);
      if (v == 0.0) continue;
      const Eigen::Index a = s.angle[static_cast<std::size_t>(i)];
      for (int k = 0; k < 6; ++k) H(a, 6 * t + k) += s.g(i, k) * v;
    }
  }
  Eigen::MatrixXd out(6 * m, c);
  Eigen::Map<Eigen::MatrixXd>(out.data(), m, 6 * c).noalias() = s.basis.transpose() * H;
  return out;
}

bool detail::series_angles_paired(const SeriesRows& s) {
  return make_slots(s, s.basis.transpose()).paired;
}

Eigen::VectorXd Gain::left_l1(const FunctionRows& C) const {
  if (!series_l1()) throw std::logic_error("Gain::left_l1: not a series' implicit gain");
  cost::detail::counters().l1_rows += C.rows();
  const SeriesRows& s = *series_;
  const Eigen::Index m = s.per_error, na = s.basis.rows(), nv = C.rows();
  const Eigen::MatrixXd cov = cov_;  // p x p, p = 6 m
  const Kernels kern = kernels();
  const ByAngle by = readings_by_angle(s, weight_);
  const Eigen::MatrixXd basis_t =
      s.basis.transpose();  // m x na: the basis row-major, for both paths
  Eigen::VectorXd out = Eigen::VectorXd::Zero(nv);
  // The values at the readings' angles, through the tiles when they are at least half of
  // all 6 na (the tiles form every error at every angle).
  const auto at = values_at_angles(C, s);
  const auto n_at = std::count_if(at.begin(), at.end(), [](const auto& x) { return x.first >= 0; });
  const bool tiles = 2 * n_at >= 6 * na;
  if (tiles) {
    const Eigen::MatrixXd l1 = values_l1(s, basis_t, cov, by, kern);
    for (Eigen::Index v = 0; v < nv; ++v) {
      const auto [k, a] = at[static_cast<std::size_t>(v)];
      if (k >= 0) out(v) = l1(a, k);
    }
    if (n_at == nv) return out;  // every function was such a value
  }
  // The others: functions with one support go together, so that z = Cov c is one dense
  // product on the support's rows of Cov for a chunk of them; then s_k at every angle (one
  // product per error) and the readings summed angle by angle.
  constexpr std::size_t kChunk = 256;  // functions at a time
  std::array<Eigen::MatrixXd, 6> P;    // per error: functions x angles
  Eigen::MatrixXd Cs, Zt;
  for (const auto& [support, all_rows] : detail::rows_by_support(C)) {
    if (support.empty()) continue;  // the zero function's sum is 0
    std::vector<Eigen::Index> rows;
    for (Eigen::Index v : all_rows) {
      if (!tiles || at[static_cast<std::size_t>(v)].first < 0) rows.push_back(v);
    }
    if (rows.empty()) continue;
    const Eigen::Index k = static_cast<Eigen::Index>(support.size());
    Eigen::MatrixXd cov_s(k, cov.cols());  // the support's rows of Cov
    for (Eigen::Index j = 0; j < k; ++j)
      cov_s.row(j) = cov.row(support[static_cast<std::size_t>(j)]);
    for (std::size_t first = 0; first < rows.size(); first += kChunk) {
      const Eigen::Index w = static_cast<Eigen::Index>(std::min(kChunk, rows.size() - first));
      Cs.setZero(w, k);
      for (Eigen::Index t = 0; t < w; ++t) {
        Eigen::Index j = 0;
        for (FunctionRows::InnerIterator it(C, rows[first + static_cast<std::size_t>(t)]); it;
             ++it) {
          if (it.value() != 0.0) Cs(t, j++) = it.value();
        }
      }
      Zt.noalias() = Cs * cov_s;  // w x p: row t is (Cov c_t)'
      for (int e = 0; e < 6; ++e) {
        P[e].resize(w, na);
        kern.products(Zt.data() + e * m * w, w, w, basis_t.data(), m, na, m, P[e].data());
      }
      Eigen::VectorXd sums = Eigen::VectorXd::Zero(w);
      for (Eigen::Index a = 0; a < na; ++a) {
        const double* p[6];
        for (int e = 0; e < 6; ++e) p[e] = P[e].col(a).data();
        kern.abs_sums(p, w, by.at(a), sums.data());
      }
      for (Eigen::Index t = 0; t < w; ++t) out(rows[first + static_cast<std::size_t>(t)]) = sums(t);
    }
  }
  return out;
}

}  // namespace dbbkit

#pragma GCC diagnostic pop
