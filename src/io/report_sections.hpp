#pragma once
// Sections shared by the commands' reports (reports.hpp), each written through the
// ReportWriter interface. Internal to io.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/identify.hpp"
#include "dbbkit/io/plots.hpp"
#include "dbbkit/io/report_writer.hpp"
#include "dbbkit/io/reports.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/measurement.hpp"

namespace dbbkit::io::detail {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The design: a sentence, its drawing and the table of what it measures (a ball bar's
// installations, a probe's spheres).
void design_section(ReportWriter& p, const Design& d);
// The residual of each installation, each sweep (and repeat) a line in angle order.
std::vector<ResidualPanel> residual_panels(const Design& d, const std::vector<Reading>& readings,
                                           const Eigen::VectorXd& residual);
// The ISO 230-7 quantities (location errors, constant parts, component motions, error motion
// values), with what their uncertainty holds.
void iso230_section(ReportWriter& p, const IsoResult& iso, const std::string& note);
// The conformance decisions (conformance.hpp): verdict, rule, warnings, a row per tolerance.
void conformance_section(ReportWriter& p, const ConformanceReport& c);
// The warnings (warnings.hpp), first on the page, when there are any.
void warnings_section(ReportWriter& p, const std::vector<Warning>& warnings);
// The result's first screen (text.hpp: BriefItem), first in every report.
void summary_section(ReportWriter& p, const std::vector<BriefItem>& brief);
// The combinations of the errors no reading sees, when there are any.
void unidentifiable_section(ReportWriter& p, const std::vector<Unidentifiable>& list);
// The errors (values with +-U, or U alone) as a plot and a table; `coverage`: the coverage
// probability of U.
void errors_section(ReportWriter& p, const std::vector<ExpandedErrorsAtAngle>& expanded,
                    bool values, const std::string& what, double coverage);
// The errors as table rows: angle, then value +- U (or U alone) per error; "--" where not
// determined.
std::vector<std::vector<std::string>> errors_rows(const std::vector<ExpandedErrorsAtAngle>& errors,
                                                  bool values);
std::vector<std::string> errors_header(bool values);
// A clause as a sentence: capital first letter, full stop.
std::string as_sentence(std::string text);
// The run's conditions (ReportWriter::conditions).
void conditions(ReportWriter& p, const RunContext& run, const Design* design);

}  // namespace dbbkit::io::detail
