#include "dbbkit/io/result_io.hpp"

#include <gtest/gtest.h>

#include <string>

#include "dbbkit/simulate.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

using nlohmann::json;

// json_text writes the rows one at a time; the text must be that of the whole document dumped.
TEST(JsonText, IsTheDumpOfTheDocumentWithTheRows) {
  json doc = {{"a", 1.5},
              {"z", {{"k", "v"}}},
              {"m", json::array({1, 2})},
              {"s", "text \x01 with a control"}};
  auto row = [](std::size_t i) {
    return json{{"i", i}, {"x", 0.1 * static_cast<double>(i)}, {"nested", {{"a", {1, 2}}}}};
  };
  for (std::size_t count : {0, 1, 3}) {
    json whole = doc;
    whole["readings"] = json::array();
    for (std::size_t i = 0; i < count; ++i) whole["readings"].push_back(row(i));
    EXPECT_EQ(io::json_text(doc, "readings", count, row), whole.dump(2)) << count << " rows";
  }
  // A key placed first and one placed last among the sorted keys.
  for (const char* key : {"0first", "~last"}) {
    json whole = doc;
    whole[key] = json::array({row(0), row(1)});
    EXPECT_EQ(io::json_text(doc, key, 2, row), whole.dump(2)) << key;
  }
  EXPECT_THROW(io::json_text(doc, "a", 1, row), std::logic_error);
}

// The identify result written row by row is the document identify_to_json builds whole.
TEST(JsonText, IdentifyRowsMatchTheWholeDocument) {
  const Design d = test::paper_design('C');
  Truth truth;
  truth.model = d.errors;
  for (double a : d.angles_deg) test::add_truth_value(truth, d.axis, a, Vector6d::Constant(2.0));
  const std::vector<Reading> readings = simulate(d, truth, 7);
  const IdentifyResult result = identify(d, readings);
  const json whole = io::identify_to_json(d, readings, result, {"d.json", "m.csv"});
  const json head = io::identify_to_json(d, readings, result, {"d.json", "m.csv"}, nullptr, false);
  EXPECT_FALSE(head.contains("readings"));
  ASSERT_EQ(whole["readings"].size(), readings.size());
  const std::string text = io::json_text(head, "readings", readings.size(), [&](std::size_t i) {
    return io::identify_reading_row(d, readings, result.estimate, i);
  });
  EXPECT_EQ(text, whole.dump(2));
}

}  // namespace
}  // namespace dbbkit

#include "../src/io/report_sections.hpp"

namespace dbbkit {
namespace {

// The residual plots draw each installation in its own panel and each sweep (and repeat) as
// a line of its own in angle order, whatever order the readings were taken in.
TEST(ResidualPanels, EachSweepIsALineInAngleOrder) {
  const Design d = test::paper_design('C');
  std::vector<Reading> readings;
  for (int sweep = 0; sweep < 2; ++sweep) {
    for (int k = 0; k < 5; ++k) {
      Reading r;
      r.installation = "2r";
      r.angle_deg = sweep == 0 ? 20.0 * k : 20.0 * (4 - k);  // ccw up, then cw down
      r.sweep = sweep == 0 ? Sweep::kCCW : Sweep::kCW;
      readings.push_back(r);
    }
  }
  Reading lone;
  lone.installation = "1r";
  lone.angle_deg = 40;
  readings.push_back(lone);
  Eigen::VectorXd residual(static_cast<long>(readings.size()));
  for (long i = 0; i < residual.size(); ++i) residual(i) = static_cast<double>(i);
  const std::vector<io::ResidualPanel> panels = io::detail::residual_panels(d, readings, residual);
  ASSERT_EQ(panels.size(), 2u);  // installations with readings only, in the design's order
  EXPECT_EQ(panels[0].installation, "1r");
  EXPECT_EQ(panels[0].lines[0].sweep, "sweep not recorded");
  ASSERT_EQ(panels[1].lines.size(), 2u);
  EXPECT_EQ(panels[1].lines[0].sweep, "ccw");
  EXPECT_EQ(panels[1].lines[1].sweep, "cw");
  EXPECT_EQ(panels[1].lines[1].angle_deg, (std::vector<double>{0, 20, 40, 60, 80}));
  // The cw readings 5..9 were taken at 80, 60, ..., 0: in angle order their residuals reverse.
  EXPECT_EQ(panels[1].lines[1].residual_um, (std::vector<double>{9, 8, 7, 6, 5}));
}

}  // namespace
}  // namespace dbbkit
