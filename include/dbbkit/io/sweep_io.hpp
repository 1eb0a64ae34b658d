#pragma once
// The --sweep argument of `evaluate` and the design map it writes.
//   NAME=start:stop:step   NAME = L|D|H followed by a prefix of installation ids
//                          ("L2": L of every installation whose id starts with "2")
//                          or L|D|H@id,id,... naming the installations.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dbbkit/observability.hpp"

namespace dbbkit::io {

SweepVariable parse_sweep(const Design& design, const std::string& spec);

// The most design points one map may have: the product of the sweeps' values (each sweep has at
// most 10,000). A 0.3 ms evaluation of the paper's design makes it about half a minute.
inline constexpr double kMaxSweepPoints = 100000;

nlohmann::json sweep_to_json(const std::vector<SweepVariable>& variables,
                             const std::vector<SweepPoint>& points);
std::string sweep_csv(const std::vector<SweepVariable>& variables,
                      const std::vector<SweepPoint>& points);
// The map on the terminal: its size and its best point (best_sweep_point).
std::string sweep_summary(const std::vector<SweepVariable>& variables,
                          const std::vector<SweepPoint>& points);

}  // namespace dbbkit::io
