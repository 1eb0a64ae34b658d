#pragma once
// `dbbkit chain`: the results of a machine's axes combined (chain.hpp), as JSON
// (dbbkit.chain/1) and as text for the terminal.

#include <Eigen/Core>
#include <array>
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

// A machine result read back (compensation takes it): every axis' nominal line and location
// errors with their directions, the covariance of all of them, the chain terms, the warnings.
struct ChainFileAxis {
  char letter = 'C';
  bool table = true;
  char on = 0;  // the carrier's letter, 0: the machine's frame
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero(), direction = Eigen::Vector3d::UnitZ();
  std::string result;
  std::vector<ResultQuantity> location;  // 5: two offsets (um), two tilts, the zero (urad)
  std::array<Eigen::Vector3d, 5> vector;
};
struct ChainFileTerm {
  std::string name, text;
  char a = 'A', b = 'C';
  ResultQuantity q;
};
struct ChainFile {
  std::string source, machine_name, controller;
  std::vector<ChainFileAxis> axes;
  std::vector<ChainFileTerm> terms;
  Eigen::MatrixXd covariance;  // 5 per axis, in axes' order (um, urad)
  std::vector<std::string> warnings;
};

// Whether a JSON text is a machine result (its "format" is dbbkit.chain/1).
bool is_chain_text(const std::string& text);
// Throws InputError(path, key) on what is not a machine result of dbbkit chain.
ChainFile chain_from_text(const std::string& text, const std::string& source);
ChainFile read_chain_file(const std::string& path);

// `machine_sha256`: the machine file's SHA-256, empty when it came from no file.
nlohmann::json chain_to_json(const ChainResult& r, const Machine& machine,
                             const std::string& machine_file,
                             const std::string& machine_sha256 = "");
std::string chain_text(const ChainResult& r, const Machine& machine);

}  // namespace dbbkit::io
