#pragma once
// Random numbers, order statistics and the adaptive stopping rule shared by the Monte Carlo
// propagations
// (monte_carlo.cpp, iso230.cpp): internal to the library.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

namespace dbbkit::detail {

inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

// xoshiro256++ (Blackman and Vigna, 2019): a UniformRandomBitGenerator of period 2^256 - 1,
// its state filled from a splitmix64 sequence (as its authors advise).
class Xoshiro256pp {
 public:
  using result_type = std::uint64_t;
  explicit Xoshiro256pp(std::uint64_t seed) {
    for (int i = 0; i < 4; ++i)
      s_[i] = splitmix64(seed + static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ULL);
  }
  // From a given state (not all zero).
  static Xoshiro256pp from_state(const std::uint64_t (&state)[4]) {
    Xoshiro256pp g(0);
    for (int i = 0; i < 4; ++i) g.s_[i] = state[i];
    return g;
  }
  static constexpr result_type min() { return 0; }
  static constexpr result_type max() { return ~result_type{0}; }
  result_type operator()() {
    const std::uint64_t result = rotl(s_[0] + s_[3], 23) + s_[0];
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  // Uniform on [0, 1) with 53 random bits (every double k 2^-53).
  double uniform01() { return static_cast<double>(operator()() >> 11) * 0x1.0p-53; }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4];
};

// Four xoshiro256++ streams side by side, their words interleaved (word k from lane k mod 4):
// the state is kept in local arrays over the lanes, which the compiler keeps in vector
// registers on any SIMD instruction set, so the words come at several times the rate of one
// stream. Lane l is seeded from splitmix64(seed, l) as Xoshiro256pp is from its seed.
class Xoshiro256ppX4 {
 public:
  using result_type = std::uint64_t;
  static constexpr int kLanes = 4;
  explicit Xoshiro256ppX4(std::uint64_t seed) {
    for (int l = 0; l < kLanes; ++l) {
      const std::uint64_t lane_seed =
          splitmix64(seed ^ splitmix64(0xD1B54A32D192ED03ULL * static_cast<std::uint64_t>(l + 1)));
      for (int i = 0; i < 4; ++i)
        s_[i][l] = splitmix64(lane_seed + static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ULL);
    }
  }
  // The state of lane l (as Xoshiro256pp::from_state takes it).
  void lane_state(int l, std::uint64_t (&state)[4]) const {
    for (int i = 0; i < 4; ++i) state[i] = s_[i][l];
  }
  // n words (n a multiple of kLanes). The states are pairs of lanes in 128-bit vectors of the
  // GCC and Clang vector extensions, which become SIMD registers on any instruction set that
  // has them (SSE2, NEON) and scalar code otherwise.
  void fill(std::uint64_t* out, std::size_t n) {
    using U2 = std::uint64_t __attribute__((vector_size(16)));
    U2 a0, a1, a2, a3, b0, b1, b2, b3;  // lanes 0-1 and 2-3
    std::memcpy(&a0, s_[0], sizeof a0);
    std::memcpy(&a1, s_[1], sizeof a1);
    std::memcpy(&a2, s_[2], sizeof a2);
    std::memcpy(&a3, s_[3], sizeof a3);
    std::memcpy(&b0, s_[0] + 2, sizeof b0);
    std::memcpy(&b1, s_[1] + 2, sizeof b1);
    std::memcpy(&b2, s_[2] + 2, sizeof b2);
    std::memcpy(&b3, s_[3] + 2, sizeof b3);
    auto step = [](U2& s0, U2& s1, U2& s2, U2& s3) {
      const U2 sum = s0 + s3;
      const U2 r = ((sum << 23) | (sum >> 41)) + s0;
      const U2 t = s1 << 17;
      s2 ^= s0;
      s3 ^= s1;
      s1 ^= s2;
      s0 ^= s3;
      s2 ^= t;
      s3 = (s3 << 45) | (s3 >> 19);
      return r;
    };
    for (std::size_t k = 0; k < n; k += kLanes) {
      const U2 ra = step(a0, a1, a2, a3);
      const U2 rb = step(b0, b1, b2, b3);
      std::memcpy(out + k, &ra, sizeof ra);
      std::memcpy(out + k + 2, &rb, sizeof rb);
    }
    std::memcpy(s_[0], &a0, sizeof a0);
    std::memcpy(s_[1], &a1, sizeof a1);
    std::memcpy(s_[2], &a2, sizeof a2);
    std::memcpy(s_[3], &a3, sizeof a3);
    std::memcpy(s_[0] + 2, &b0, sizeof b0);
    std::memcpy(s_[1] + 2, &b1, sizeof b1);
    std::memcpy(s_[2] + 2, &b2, sizeof b2);
    std::memcpy(s_[3] + 2, &b3, sizeof b3);
  }

 private:
  std::uint64_t s_[4][kLanes];
};

// Uniform on [0, 1) from the top 52 bits of a word, every double k 2^-52 equally likely: the
// bits become the mantissa of a double in [1, 2), less one (exact). Unlike the conversion of
// an integer, it is a shift, an or and a subtraction on any SIMD instruction set.
inline double unit_interval(std::uint64_t w) {
  const std::uint64_t bits = (w >> 12) | 0x3FF0000000000000ULL;
  double x;
  std::memcpy(&x, &bits, sizeof x);
  return x - 1.0;
}

// The words of a Xoshiro256ppX4 in blocks, one at a time, for the draws that take a varying
// number of words (the ziggurat's normals, the chi-squared deviates): the same
// UniformRandomBitGenerator interface as Xoshiro256pp.
class BlockXoshiro {
 public:
  using result_type = std::uint64_t;
  explicit BlockXoshiro(std::uint64_t seed) : gen_(seed) {}
  static constexpr result_type min() { return 0; }
  static constexpr result_type max() { return ~result_type{0}; }
  result_type operator()() {
    if (pos_ == kBlock) {
      gen_.fill(block_, kBlock);
      pos_ = 0;
    }
    return block_[pos_++];
  }
  double uniform01() { return static_cast<double>(operator()() >> 11) * 0x1.0p-53; }
  // n words straight from the generator (n a multiple of 4), after the block's rest.
  void fill(std::uint64_t* out, std::size_t n) {
    pos_ = kBlock;  // the block's rest is dropped: the streams stay a function of the seed
    gen_.fill(out, n);
  }

 private:
  static constexpr int kBlock = 256;
  Xoshiro256ppX4 gen_;
  std::uint64_t block_[kBlock];
  int pos_ = kBlock;
};

// Standard normal deviates by the ziggurat method (Marsaglia and Tsang, J. Stat. Softw. 5(8),
// 2000) with 256 layers of equal area v under f(x) = exp(-x^2 / 2), x >= 0. Layer 0 is the base
// rectangle [0, r] x [0, f(r)] with the tail beyond r (drawn by Marsaglia's exact tail method);
// layer i >= 1 spans x in [0, x_i] and y in [f(x_i), f(x_{i+1})]. One 64-bit word gives the layer
// (8 bits), the sign (1 bit) and the abscissa (53 bits); about 99 % of deviates need nothing more
// than a table look-up, a product and a comparison. Unlike std::normal_distribution, whose
// algorithm each standard library chooses, the stream is the same on every platform.
class NormalZiggurat {
 public:
  static constexpr int kLayers = 256;
  static constexpr double kR = 3.6541528853610088;  // x_1: x_256 = 0 with 256 layers of equal area

  // x[0] = v / f(r) (the base layer's width with its tail folded in), x[1] = r, ..., x[256] = 0;
  // fx[i] = f(x[i]).
  struct Tables {
    std::array<double, kLayers + 1> x{}, fx{};
    double area = 0;  // v
  };
  static const Tables& tables() {
    static const Tables t = [] {
      Tables s;
      const double fr = std::exp(-0.5 * kR * kR);
      s.area = kR * fr + std::sqrt(std::acos(-1.0) / 2) * std::erfc(kR / std::sqrt(2.0));
      s.x[0] = s.area / fr;
      s.x[1] = kR;
      for (int i = 1; i < kLayers - 1; ++i) {
        // The layer above x[i] has area v: x[i] (f(x[i+1]) - f(x[i])) = v.
        s.x[i + 1] = std::sqrt(-2.0 * std::log(s.area / s.x[i] + std::exp(-0.5 * s.x[i] * s.x[i])));
      }
      s.x[kLayers] = 0;
      for (int i = 0; i <= kLayers; ++i) s.fx[i] = std::exp(-0.5 * s.x[i] * s.x[i]);
      return s;
    }();
    return t;
  }

  template <class Rng>
  double operator()(Rng& rng) const {
    const Tables& t = tables_;
    for (;;) {
      const std::uint64_t bits = rng();
      const int i = static_cast<int>(bits & 0xFF);
      const bool negative = (bits & 0x100) != 0;
      const double x = static_cast<double>(bits >> 11) * 0x1.0p-53 * t.x[i];
      if (x < t.x[i + 1]) return negative ? -x : x;  // inside the rectangle under the curve
      if (i == 0) {
        // The tail x > r: x = r + a with a = -ln(U1) / r, accepted when 2 (-ln U2) > a^2.
        double a, b;
        do {
          a = -std::log(1.0 - rng.uniform01()) / kR;
          b = -std::log(1.0 - rng.uniform01());
        } while (2.0 * b < a * a);
        return negative ? -(kR + a) : kR + a;
      }
      // The wedge between the curve and the layer's inner rectangle.
      const double y = t.fx[i] + rng.uniform01() * (t.fx[i + 1] - t.fx[i]);
      if (y < std::exp(-0.5 * x * x)) return negative ? -x : x;
    }
  }

 private:
  const Tables& tables_ = tables();
};

// Chi-squared deviates with nu > 0 degrees of freedom: 2 Gamma(nu / 2) by Marsaglia and Tsang's
// method (ACM TOMS 26(3), 2000) on the ziggurat normals; for nu / 2 < 1, Gamma(a + 1) U^(1/a).
class ChiSquared {
 public:
  explicit ChiSquared(double nu) : shape_(nu / 2) {
    const double a = shape_ < 1 ? shape_ + 1 : shape_;
    d_ = a - 1.0 / 3.0;
    c_ = 1.0 / std::sqrt(9.0 * d_);
  }
  template <class Rng>
  double operator()(Rng& rng) const {
    double g;
    for (;;) {
      const double z = normal_(rng);
      const double w = 1.0 + c_ * z;
      if (w <= 0) continue;
      const double v = w * w * w;
      const double u = 1.0 - rng.uniform01();  // (0, 1]
      if (std::log(u) < 0.5 * z * z + d_ - d_ * v + d_ * std::log(v)) {
        g = d_ * v;
        break;
      }
    }
    if (shape_ < 1) g *= std::pow(1.0 - rng.uniform01(), 1.0 / shape_);
    return 2.0 * g;
  }

 private:
  double shape_, d_, c_;
  NormalZiggurat normal_;
};

// The ranks (0-based, in ascending order) of the probabilistically symmetric p-interval's
// endpoints among M trials (JCGM 101 §7.7): q = floor(p M + 1/2), r = (M - q) / 2.
inline std::pair<long, long> interval_ranks(long M, double p) {
  long q = static_cast<long>(std::floor(p * M + 0.5));
  q = std::min(q, M - 1);
  const long r = std::max(0L, (M - q) / 2);
  return {r, std::min(r + q, M - 1)};
}

// The adaptive rule's test (JCGM 101 §7.9.4) on one output quantity: the mean of its h >= 2
// batch estimates get(b) and twice the standard deviation of that mean, 2 s / sqrt(h).
struct BatchSpread {
  double mean = 0, spread = 0;
};
template <class Batch, class Get>
BatchSpread batch_spread(const std::vector<Batch>& batches, Get get) {
  const double h = static_cast<double>(batches.size());
  BatchSpread r;
  for (const Batch& b : batches) r.mean += get(b) / h;
  double ss = 0;
  for (const Batch& b : batches) ss += (get(b) - r.mean) * (get(b) - r.mean);
  r.spread = 2.0 * std::sqrt(ss / (h * (h - 1.0)));
  return r;
}

}  // namespace dbbkit::detail
