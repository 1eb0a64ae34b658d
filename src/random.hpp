#pragma once
// Random numbers, order statistics and the adaptive stopping rule shared by the Monte Carlo
// propagations
// (monte_carlo.cpp, iso230.cpp): internal to the library.

#include <algorithm>
#include <cmath>
#include <cstdint>
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
    for (int i = 0; i < 4; ++i) s_[i] = splitmix64(seed + static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ULL);
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
