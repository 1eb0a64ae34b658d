#pragma once
// The work a call does, counted as it is done: deterministic counts of the numerical kernels
// run on the calling thread, the same on any machine at any speed. The cost gate
// (benchmarks/cost_gate.cpp, against benchmarks/cost-baseline.json) holds identify, evaluate
// and the worst case of the committed designs to them, so that a change that adds a
// factorisation or a pass over the readings is seen where it is added, not in a timing.

#include <string>
#include <utility>
#include <vector>

namespace dbbkit::cost {

struct Counts {
  long factorisations = 0;  // models factorised: WlsSolver, and SetupSolver with set-up columns
  long solves = 0;          // estimates formed from readings (WlsSolver::solve, SetupSolver::solve)
  long gain_columns = 0;    // columns of readings through a gain (G M), and rows of functions (C G)
  long unexplained_columns = 0;  // columns whose unexplained part W^1/2 (M - J G M) is formed
  long l1_rows = 0;              // rows of functions whose |c'G|_1 is formed
  long variances = 0;            // variances c' Cov c of single functions (Estimate::evaluate)
};

// The calling thread's counts since its last reset().
Counts counts();
void reset();

// The counters by name, in the order of Counts (the gate's file and messages use these).
std::vector<std::pair<std::string, long>> named(const Counts& c);

}  // namespace dbbkit::cost
