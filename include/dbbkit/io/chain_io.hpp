#pragma once
// `dbbkit chain`: the results of a machine's axes combined (chain.hpp), as JSON
// (dbbkit.chain/1) and as text for the terminal.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "dbbkit/chain.hpp"
#include "dbbkit/io/result_read.hpp"
#include "dbbkit/machine.hpp"

namespace dbbkit::io {

inline constexpr const char* kChainFormat = "dbbkit.chain/1";

// One result as chain takes it: it must name the machine (design.machine), its axis frame be
// the machine's at the result's park angles and carry the location errors' covariance; throws
// InputError naming the result's file and key otherwise.
ChainInput chain_input(const Machine& machine, const ResultFile& result);

nlohmann::json chain_to_json(const ChainResult& r, const Machine& machine,
                             const std::string& machine_file);
std::string chain_text(const ChainResult& r, const Machine& machine);

}  // namespace dbbkit::io
