#pragma once
// Options shared by the commands that report uncertainty.

#include <CLI/CLI.hpp>
#include <chrono>
#include <iostream>
#include <memory>

#include "checks.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/monte_carlo.hpp"

namespace dbbkit::cli {

struct UncertaintyArgs {
  double coverage = 0.95;
  bool monte_carlo = false;
  MonteCarloOptions mc;
};

inline void add_uncertainty_options(CLI::App* sub, const std::shared_ptr<UncertaintyArgs>& args) {
  sub->add_option("--coverage", args->coverage, "Coverage probability of the expanded uncertainty")
      ->check(finite_in(limits::kMinCoverage, limits::kMaxCoverage))
      ->capture_default_str();
  sub->add_flag("--monte-carlo", args->monte_carlo,
                "Check the linear result by Monte Carlo (JCGM 101)");
  sub->add_option("--mc-seed", args->mc.seed, "Monte Carlo seed")
      ->transform(seed_value())
      ->capture_default_str();
  sub->add_option("--mc-threads", args->mc.threads, "Monte Carlo threads (0: all)")
      ->transform(thread_count())
      ->capture_default_str();
  sub->add_option("--mc-max-trials", args->mc.max_trials, "Most Monte Carlo trials")
      ->transform(integer_in(limits::kMinMonteCarloTrials, limits::kMaxMonteCarloTrials))
      ->capture_default_str();
  sub->add_option("--mc-batch", args->mc.batch_trials,
                  "Trials per adaptive batch (a multiple of 1000)")
      ->transform(integer_in(limits::kMinMonteCarloTrials, limits::kMaxMonteCarloBatch))
      ->capture_default_str();
  sub->add_option("--mc-digits", args->mc.significant_digits,
                  "Significant digits of u that set the numerical tolerance")
      ->transform(integer_in(limits::kMinSignificantDigits, limits::kMaxSignificantDigits))
      ->capture_default_str();
}

// Progress of a Monte Carlo run on stderr, once a second after the first second.
inline void report_progress(MonteCarloOptions& mc, bool quiet) {
  if (quiet) return;
  const auto start = std::chrono::steady_clock::now();
  auto last = std::make_shared<double>(0.0);
  mc.progress = [start, last](long trials) {
    const double t =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (t < 1.0 || t - *last < 1.0) return;
    *last = t;
    std::cerr << "monte carlo: " << trials << " trials, " << static_cast<int>(t) << " s\n";
  };
}

}  // namespace dbbkit::cli
