// Readings against their design: the instrument's range catches a unit mix-up, and a
// design may declare a wider range.

#include "dbbkit/measurement.hpp"

#include <gtest/gtest.h>

#include "dbbkit/error.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/measurement_io.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

std::string message_of(const Design& d, const std::string& csv) {
  try {
    validate_readings(d, io::parse_measurements(csv, "M.csv"), "M.csv");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Readings, AnIntegerColumnSaysWhatIsWrong) {
  const Design d = test::paper_design('C');
  const std::string frac = message_of(d, "installation,angle_deg,reading_um,repeat\n1r,0,1,1.5\n");
  EXPECT_NE(frac.find("is not an integer"), std::string::npos) << frac;
  EXPECT_NE(frac.find("line 2"), std::string::npos) << frac;
  const std::string big =
      message_of(d, "installation,angle_deg,reading_um,repeat\n1r,0,1,3000000000\n");
  EXPECT_NE(big.find("is an integer beyond +-2000000000"), std::string::npos) << big;
  EXPECT_EQ(message_of(d, "installation,angle_deg,reading_um,repeat\n1r,0,1,2000000000\n"), "");
}

// A CR alone ends a line as LF and CR LF do (an old Mac's files): the same readings, and a
// line named by its number.
TEST(Readings, LinesEndedByACarriageReturnAloneAreRead) {
  const std::string lf = "installation,angle_deg,reading_um\n1r,0,1.5\n1r,20,2.5\n";
  std::string cr = lf, crlf;
  for (char& c : cr) c = c == '\n' ? '\r' : c;
  for (const char c : lf) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  const std::vector<Reading> a = io::parse_measurements(lf, "lf.csv");
  for (const std::string& text : {cr, crlf}) {
    const std::vector<Reading> b = io::parse_measurements(text, "cr.csv");
    ASSERT_EQ(b.size(), a.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(b[i].angle_deg, a[i].angle_deg);
      EXPECT_EQ(b[i].reading_um, a[i].reading_um);
      EXPECT_EQ(b[i].line, a[i].line);
    }
  }
  const Design d = test::paper_design('C');
  const std::string m = message_of(d, "installation,angle_deg,reading_um\r1r,0,x\r");
  EXPECT_NE(m.find("line 2"), std::string::npos) << m;
}

TEST(Readings, TheInstrumentRangeCatchesUmInAMmColumnAndCanBeWidened) {
  Design d = test::paper_design('C');
  ASSERT_EQ(d.instrument_range_mm, 1.0);  // the default: a QC20-W class ballbar
  // 0.9 mm is a reading; 2.5 in a mm column is beyond +-1 mm, most likely um.
  EXPECT_EQ(message_of(d, "installation,angle_deg,reading_mm\n1r,0,0.9\n"), "");
  const std::string mm = message_of(d, "installation,angle_deg,reading_mm\n1r,0,0.9\n1r,20,2.5\n");
  EXPECT_NE(mm.find("line 3"), std::string::npos) << mm;
  EXPECT_NE(
      mm.find("reading_mm 2.5 is beyond the instrument's range of +-1 mm: are the readings in um?"),
      std::string::npos)
      << mm;
  const std::string um = message_of(d, "installation,angle_deg,reading_um\n1r,0,-1000.5\n");
  EXPECT_NE(um.find("reading -1000.5 um is beyond the instrument's range of +-1 mm"),
            std::string::npos)
      << um;
  // A design declaring a range of 5 mm accepts 2.5 mm, and says so in its file.
  d.instrument_range_mm = 5.0;
  EXPECT_EQ(message_of(d, "installation,angle_deg,reading_mm\n1r,20,2.5\n"), "");
  const Design back = io::design_from_json(io::design_to_json(d), "round trip");
  EXPECT_EQ(back.instrument_range_mm, 5.0);
  d.instrument_range_mm = 12.0;  // beyond any DBB
  EXPECT_THROW(validate_design(d), InputError);
}

// The fastest drift a finding may have: 10 um/min unless the design says otherwise; a design
// stating one keeps it through its file, alone or beside the range.
TEST(Readings, TheDriftBoundDefaultsAndIsKeptInTheDesignFile) {
  Design d = test::paper_design('C');
  EXPECT_EQ(d.max_drift_um_per_min, kDefaultMaxDrift_um_per_min);
  EXPECT_FALSE(io::design_to_json(d).contains("instrument"));
  d.max_drift_um_per_min = 2.5;
  nlohmann::json j = io::design_to_json(d);
  EXPECT_FALSE(j["instrument"].contains("range_mm"));
  EXPECT_EQ(io::design_from_json(j, "round trip").max_drift_um_per_min, 2.5);
  d.instrument_range_mm = 3.0;
  const Design back = io::design_from_json(io::design_to_json(d), "round trip");
  EXPECT_EQ(back.max_drift_um_per_min, 2.5);
  EXPECT_EQ(back.instrument_range_mm, 3.0);
  d.max_drift_um_per_min = -1;
  EXPECT_THROW(validate_design(d), InputError);
}

}  // namespace
}  // namespace dbbkit
