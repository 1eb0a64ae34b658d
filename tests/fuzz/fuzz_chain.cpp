// libFuzzer target: the machine result's reader of compensation (chain_io.hpp), then every
// compensation format of a machine and its chain predicted at two poses; and the same bytes as a
// machine poses file (predict --result M.json --at) for a table and a head. Bad input must end in
// InputError; any other exception or a crash is a bug.
#include <cstdint>
#include <string>

#include "dbbkit/error.hpp"
#include "dbbkit/io/chain_io.hpp"
#include "dbbkit/io/compensation_io.hpp"
#include "dbbkit/io/predict_io.hpp"

namespace {

// A C table and a B head (the paper's machine), built in code: its poses need the tool tip.
dbbkit::ChainErrors table_and_head() {
  dbbkit::ChainErrors c;
  for (const char letter : {'C', 'B'}) {
    dbbkit::ChainErrors::Axis a;
    a.letter = letter;
    a.table = letter == 'C';
    a.direction = letter == 'C' ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitY();
    a.point_mm = letter == 'C' ? Eigen::Vector3d::Zero() : Eigen::Vector3d(0, 0, 250);
    a.vector = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitX(),
                Eigen::Vector3d::UnitY(), a.direction};
    if (letter == 'B') a.vector[1] = a.vector[3] = Eigen::Vector3d::UnitZ();
    for (auto& l : a.location) l = 1.0;
    c.axes.push_back(a);
  }
  c.covariance = Eigen::MatrixXd::Identity(10, 10);
  return c;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const dbbkit::io::ChainFile m = dbbkit::io::chain_from_text(text, "fuzz");
    for (const auto f :
         {dbbkit::io::CompensationFormat::kIsg, dbbkit::io::CompensationFormat::kTable,
          dbbkit::io::CompensationFormat::kLinuxCnc, dbbkit::io::CompensationFormat::kSiemens}) {
      try {
        dbbkit::io::CompensationOptions o;
        if (f == dbbkit::io::CompensationFormat::kSiemens) o.record = 1;
        if (f == dbbkit::io::CompensationFormat::kLinuxCnc)
          o.current_mm = {{"x-rot-point", 0}, {"y-rot-point", 0}, {"z-rot-point", 0},
                          {"x-offset", 0},    {"y-offset", 0},    {"z-offset", 0}};
        (void)dbbkit::io::machine_compensation_text(m, f, o);
      } catch (const dbbkit::InputError&) {
      }
    }
    // Its chain, where it is one on each side, at two poses (every axis at 0 and at 30 deg).
    try {
      const dbbkit::ChainErrors chain = dbbkit::io::chain_errors_of(m);
      const std::vector<std::string> columns = dbbkit::io::chain_pose_columns(chain);
      std::string csv;
      for (const std::string& column : columns) csv += (csv.empty() ? "" : ",") + column;
      csv += "\n";
      for (const char* angle : {"0", "30"}) {
        for (std::size_t k = 0; k < chain.axes.size(); ++k) csv += std::string(angle) + ",";
        csv += columns.size() > chain.axes.size() + 3 ? "100,0,50,0,0,100\n" : "100,0,50\n";
      }
      const auto poses = dbbkit::io::parse_chain_poses(csv, "poses", chain);
      (void)dbbkit::io::chain_prediction_to_json(dbbkit::io::predict_chain(m, chain, poses, 0.95));
    } catch (const dbbkit::InputError&) {
    }
  } catch (const dbbkit::InputError&) {
  }
  // The bytes as a poses file of a table and a head: refused with InputError, or poses a
  // prediction takes.
  static const dbbkit::ChainErrors th = table_and_head();
  try {
    const auto poses = dbbkit::io::parse_chain_poses(text, "fuzz", th);
    const std::optional<dbbkit::ChainOrder> order = dbbkit::chain_order(th);
    const dbbkit::PredictionCoverage cov = dbbkit::prediction_coverage(0.95, std::nullopt);
    for (std::size_t i = 0; i < poses.size() && i < 16; ++i)
      (void)dbbkit::predict_chain_point(th, *order, poses[i], cov);
  } catch (const dbbkit::InputError&) {
  }
  return 0;
}
