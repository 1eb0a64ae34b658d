#pragma once
// The words of diagnose: the verdict and the residual's features, built from the
// structured result (diagnose.hpp). `readings` are the readings given to diagnose (the
// rows of the result's features and gross readings index them).

#include <string>
#include <vector>

#include "dbbkit/design.hpp"
#include "dbbkit/diagnose.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/measurement.hpp"

namespace dbbkit::io {

// What the residual says before and after, which effects were added and why, what remains,
// the set-up effects the design cannot see and, when nothing was added, the sizes that
// would have been found.
std::string diagnose_verdict(const Design& design, const std::vector<Reading>& readings,
                             const DiagnoseResult& result);

// diagnose's answer in at most six sentences, each at most kBriefItemMaxChars long: what is
// wrong (the effects found, where, how large, in the shop's terms), how sure (the evidence and
// what fits almost as well, families said once), what it changes (the errors that moved most),
// how uncertain the corrected errors are where a choice the readings cannot make enters them,
// and what to do next.
std::vector<BriefItem> diagnose_brief(const Design& design, const DiagnoseResult& result);

// A feature in words, with its test: "a step of 5.02 +- 0.3 um in installation 2t from the
// reading ... (F = ..., p = ...)".
std::string describe_feature(const Design& design, const std::vector<Reading>& readings,
                             const ResidualFeature& f);

// Why a candidate ended in its state, in words with its figures (CandidateReason): "F = 2.1,
// p = 0.15", "step 2: F = 40.2, p = 1e-08 < 0.000345, BIC change -31.4", ...; empty when it
// was not tested.
std::string candidate_detail(const CandidateStatus& c);

using dbbkit::not_applicable_text;  // effects.hpp

}  // namespace dbbkit::io
