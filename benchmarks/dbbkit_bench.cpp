// Speed targets of dbbkit (benchmarks/RESULTS.md records the figures, each beside its NumPy
// peer or its kernel measured in the same run):
//   evaluate the paper's C design:                        <= 150 us on one thread
//   Monte Carlo, 10^6 trials of the paper C identification: <= 0.25 s on 2 threads, <= 64 MB
//   identify 360 angles, 12 installations, Fourier order 20: <= 25 ms, >= 15x the NumPy peer
//   optimize the formats.md C kit (designs/kits/c-turntable-kit.json): <= 0.5 s on one thread
//   the set-up-inclusive total worst case:                >= 200,000 designs/s
//   readings from a raw trace of 10^7 samples (read and dwells found): in seconds, memory
//   linear in the samples

#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>

#include "../src/factorised.hpp"
#include "../src/random.hpp"
#include "../src/setup_solver.hpp"
#include "../src/wls_solver.hpp"
#include "dbbkit/diagnose.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/kit_io.hpp"
#include "dbbkit/io/trace_io.hpp"
#include "dbbkit/linear_model.hpp"
#include "dbbkit/monte_carlo.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/optimize.hpp"
#include "dbbkit/setup.hpp"
#include "dbbkit/simulate.hpp"
#include "dbbkit/trace.hpp"
#include "dbbkit/uncertainty.hpp"

namespace {

using namespace dbbkit;

Design paper_c() {
  return io::read_design_file(std::string(DBBKIT_SOURCE_DIR) + "/designs/paper-c-turntable.json");
}

// What optimize needs of a design: the worst-case a-priori uncertainty (the fast path).
void BM_WorstCasePaperC(benchmark::State& state) {
  const Design d = paper_c();
  for (auto _ : state) benchmark::DoNotOptimize(design_worst_case(d, 100.0).worst_std_um);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_WorstCasePaperC)->Unit(benchmark::kMicrosecond);

// The same number through the general solver: the stacked Jacobian, its SVD and the covariance.
void BM_WorstCasePaperCGeneralSolver(benchmark::State& state) {
  const Design d = paper_c();
  for (auto _ : state) {
    const Parameterisation param(d);
    const LinearModel m = design_model(d, param);
    const WlsSolver solver(m.J, m.sigma_um);
    Estimate prior = solver.a_priori();
    prior.theta = Eigen::VectorXd::Zero(prior.n_unknowns);
    const WorstCase w = worst_case(errors_at_stations(param, prior), 100.0);
    benchmark::DoNotOptimize(w.worst_std_um);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_WorstCasePaperCGeneralSolver)->Unit(benchmark::kMicrosecond);

// The criterion of a search under declared set-up tolerances (10 um length offset, 5 um
// centring on every installation): the worst case of the total, by the per-angle path
// (fast_worst_total: the total alone as the search scores it, and with the noise part as
// evaluate reports it) and through the stacked model (dense_worst_total). Target: the
// total within 3x of the noise-only worst case above.
Design paper_c_with_setup() {
  Design d = paper_c();
  d.setup_std.length_offset_um = 10;
  d.setup_std.centring_um = 5;
  return d;
}
void BM_WorstTotalPaperC(benchmark::State& state) {
  const Design d = paper_c_with_setup();
  for (auto _ : state)
    benchmark::DoNotOptimize(fast_worst_total(d, 100.0, false)->total.worst_std_um);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_WorstTotalPaperC)->Unit(benchmark::kMicrosecond);
// The same as the search scores it: the stations of its angles formed once for every candidate.
void BM_WorstTotalPaperCStationsGiven(benchmark::State& state) {
  const Design d = paper_c_with_setup();
  const AngleStations stations(d.axis, d.angles_deg);
  for (auto _ : state)
    benchmark::DoNotOptimize(fast_worst_total(d, 100.0, false, &stations)->total.worst_std_um);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_WorstTotalPaperCStationsGiven)->Unit(benchmark::kMicrosecond);
// The same pair on the design the search chose for the kit with set-up tolerances
// (12 installations, 37 angles): the size the search scores.
Design setup_kit_design() {
  return io::read_design_file(std::string(DBBKIT_SOURCE_DIR) +
                              "/designs/c-turntable-kit-setup-optimized.json");
}
void BM_WorstCaseSetupKitDesign(benchmark::State& state) {
  Design d = setup_kit_design();
  d.setup_std = {};
  for (Installation& in : d.installations) in.setup_std = {};
  for (auto _ : state) benchmark::DoNotOptimize(fast_worst_case(d, 100.0)->worst_std_um);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_WorstCaseSetupKitDesign)->Unit(benchmark::kMicrosecond);
void BM_WorstTotalSetupKitDesign(benchmark::State& state) {
  const Design d = setup_kit_design();
  for (auto _ : state)
    benchmark::DoNotOptimize(fast_worst_total(d, 100.0, false)->total.worst_std_um);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_WorstTotalSetupKitDesign)->Unit(benchmark::kMicrosecond);
// What the readings keep of each declared set-up effect (the search's detection requirement):
// closed form and, beside it, the stacked model's SVD per effect.
void BM_SetupInformationSetupKitDesign(benchmark::State& state) {
  const Design d = setup_kit_design();
  for (auto _ : state) benchmark::DoNotOptimize(fast_setup_information(d)->effects.size());
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SetupInformationSetupKitDesign)->Unit(benchmark::kMicrosecond);
void BM_SetupInformationSetupKitDesignGeneralSolver(benchmark::State& state) {
  const Design d = setup_kit_design();
  for (auto _ : state) benchmark::DoNotOptimize(dense_setup_information(d).effects.size());
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SetupInformationSetupKitDesignGeneralSolver)->Unit(benchmark::kMicrosecond);
void BM_WorstTotalWithNoisePartPaperC(benchmark::State& state) {
  const Design d = paper_c_with_setup();
  for (auto _ : state)
    benchmark::DoNotOptimize(fast_worst_total(d, 100.0, true)->noise->worst_std_um);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_WorstTotalWithNoisePartPaperC)->Unit(benchmark::kMicrosecond);
void BM_WorstTotalPaperCGeneralSolver(benchmark::State& state) {
  const Design d = paper_c_with_setup();
  for (auto _ : state) benchmark::DoNotOptimize(dense_worst_total(d, 100.0).total.worst_std_um);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_WorstTotalPaperCGeneralSolver)->Unit(benchmark::kMicrosecond);

// The whole search over the kit of formats.md, on 1 and 2 threads.
void BM_OptimizeFormatsKit(benchmark::State& state) {
  const Kit kit =
      io::read_kit_file(std::string(DBBKIT_SOURCE_DIR) + "/designs/kits/c-turntable-kit.json");
  OptimizeOptions o;
  o.threads = static_cast<int>(state.range(0));
  long evaluations = 0;
  for (auto _ : state) {
    const OptimizeResult r = optimize_kit(kit, o);
    evaluations = r.evaluations;
    benchmark::DoNotOptimize(r.best->objective);
  }
  state.counters["designs_scored"] = static_cast<double>(evaluations);
}
BENCHMARK(BM_OptimizeFormatsKit)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);

// The whole evaluate (indices, criteria, null-space description as well).
void BM_EvaluatePaperC(benchmark::State& state) {
  const Design d = paper_c();
  for (auto _ : state) benchmark::DoNotOptimize(evaluate_design(d, 100.0).worst.worst_std_um);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_EvaluatePaperC)->Unit(benchmark::kMicrosecond);

// The drawing kernel alone: the paper's C design's 133 rectangular readings for 10^6 trials
// (1.33e8 uniform deviates) from the four-lane generator, as the Monte Carlo draws them, into a
// buffer of one chunk (summed so that nothing is optimised away).
void BM_KernelDrawsPaperC(benchmark::State& state) {
  std::vector<std::uint64_t> words(1000);
  std::vector<double> x(1000);
  for (auto _ : state) {
    detail::Xoshiro256ppX4 rng(1);
    double sum = 0;
    for (long row = 0; row < 133 * 1000; ++row) {
      rng.fill(words.data(), words.size());
      for (std::size_t t = 0; t < words.size(); ++t)
        x[t] = 2.5 * detail::unit_interval(words[t]) - 1.25;
      sum += x[row % 1000];
    }
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * 133000000L);
}
BENCHMARK(BM_KernelDrawsPaperC)->Unit(benchmark::kMillisecond);

void BM_MonteCarloPaperC(benchmark::State& state) {
  const Design d = paper_c();
  MonteCarloOptions o;
  o.adaptive = false;
  o.max_trials = state.range(0);
  o.threads = static_cast<int>(state.range(1));
  for (auto _ : state) benchmark::DoNotOptimize(monte_carlo_a_priori(d, 0.95, o).trials);
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_MonteCarloPaperC)
    ->Args({10000, 1})
    ->Args({100000, 2})
    ->Args({1000000, 2})
    ->Args({1000000, 1})
    ->Args({10000000, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Monte Carlo of a 0.5 deg per-angle C design (720 angles, 7 installations: 5,040 readings,
// 4,320 values), without (range 1 = 0) and with (1) set-up tolerances of 10 um length offset
// and 5 um centring on every installation. Target: with them, at most 3 times the time per
// trial without them (the set-up part is a correction of rank 28 beside the sparse gain).
void BM_MonteCarloHalfDegree(benchmark::State& state) {
  Design d = paper_c();
  d.angles_deg.clear();
  for (int i = 0; i < 720; ++i) d.angles_deg.push_back(0.5 * i);
  if (state.range(1)) {
    d.setup_std.length_offset_um = 10;
    d.setup_std.centring_um = 5;
  }
  // The model, its factorisation and the budget are formed once: the loop times the trials.
  const Parameterisation param(d);
  const LinearModel model = design_model(d, param);
  const WlsSolver solver(model);
  const SetupSolver setup(solver, setup_effects(d, model, true));
  const Estimate est = setup.solve(model.y_um);
  const Budget budget = uncertainty_budget(d, param, model, solver, est, BudgetOptions{}, &setup);
  MonteCarloOptions o;
  o.adaptive = false;
  o.max_trials = state.range(0);
  o.batch_trials = state.range(0);
  o.threads = 1;
  for (auto _ : state)
    benchmark::DoNotOptimize(monte_carlo(d, param, model, solver, est, budget, o, &setup).trials);
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_MonteCarloHalfDegree)
    ->Args({10000, 0})
    ->Args({10000, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// A large series model: `angles` angles over a full turn, 12 installations, Fourier order `order`.
Design fourier_design(int angles, int order) {
  Design d = paper_c();
  d.angles_deg.clear();
  for (int i = 0; i < angles; ++i) d.angles_deg.push_back(360.0 * i / angles);
  d.errors = {ErrorModel::Kind::kFourier, order};
  for (int k = 0; k < 5; ++k) {
    Installation in = d.installations[k % 7];
    in.id = "x" + std::to_string(k);
    in.L_mm += 30 + 10 * k;
    in.H_mm += 20 * k;
    d.installations.push_back(in);
  }
  return d;
}

// The series sizes: angles over a turn and order (readings grow with the angles, unknowns with
// the order).
void series_sizes(benchmark::internal::Benchmark* b) {
  for (const auto& [angles, order] :
       {std::pair{360, 20}, {180, 20}, {90, 20}, {720, 20}, {360, 10}, {360, 5}})
    b->Args({angles, order});
}

// Readings of the series design: every coefficient 1, the declared noise.
std::vector<Reading> series_readings(const Design& d) {
  Truth t;
  t.model = d.errors;
  for (int k = 0; k < 6; ++k) t.coefficients[k].assign(2 * d.errors.order + 1, 1.0);
  return simulate(d, t, 1);
}

// What the NumPy peer (benchmarks/peer_series_identify.py) times: from the model's rows to the
// estimate and its covariance (the factorisation, the estimate, the residual and chi2).
void BM_SolveFourier(benchmark::State& state) {
  const Design d =
      fourier_design(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const Parameterisation param(d);
  const LinearModel model = build_linear_model(d, param, series_readings(d));
  for (auto _ : state) {
    const WlsSolver solver(model);
    benchmark::DoNotOptimize(solver.solve(model.y_um).chi2);
  }
  state.counters["readings"] = static_cast<double>(model.J.rows());
  state.counters["unknowns"] = static_cast<double>(model.J.cols());
}
BENCHMARK(BM_SolveFourier)->Apply(series_sizes)->Unit(benchmark::kMillisecond);

// The first-order bias bound's kernel alone: |c'G|_1 of every error's value at every angle
// (what identify's bound_first_order_bias asks of the series' gain).
void BM_BiasBoundFourier(benchmark::State& state) {
  const Design d =
      fourier_design(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const Parameterisation param(d);
  const LinearModel model = build_linear_model(d, param, series_readings(d));
  const WlsSolver solver(model);
  std::vector<Eigen::Triplet<double>> entries;
  int row = 0;
  for (int s = 0; s < param.n_stations(); ++s) {
    const Eigen::SparseMatrix<double> E = param.error_functions(s);
    for (int e = 0; e < 6; ++e, ++row) {
      for (Eigen::SparseMatrix<double>::InnerIterator it(E, e); it; ++it)
        entries.emplace_back(row, static_cast<int>(it.row()), it.value());
    }
  }
  FunctionRows C(row, model.J.cols());
  C.setFromTriplets(entries.begin(), entries.end());
  for (auto _ : state) benchmark::DoNotOptimize(solver.J_theta_reading().left_l1(C).sum());
  state.counters["values"] = static_cast<double>(C.rows());
  state.counters["readings"] = static_cast<double>(model.J.rows());
}
BENCHMARK(BM_BiasBoundFourier)->Apply(series_sizes)->Unit(benchmark::kMillisecond);

void BM_IdentifyFourier(benchmark::State& state) {
  const Design d =
      fourier_design(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const std::vector<Reading> readings = series_readings(d);
  IdentifyOptions options;  // the estimate; the error motion values' Monte Carlo is not part of it
  options.iso_motion.enabled = false;
  for (auto _ : state) benchmark::DoNotOptimize(identify(d, readings, options).estimate.chi2);
  state.counters["readings"] = static_cast<double>(readings.size());
  state.counters["unknowns"] = 6.0 * (2 * d.errors.order + 1);
}
BENCHMARK(BM_IdentifyFourier)->Apply(series_sizes)->Unit(benchmark::kMillisecond);

}  // namespace

// Growth with the size of the design (issue of linear time and memory): the paper's C
// design at step 360/a deg (a angles, per angle), evaluate_design plus the effect
// detectability that `evaluate` reports; and a C design of k installations at 20 deg.
// The complexity fit is printed beside the times; RESULTS.md keeps the growth tables.
Design scaled_c(int angles, int installations) {
  Design d = paper_c();
  if (angles > 0) {
    d.angles_deg.clear();
    for (int i = 0; i <= angles; ++i) d.angles_deg.push_back(360.0 * i / angles);
  }
  if (installations > 0) {
    const std::vector<Installation> base = d.installations;
    d.installations.clear();
    for (int k = 0; k < installations; ++k) {
      Installation in = base[k % base.size()];
      in.id = "i" + std::to_string(k);
      if (in.L_mm > 0) in.L_mm += 0.4 * k;
      d.installations.push_back(in);
    }
  }
  return d;
}

void BM_EvaluateGrowthAngles(benchmark::State& state) {
  const Design d = scaled_c(static_cast<int>(state.range(0)), 0);
  const std::vector<Reading> r = nominal_readings(d);
  for (auto _ : state) {
    benchmark::DoNotOptimize(evaluate_design(d, 100.0).worst.worst_std_um);
    benchmark::DoNotOptimize(effect_detectability(d, r).size());
  }
  state.SetComplexityN(state.range(0));
}
BENCHMARK(BM_EvaluateGrowthAngles)
    ->Arg(18)
    ->Arg(36)
    ->Arg(72)
    ->Arg(144)
    ->Arg(288)
    ->Arg(576)
    ->Arg(1152)
    ->Arg(3600)
    ->Complexity()
    ->Unit(benchmark::kMillisecond);

// identify of nominal readings (the estimate, its budget, ISO 230 quantities and the
// first-order check) of the same designs: 3600 angles is a 0.1 deg step.
void BM_IdentifyGrowthAngles(benchmark::State& state) {
  const Design d = scaled_c(static_cast<int>(state.range(0)), 0);
  const std::vector<Reading> r = nominal_readings(d);
  const IdentifyOptions o;
  for (auto _ : state) benchmark::DoNotOptimize(identify(d, r, o).estimate.chi2);
  state.SetComplexityN(state.range(0));
}
BENCHMARK(BM_IdentifyGrowthAngles)
    ->Arg(18)
    ->Arg(144)
    ->Arg(576)
    ->Arg(1152)
    ->Arg(3600)
    ->Complexity()
    ->Unit(benchmark::kMillisecond);

void BM_EvaluateGrowthInstallations(benchmark::State& state) {
  const Design d = scaled_c(0, static_cast<int>(state.range(0)));
  const std::vector<Reading> r = nominal_readings(d);
  for (auto _ : state) {
    benchmark::DoNotOptimize(evaluate_design(d, 100.0).worst.worst_std_um);
    benchmark::DoNotOptimize(effect_detectability(d, r).size());
  }
  state.SetComplexityN(state.range(0));
}
BENCHMARK(BM_EvaluateGrowthInstallations)
    ->Arg(7)
    ->Arg(28)
    ->Arg(112)
    ->Arg(500)
    ->Complexity()
    ->Unit(benchmark::kMillisecond);

// identify of the 0.1 deg C design read k times over (25,207 k readings; k = 40 is about a
// million readings): the solve, budget and checks on readings already in memory.
void BM_IdentifyGrowthReadings(benchmark::State& state) {
  const Design d = scaled_c(3600, 0);
  const std::vector<Reading> once = nominal_readings(d);
  std::vector<Reading> r;
  r.reserve(once.size() * static_cast<std::size_t>(state.range(0)));
  for (int k = 0; k < state.range(0); ++k) r.insert(r.end(), once.begin(), once.end());
  const IdentifyOptions o;
  for (auto _ : state) benchmark::DoNotOptimize(identify(d, r, o).estimate.chi2);
  state.counters["readings"] = static_cast<double>(r.size());
  state.SetComplexityN(static_cast<benchmark::IterationCount>(r.size()));
}
BENCHMARK(BM_IdentifyGrowthReadings)
    ->Arg(1)
    ->Arg(4)
    ->Arg(10)
    ->Arg(40)
    ->Complexity()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// diagnose of clean readings (the search that adds nothing) of the C design at 360/a deg:
// the effect columns span every station and are solved as a border (EstimateOptions), so
// the time stays near linear in the angles (3600: a 0.1 deg step).
void BM_DiagnoseGrowthAngles(benchmark::State& state) {
  const Design d = scaled_c(static_cast<int>(state.range(0)), 0);
  Truth truth;  // no error: the residual is the declared noise alone
  truth.model = d.errors;
  for (double a : d.angles_deg) truth.per_angle.emplace_back(a, Vector6d::Zero());
  const std::vector<Reading> r = simulate(d, truth, 5);
  for (auto _ : state) benchmark::DoNotOptimize(diagnose(d, r).added.size());
  state.SetComplexityN(state.range(0));
}
BENCHMARK(BM_DiagnoseGrowthAngles)
    ->Arg(18)
    ->Arg(72)
    ->Arg(360)
    ->Arg(1152)
    ->Arg(3600)
    ->Complexity()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

// dbbkit readings on one installation's raw trace of 10^7 samples at 1 kHz (2.8 h: the paper's
// C design swept both ways, 40 s dwells, slow moves), written once as CSV: the reader and the
// dwell search, items = samples.
void BM_ReadingsFromTrace(benchmark::State& state) {
  const Design d = paper_c();
  const std::vector<Sweep> sweeps = {Sweep::kCCW, Sweep::kCW};
  const std::vector<Stop> stops = program_stops(d, 0, sweeps);
  std::vector<double> levels;
  for (const Stop& s : stops)
    for (std::size_t q = 0; q < s.sweeps.size(); ++q)
      levels.push_back(0.5 * static_cast<double>(levels.size()));
  TraceSimulation o;
  o.dwell_s = 40;  // 10^4 s in all at 1 kHz: the moves take what the dwells leave
  o.move_s_min = o.move_s_max = (1.0e4 - o.dwell_s * static_cast<double>(levels.size())) /
                                static_cast<double>(stops.size() - 1);
  const SimulatedTrace sim = simulate_trace(stops, levels, o);
  const std::string path = "/tmp/dbbkit_bench_trace.csv";
  {
    std::ofstream out(path);
    io::write_trace_csv(out, sim.trace, {"benchmark trace"});
  }
  DwellOptions dwell;
  dwell.dwell_s = o.dwell_s;
  std::size_t n = 0;
  double read_s = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const Trace t = io::read_trace_file(path, {});
    read_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    n = t.time_s.size();
    benchmark::DoNotOptimize(readings_from_trace(d, "1r", t, sweeps, dwell, path).readings.size());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
  state.counters["samples"] = static_cast<double>(n);
  state.counters["read_s"] = read_s / static_cast<double>(state.iterations());
  std::remove(path.c_str());
}
BENCHMARK(BM_ReadingsFromTrace)->Unit(benchmark::kMillisecond)->Iterations(1);

BENCHMARK_MAIN();
