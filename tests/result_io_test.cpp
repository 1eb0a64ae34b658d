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
    return io::identify_reading_row(readings, result.estimate, i);
  });
  EXPECT_EQ(text, whole.dump(2));
}

}  // namespace
}  // namespace dbbkit
