#include "dbbkit/cost.hpp"

#include "cost_counters.hpp"

namespace dbbkit::cost {

namespace {
thread_local Counts tally;
}  // namespace

Counts& detail::counters() { return tally; }

Counts counts() { return tally; }

void reset() { tally = Counts{}; }

std::vector<std::pair<std::string, long>> named(const Counts& c) {
  return {{"factorisations", c.factorisations},
          {"solves", c.solves},
          {"gain_columns", c.gain_columns},
          {"unexplained_columns", c.unexplained_columns},
          {"l1_rows", c.l1_rows},
          {"variances", c.variances}};
}

}  // namespace dbbkit::cost
