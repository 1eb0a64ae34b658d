#include "dbbkit/io/diagnose_text.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include "../number_text.hpp"
#include "dbbkit/effects.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/setup.hpp"

namespace dbbkit::io {

namespace {

// Per kind of effect ("drift" of "drift[3r]"), in the order the kinds first come, over its
// candidates' detection limits: the least (with its candidate) and the largest of those the
// readings could hold; where every limit of the kind is one no machine or bar can have (beyond
// the instrument's range, or a drift faster than the design allows), the least reach and rate of
// those instead (the design cannot see the kind at all).
struct KindLimits {
  std::string kind, unit, least_label;
  double least = 0, largest = 0;                                  // when least_label is not empty
  std::optional<double> unseen_reach_um, unseen_rate_um_per_min;  // every limit unseeable
  bool unseen() const { return unseen_reach_um || unseen_rate_um_per_min; }
};
std::vector<KindLimits> limits_by_kind(const std::vector<DetectionLimit>& limits) {
  std::vector<KindLimits> out;
  std::vector<bool> all_beyond;
  for (const DetectionLimit& d : limits) {
    if (!d.limit) continue;
    const std::string kind = d.label.substr(0, d.label.find('['));
    auto it =
        std::find_if(out.begin(), out.end(), [&](const KindLimits& k) { return k.kind == kind; });
    if (it == out.end()) {
      out.push_back({kind, d.unit, "", 0, 0, std::nullopt, std::nullopt});
      all_beyond.push_back(true);
      it = out.end() - 1;
    }
    const std::size_t i = static_cast<std::size_t>(it - out.begin());
    if (d.unseeable()) {
      auto least = [](std::optional<double>& to, const std::optional<double>& x) {
        if (x) to = std::min(to.value_or(*x), *x);
      };
      least(it->unseen_reach_um, d.beyond_instrument_um);
      least(it->unseen_rate_um_per_min, d.beyond_drift_rate_um_per_min);
      continue;
    }
    all_beyond[i] = false;
    if (it->least_label.empty() || *d.limit < it->least)
      it->least = *d.limit, it->least_label = d.label;
    it->largest = std::max(it->largest, *d.limit);
  }
  for (std::size_t i = 0; i < out.size(); ++i)
    if (!all_beyond[i]) out[i].unseen_reach_um.reset(), out[i].unseen_rate_um_per_min.reset();
  return out;
}

// The kinds the design cannot see, e.g. "drift (1.3e+04 um on the bar at the least)" or
// "drift (1.2e+03 um/min at the least)".
std::vector<std::string> unseen_kinds(const std::vector<KindLimits>& kinds) {
  std::vector<std::string> out;
  for (const KindLimits& k : kinds) {
    if (!k.unseen()) continue;
    std::vector<std::string> sizes;
    if (k.unseen_reach_um) sizes.push_back(fmt_num(*k.unseen_reach_um, 2) + " um on the bar");
    if (k.unseen_rate_um_per_min)
      sizes.push_back(fmt_num(*k.unseen_rate_um_per_min, 2) + " um/min");
    out.push_back(k.kind + " (" + sizes.front() + (sizes.size() > 1 ? " or " + sizes.back() : "") +
                  " at the least)");
  }
  return out;
}

std::string comma_listed(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& i : items) out += (out.empty() ? "" : ", ") + i;
  return out;
}

// The most significant feature (smallest p) in words, or empty.

std::string p_text(double p) { return p < 1e-300 ? "< 1e-300" : "= " + fmt_num(p, 3); }

std::string reading_text(const Reading& r) {
  std::string s = "installation " + r.installation + " at " + fmt_num(r.angle_deg, 6) + " deg";
  if (r.sweep) s += *r.sweep == Sweep::kCW ? " cw" : " ccw";
  if (r.time_s) s += ", t = " + fmt_num(*r.time_s, 6) + " s";
  if (r.line > 0) s += ", line " + std::to_string(r.line);
  return s;
}

// A reading and those the data cannot tell from it, each with the offset it would have:
// "installation 2r at 100 deg, line 12" or "one of installation 2r at 100 deg, line 12 (off by
// 30 um); installation 1r at 100 deg, line 5 (off by -31 um) (the data cannot tell which ...)".
std::string readings_text(const Reading& r, double value_um,
                          const std::vector<Reading>& alternatives,
                          const std::vector<double>& values_um) {
  if (alternatives.empty()) return reading_text(r);
  std::string s = "one of " + reading_text(r) + " (off by " + fmt_num(value_um, 4) + " um)";
  for (std::size_t k = 0; k < alternatives.size(); ++k) {
    s += "; " + reading_text(alternatives[k]);
    if (k < values_um.size()) s += " (off by " + fmt_num(values_um[k], 4) + " um)";
  }
  return s + ": the data cannot tell which, each explains the residual alike";
}

using text::joined;

std::string setup_risk_text(const Design& design, const std::vector<SetupRisk>& risks) {
  std::ostringstream v;
  const bool declared = design.setup_nuisance_declared();
  v << "But " << risks.size()
    << " set-up effect(s) cannot be detected by this design, and they move the errors "
    << "without leaving a residual";
  if (!declared)
    v << " (no set-up tolerance is declared: the stated uncertainties assume a perfect set-up)";
  v << ". The most dangerous:";
  const std::size_t shown = std::min<std::size_t>(3, risks.size());
  for (std::size_t i = 0; i < shown; ++i) {
    const SetupRisk& r = risks[i];
    v << (i ? ";" : "") << " " << r.label << " of " << fmt_num(r.threshold_um, 3) << " um moves "
      << kErrorNames[r.error] << " at " << fmt_num(r.angle_deg, 3)
      << " deg by its standard uncertainty " << fmt_num(r.stated_std, 3) << " "
      << kErrorUnits[r.error] << " (" << fmt_num(r.bias_per_um, 3) << " " << kErrorUnits[r.error]
      << " per um)";
    if (r.at_declared) {
      v << ", at its declared " << fmt_num(r.declared_std_um, 3) << " um by "
        << fmt_num(*r.at_declared, 3) << " " << kErrorUnits[r.error];
    }
  }
  if (declared) {
    v << ". The errors here are stated for the readings' noise; identify and evaluate carry the "
         "declared set-up tolerances in their total uncertainties. "
      << instrument_info(design.instrument).items_capitalised
      << " that make these effects detectable remove the doubt (evaluate lists them).";
  } else {
    v << ". Declare set-up tolerances (setup_std) to carry them in the uncertainties, or measure "
      << instrument_info(design.instrument).items
      << " that make them detectable (evaluate lists them).";
  }
  return v.str();
}

// Labels of one family said once (defined below with the brief's phrases).
std::string family_phrase(const Design& design, const std::vector<std::string>& labels);
std::optional<EffectCandidate> parsed(const Design& design, const std::string& label);

// The alternatives to an effect: each label as it is ("scale.z or squareness.zx"), or, where
// one kind comes more than once (ten warm-ups with their time constants), each family said once.
std::string alternatives_text(const Design& design, const std::vector<std::string>& labels) {
  std::vector<EffectKind> kinds;
  bool repeated = false;
  for (const std::string& l : labels) {
    const std::optional<EffectCandidate> e = parsed(design, l);
    if (!e) continue;
    repeated = repeated || std::find(kinds.begin(), kinds.end(), e->kind) != kinds.end();
    kinds.push_back(e->kind);
  }
  if (repeated) return family_phrase(design, labels);
  std::string s;
  for (std::size_t i = 0; i < labels.size(); ++i) s += (i ? " or " : "") + labels[i];
  return s;
}

}  // namespace

std::string describe_feature(const Design& design, const std::vector<Reading>& readings,
                             const ResidualFeature& f) {
  std::ostringstream s;
  const std::string inst =
      std::string(instrument_info(design.instrument).row_carrier) + " " +
      (f.installation >= 0 ? design.installations[f.installation].id : std::string("all"));
  auto pm = [&](const char* unit) {
    return fmt_num(f.value, 4) + " +- " + fmt_num(f.std, 2) + " " + unit;
  };
  switch (f.kind) {
    case FeatureKind::kMean:
      s << "a mean residual of " << pm("um") << " in " << inst;
      break;
    case FeatureKind::kHarmonic:
      s << "a " << f.harmonic << "-per-turn term of amplitude " << fmt_num(f.value, 4) << " um in "
        << inst;
      break;
    case FeatureKind::kDrift:
      s << "a drift of " << pm("um/min") << " in " << inst;
      break;
    case FeatureKind::kReversal:
      s << "a difference cw - ccw of " << pm("um") << " in " << inst;
      break;
    case FeatureKind::kStep:
      s << "a step of " << pm("um") << " in " << inst << " from the reading "
        << reading_text(readings[f.row]);
      break;
    case FeatureKind::kReading: {
      std::vector<Reading> alternatives;
      for (int j : f.indistinguishable) alternatives.push_back(readings[j]);
      s << "one reading off by " << pm("um") << ": "
        << readings_text(readings[f.row], f.value, alternatives, f.indistinguishable_values);
    } break;
  }
  s << " (F = " << fmt_num(f.test.F, 4) << ", p " << p_text(f.test.p);
  if (f.tested > 1)
    s << ", times " << f.tested
      << " positions scanned: " << p_text(f.p).substr(f.p < 1e-300 ? 0 : 2);
  s << ")";
  if (!f.difference_with.empty()) {
    s << "; only its difference from installation";
    for (int j : f.difference_with) s << " " << design.installations[j].id;
    s << " is determined";
  }
  return s.str();
}

std::string diagnose_verdict(const Design& design, const std::vector<Reading>& readings,
                             const DiagnoseResult& res) {
  std::ostringstream v;
  if (!res.excluded.empty()) {
    v << "Refit without " << res.excluded.size()
      << " gross reading(s), as asked (--exclude-gross):";
    for (std::size_t g = 0; g < res.excluded.size(); ++g) {
      v << (g ? ";" : "") << " "
        << reading_text(readings[static_cast<std::size_t>(res.excluded[g].row)]) << ", off by "
        << fmt_num(res.excluded[g].value_um, 4) << " +- " << fmt_num(res.excluded[g].std_um, 2)
        << " um (t = " << fmt_num(res.excluded[g].t, 4) << ")";
    }
    v << ". ";
  }
  if (!res.not_excluded.empty()) {
    v << "Not excluded (--exclude-gross), since the data cannot tell which reading is the gross "
         "one:";
    for (std::size_t g = 0; g < res.not_excluded.size(); ++g) {
      const GrossReading& gr = res.not_excluded[g];
      v << (g ? ";" : "") << " "
        << readings_text(readings[static_cast<std::size_t>(gr.row)], gr.value_um, gr.alternatives,
                         gr.alternative_values_um)
        << " (u = " << fmt_num(gr.std_um, 2) << " um)";
    }
    v << ". Measure that position again. ";
  }
  const std::string dominant_after =
      res.signature_after.dominant
          ? describe_feature(design, readings, *res.signature_after.dominant)
          : std::string();
  auto chi = [](const Estimate& e) {
    std::ostringstream s;
    s << "chi2 " << fmt_num(e.chi2, 4) << " on " << e.dof << " dof, p ";
    if (e.p_value && *e.p_value < 1e-300) {
      s << "< 1e-300";
    } else if (e.p_value) {
      s << "= " << fmt_num(*e.p_value, 3);
    } else {
      s << "undefined";
    }
    return s.str();
  };
  if (!res.before.p_value) {
    v << "The design leaves no redundant reading: nothing can be tested.";
  } else if (!res.significant_before && res.added.empty()) {
    v << "The residual is consistent with the declared noise (" << chi(res.before)
      << "): nothing to explain" << (res.setup_risks.empty() ? "." : " in the residual.");
  } else {
    v << "Before: " << chi(res.before) << ". ";
    if (res.added.empty() && res.stopped_at_step > 0) {
      v << "No effect of the library was added before selection stopped. ";
    } else if (res.added.empty()) {
      v << "No effect of the library is justified. ";
    } else {
      // The change of the errors should the alternatives of `effect` be the true ones.
      auto attribution_sentence = [&](const std::string& effect, bool convention) {
        for (const Attribution& at : res.attributions) {
          if (at.effect != effect || at.convention != convention) continue;
          const double um =
              *std::max_element(at.largest_change.begin(), at.largest_change.begin() + 3);
          const double urad =
              *std::max_element(at.largest_change.begin() + 3, at.largest_change.end());
          v << "The errors after carry the change should "
            << alternatives_text(design, at.alternatives) << " be the true one (up to "
            << fmt_num(um < 1e-6 ? 0.0 : um, 3) << " um, " << fmt_num(urad < 1e-6 ? 0.0 : urad, 3)
            << " urad) in their uncertainties ("
            << (convention ? "whole: the readings cannot choose" : "rectangular") << "). ";
        }
      };
      v << "Added:";
      for (const AddedEffect& a : res.added) v << " " << a.block.label;
      v << ". After: " << chi(res.after) << ". ";
      for (const AddedEffect& a : res.added) {
        if (!a.close_alternatives.empty()) {
          v << a.block.label << " was chosen over "
            << alternatives_text(design, a.close_alternatives)
            << ", which fit almost as well: these readings cannot tell them apart reliably. ";
          attribution_sentence(a.block.label, false);
        }
        if (a.equivalent_to.empty()) continue;
        v << a.block.label << " is equivalent to";
        for (const std::string& l : a.equivalent_to) v << " " << l;
        v << ": the data determine " << instrument_info(design.instrument).equivalent_determined
          << ", so it is attributed by convention to "
          << instrument_info(design.instrument).equivalent_convention << ". ";
      }
      for (const Attribution& at : res.attributions) {
        if (at.convention) attribution_sentence(at.effect, true);
      }
      for (const Substitution& sub : res.substitutions) {
        std::vector<std::string> by;
        for (const EffectBlock& b : sub.by) by.push_back(b.label);
        v << joined(by) << " in place of " << joined(sub.replaced) << " fit"
          << (by.size() == 1 ? "s" : "")
          << " almost as well: these readings cannot tell the two explanations apart reliably. ";
        attribution_sentence(joined(sub.replaced), false);
      }
    }
    for (const StructureComparison& c : res.structures) {
      auto list = [](const std::vector<std::string>& labels) {
        std::string out;
        for (const std::string& l : labels) out += (out.empty() ? "" : " ") + l;
        return out;
      };
      v << (c.chosen.size() == 1 ? "One " + c.kind + " for the whole test (" + list(c.chosen) + ")"
                                 : "A " + c.kind + " per installation (" + list(c.chosen) + ")")
        << " was preferred to "
        << (c.rejected.size() == 1 ? "one for the whole test (" + list(c.rejected) + ")"
                                   : "one per installation (" + list(c.rejected) + ")")
        << ": BIC " << fmt_num(c.bic_chosen, 6) << " against " << fmt_num(c.bic_rejected, 6)
        << ". ";
    }
    if (res.stopped_at_step > 0 && (res.stopped_because == SelectionStop::kModelOrder)) {
      v << "Selection stopped at step " << res.stopped_at_step
        << ", where a higher order of the error model was the best candidate: no effect is added "
           "to explain part "
           "of a motion the model's order cannot follow. ";
    }
    if (res.stopped_at_step > 0 && !(res.stopped_because == SelectionStop::kModelOrder) &&
        !res.gross.empty()) {
      v << "Selection stopped at step " << res.stopped_at_step
        << ", where one reading alone was the best candidate: no effect is added to explain part "
           "of it away. ";
    }
    if (!res.gross.empty()) {
      v << res.gross.size()
        << " gross reading(s), each tested alone against the rest (externally studentised "
        << "residual, Bonferroni over the readings):";
      for (std::size_t g = 0; g < res.gross.size(); ++g) {
        const GrossReading& gr = res.gross[g];
        v << (g ? ";" : "") << " ";
        if (gr.alternatives.empty()) {
          v << reading_text(readings[gr.row]) << ", off by " << fmt_num(gr.value_um, 4) << " +- "
            << fmt_num(gr.std_um, 2) << " um";
        } else {
          v << readings_text(readings[gr.row], gr.value_um, gr.alternatives,
                             gr.alternative_values_um)
            << " (u = " << fmt_num(gr.std_um, 2) << " um)";
        }
        v << " (t = " << fmt_num(gr.t, 4) << ", p " << p_text(gr.p_scan) << " over " << gr.tested
          << " readings)";
      }
      v << ". Check them at the machine; dbbkit diagnose --exclude-gross refits without them and "
           "says so (not where the data cannot tell which reading is the gross one: measure that "
           "position again). ";
    }
    if (res.significant_after) {
      v << "A significant residual remains that no effect of the library explains";
      if (res.features_p_all < res.level) {
        v << "; its most significant feature is " << dominant_after << ". ";
      } else {
        v << ". ";
      }
      if (res.order && res.order->p < res.level) {
        const OrderCheck& o = *res.order;
        v << "The error model's order looks too low: order " << o.suggested << " instead of "
          << o.order << " explains " << fmt_num(o.test.delta_chi2, 4)
          << " of chi2 (F = " << fmt_num(o.test.F, 4) << ", p " << p_text(o.p) << " over "
          << o.tried << " orders); with it chi2 " << fmt_num(o.chi2_with, 4) << " on " << o.dof_with
          << " dof" << (o.p_value_with ? ", p " + p_text(*o.p_value_with) : std::string())
          << ". Set errors.order to " << o.suggested << " in the design. ";
      }
      if (res.noise_larger_than_declared && res.noise) {
        const NoiseScale& ns = *res.noise;
        v << "No feature of the residual stands out against its own scatter (the most significant, "
          << dominant_after << ", has p " << p_text(res.features_p_all) << " over "
          << res.features_after.size() << " features): the readings scatter "
          << fmt_num(ns.ratio, 3) << " times (95 % interval " << fmt_num(ns.low, 3) << " to "
          << fmt_num(ns.high, 3)
          << ") more than the declared noise, evenly. The declared accuracy looks too "
          << "small; identify --type-a states the uncertainties from the data's own scatter. ";
      }
    } else {
      v << "No significant residual remains.";
    }
  }
  if (res.p_lower_after) {
    // The lower tail: a residual far smaller than the declared noise predicts.
    const double lower = *res.p_lower_after;
    if (lower < res.level) {
      v << " The residual is smaller than the declared noise predicts (P(chi2 <= "
        << fmt_num(res.after.chi2, 4) << ") = " << fmt_num(lower, 3)
        << "): the declared instrument accuracy overstates the scatter of these readings "
        << "(averaged readings?); the uncertainties stated from it are conservative, and a Type A "
           "evaluation "
        << "(identify --type-a) would state them from the data.";
    }
  }
  if (!res.setup_risks.empty()) {
    if (v.str().empty() || v.str().back() != ' ') v << " ";
    v << setup_risk_text(design, res.setup_risks);
  }
  if (!res.detection_limits.empty()) {
    // Per kind, the range over its candidates of the size found with power 0.9.
    std::ostringstream found;
    const std::vector<KindLimits> kinds = limits_by_kind(res.detection_limits);
    const std::vector<std::string> unseen = unseen_kinds(kinds);
    bool first = true;
    for (const KindLimits& k : kinds) {
      if (k.least_label.empty()) continue;
      found << (first ? " " : "; ") << k.kind << " of " << fmt_num(k.least, 2) << " " << k.unit
            << (k.largest > k.least * 1.005
                    ? " (" + k.least_label + ") to " + fmt_num(k.largest, 2) + " " + k.unit
                    : std::string())
            << " or more";
      first = false;
    }
    if (!first)
      v << " Nothing was added; with the declared noise, these would have been found with power "
           "0.9 at this level:"
        << found.str() << " (every candidate in the JSON).";
    if (!unseen.empty())
      v << " This design cannot see " << comma_listed(unseen)
        << ": the least it would find is an effect no machine or bar has (beyond the instrument's "
           "range in these readings, or a drift faster than the design's "
           "instrument.max_drift_um_per_min of "
        << fmt_num(design.max_drift_um_per_min, 3)
        << " um/min; beyond_instrument_range_um, beyond_max_drift_um_per_min in the JSON).";
  }
  return v.str();
}

// "a drift of 40 um/min", or "a warm-up whose slope at its start is 19 um/min".
static std::string rate_phrase(const CandidateStatus& c) {
  const std::string rate = fmt_num(c.implied_um_per_min, 3) + " um/min";
  if (c.label.rfind(effect_name(EffectKind::kThermal), 0) != 0) return "a drift of " + rate;
  return std::isfinite(c.implied_um_per_min)
             ? "a warm-up whose slope at its start is " + rate
             : std::string("a warm-up with a time constant not above 0");
}

std::string candidate_detail(const CandidateStatus& c) {
  auto f = [](double x) { return fmt_num(x, 3); };
  std::string t;
  switch (c.reason) {
    case CandidateReason::kNotTested:
    case CandidateReason::kFullRank:
      break;
    case CandidateReason::kNotApplicable:
      t = not_applicable_text(c.applicability);
      break;
    case CandidateReason::kRankShort:
      t = "its " + std::to_string(c.columns) + " column(s) raise the rank by " +
          std::to_string(c.added_rank) + ": its size cannot be told from the axis errors" +
          (c.with_added ? " and the effects already added" : "");
      break;
    case CandidateReason::kNoDof:
      t = "no residual degrees of freedom left to test it";
      break;
    case CandidateReason::kTested:
      t = "F = " + f(c.F) + ", p = " + f(c.p);
      break;
    case CandidateReason::kScanRankShort:
      t = "no alternative raises the rank: its size cannot be told from the model";
      break;
    case CandidateReason::kScanTested:
      t = "best " + c.other + ": F = " + f(c.F) + ", p = " + f(c.p) + " times " +
          std::to_string(c.scanned) + " alternatives = " + f(c.p_scan);
      break;
    case CandidateReason::kAdded:
      t = "step " + std::to_string(c.step) + ": F = " + f(c.F) + ", p = " + f(c.p) + " < " +
          f(c.threshold) + ", BIC change " + f(c.bic_change);
      break;
    case CandidateReason::kScanAdded:
      t = "step " + std::to_string(c.step) + ": " + c.other + ", F = " + f(c.F) +
          ", p = " + f(c.p) + " (over " + std::to_string(c.scanned) + " alternatives) < " +
          f(c.threshold) + ", BIC change " + f(c.bic_change) + " with its position";
      break;
    case CandidateReason::kEquivalent:
      t = "explains the data exactly as " + c.other +
          " does (only their difference is determined); by convention " +
          (c.note.empty() ? std::string("the later installation") : c.note) + " carries it";
      break;
    case CandidateReason::kReleased:
      t = "equivalent to " + c.other + ", which left the model";
      break;
    case CandidateReason::kExchangedOut:
      t = "exchanged for " + c.other + ", which explains the data better";
      break;
    case CandidateReason::kExchangedIn:
      t = "exchanged in for " + c.other;
      break;
    case CandidateReason::kDropped:
      t = "dropped: no longer significant once " + c.other + " were in the model (F = " + f(c.F) +
          ", p = " + f(c.p) + " >= " + f(c.level) + ")";
      break;
    case CandidateReason::kRankShortOfModel:
      t = "raises the rank by " + std::to_string(c.added_rank) + " of " +
          std::to_string(c.columns) + ": indistinguishable from the axis errors of the " + c.note +
          " model";
      break;
    case CandidateReason::kBeyondInstrument:
      t = "significant, but fitted it alone would move the bar by " + f(c.implied_um) + " um" +
          (c.other.empty() ? "" : " (" + c.other + ")") + ", beyond the instrument's range of +-" +
          f(c.level) + " um: the readings could not hold it, not a finding";
      break;
    case CandidateReason::kBeyondDriftRate:
      t = "significant, but fitted it is " + rate_phrase(c) +
          (c.other.empty() ? "" : " (" + c.other + ")") +
          ", faster than the fastest a machine or bar drifts (instrument.max_drift_um_per_min, " +
          f(c.level) + " um/min): not a finding";
      break;
    case CandidateReason::kSetUpFitted:
    case CandidateReason::kSetUpCarried:
      t = "its tolerance is declared (" + c.note + " um)" +
          (c.reason == CandidateReason::kSetUpFitted
               ? ": fitted with the axis errors, not sought as a finding; the errors hold with "
                 "the tolerance in their uncertainty, as identify states them"
               : " and the readings cannot tell it from the axis errors: carried in their "
                 "uncertainty, as identify carries it");
      break;
  }
  if (c.missed) {
    t += " (the best candidate at step " + std::to_string(c.missed->step) + "; needs p < " +
         f(c.missed->threshold) + " and a lower BIC, change " + f(c.missed->bic_change) +
         (c.missed->with_position ? " with its position)" : ")");
  }
  return t;
}

}  // namespace dbbkit::io

namespace dbbkit::io {

namespace {

std::string n3(double x) { return fmt_num(x, 3); }

// A next step of the effect table (EffectInfo::next_step) with its placeholders filled, in one
// pass over the table's text (a value is never read again for a placeholder).
std::string filled(const std::string& text,
                   std::initializer_list<std::pair<const char*, std::string>> values) {
  std::string out;
  for (std::size_t at = 0; at < text.size();) {
    bool replaced = false;
    for (const auto& [key, value] : values) {
      if (text.compare(at, std::char_traits<char>::length(key), key) != 0) continue;
      out += value;
      at += std::char_traits<char>::length(key);
      replaced = true;
      break;
    }
    if (!replaced) out += text[at++];
  }
  return out;
}

// An added warm-up's time constant [min]: fitted (its second value) or the scanned one.
double fitted_tau_min(const AddedEffect& a) {
  return a.values.size() > 1 ? a.values[1].value : a.block.effect.tau_min;
}

// "a, b and c"; beyond `budget` characters the rest as "and N more".
std::string listed(const std::vector<std::string>& items, std::size_t budget = 150) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) {
    const std::string sep = i == 0 ? "" : (i + 1 == items.size() ? " and " : ", ");
    if (i > 0 && out.size() + sep.size() + items[i].size() > budget) {
      return out + " and " + std::to_string(items.size() - i) + " more";
    }
    out += sep + items[i];
  }
  return out;
}

// The same with "or".
std::string or_listed(const std::vector<std::string>& items) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i)
    out += (i == 0 ? "" : (i + 1 == items.size() ? " or " : ", ")) + items[i];
  return out;
}

const char* kind_noun(EffectKind k) { return effect_info(k).noun; }

std::string installation_of(const Design& design, const EffectCandidate& e) {
  return effect_installation_id(design, e);
}

// The candidate a label names, when it can be read back (a periodic effect's label cannot).
std::optional<EffectCandidate> parsed(const Design& design, const std::string& label) {
  try {
    return effect_from_label(design, label, "result", "label");
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// Labels of one family said once: "a warm-up with a time constant between 5 and 112 min", "a
// length offset of 1r or 2r", "a step in 2t at t = 300 to 420 s".
std::string family_phrase(const Design& design, const std::vector<std::string>& labels) {
  struct Family {
    EffectKind kind;
    std::vector<std::string> where;
    double lo = 1e300, hi = -1e300;  // tau or step time
  };
  std::vector<Family> families;
  std::vector<std::string> unread;
  for (const std::string& l : labels) {
    const std::optional<EffectCandidate> e = parsed(design, l);
    if (!e) {
      unread.push_back(l);
      continue;
    }
    auto f = std::find_if(families.begin(), families.end(),
                          [&](const Family& x) { return x.kind == e->kind; });
    if (f == families.end()) f = families.insert(families.end(), Family{e->kind, {}});
    const std::string w = e->installation >= 0 ? installation_of(design, *e) : "the whole test";
    if (std::find(f->where.begin(), f->where.end(), w) == f->where.end()) f->where.push_back(w);
    const EffectPosition position = effect_info(e->kind).position;
    const double x = position == EffectPosition::kTimeConstant ? e->tau_min
                     : position == EffectPosition::kTime       ? e->at_s
                                                               : std::nan("");
    if (std::isfinite(x)) f->lo = std::min(f->lo, x), f->hi = std::max(f->hi, x);
  }
  std::vector<std::string> phrases;
  for (const Family& f : families) {
    std::string p = kind_noun(f.kind);
    const EffectPosition position = effect_info(f.kind).position;
    if (position == EffectPosition::kTimeConstant && f.lo <= f.hi) {
      p += f.hi > f.lo ? " with a time constant between " + n3(f.lo) + " and " + n3(f.hi) + " min"
                       : " with a time constant of " + n3(f.lo) + " min";
    } else if (!effect_is_shared(f.kind)) {
      const bool whole = f.where.size() == 1 && f.where[0] == "the whole test";
      p += (whole ? " over " : " in ") + or_listed(f.where);
      if (position == EffectPosition::kTime && f.lo <= f.hi)
        p += " at t = " + fmt_num(f.lo, 6) +
             (f.hi > f.lo ? " to " + fmt_num(f.hi, 6) : std::string()) + " s";
    }
    phrases.push_back(p);
  }
  for (const std::string& l : unread) phrases.push_back(l);
  return or_listed(phrases);
}

// "a length offset of -20.3 um", "a centring error of (cx, cy) = (-5.91, -1.46) um".
std::string effect_phrase(const AddedEffect& a) {
  const EffectCandidate& e = a.block.effect;
  std::string values, names;
  for (std::size_t k = 0; k < a.values.size(); ++k) {
    values += (k ? ", " : "") + n3(a.values[k].value);
    names += (k ? ", " : "") + a.block.parameters[k];
  }
  const EffectInfo& info = effect_info(e.kind);
  if (info.position == EffectPosition::kTimeConstant) {  // the value, and the fitted constant
    return std::string(kind_noun(e.kind)) + " of " +
           (a.values.empty() ? std::string("?") : n3(a.values[0].value)) + " um with a time " +
           "constant of " + n3(fitted_tau_min(a)) + " min";
  }
  const bool several = a.values.size() > 1;
  std::string p = kind_noun(e.kind);
  if (info.position == EffectPosition::kHarmonic)
    p = "a " + std::to_string(e.harmonic) + "-per-turn error";
  else if (info.by_component || several)
    p += " (" + names + ")";
  p += " of " + (several ? "(" + values + ")" : values) + " " + a.block.unit;
  if (info.position == EffectPosition::kTime && std::isfinite(e.at_s))
    p += " at t = " + fmt_num(e.at_s, 6) + " s";
  return p;
}

// Where an added effect is: "in installation 2r", "in installation 2r or 1r (the readings cannot
// tell which)", "over the whole test", or "" for the machine's linear axes.
std::string where_phrase(const Design& design, const AddedEffect& a) {
  const EffectCandidate& e = a.block.effect;
  if (effect_is_shared(e.kind)) return "";
  if (e.installation < 0) return "over the whole test";
  const std::string here = installation_of(design, e);
  std::vector<std::string> at{here};
  std::vector<std::string> along;  // the same sphere's other coordinates
  for (const std::string& l : a.equivalent_to) {
    const std::optional<EffectCandidate> o = parsed(design, l);
    if (!o || o->installation < 0) continue;
    const std::string id = installation_of(design, *o);
    if (id == here && o->kind == e.kind && o->component >= 0) {
      along.push_back(effect_parameter_names(o->kind)[static_cast<std::size_t>(o->component)]);
    } else if (std::find(at.begin(), at.end(), id) == at.end()) {
      at.push_back(id);
    }
  }
  std::string p =
      "in " +
      std::string(effect_info(e.kind).per_sphere ? "sphere"
                                                 : instrument_info(design.instrument).row_carrier) +
      " " + at[0];
  if (at.size() > 1 || !along.empty()) {
    std::vector<std::string> alternatives(at.begin() + 1, at.end());
    if (!along.empty()) alternatives.insert(alternatives.begin(), "its " + or_listed(along));
    p += " (or in " + or_listed(alternatives) + " instead: the readings cannot tell which)";
  }
  return p;
}

// A set-up effect found where the design declares its tolerance: diagnose carries one within
// it as nuisance, so one found is beyond it (" (beyond its declared tolerance, 1 um)").
std::string beyond_tolerance(const Design& design, const AddedEffect& a) {
  const EffectCandidate& e = a.block.effect;
  if (e.installation < 0 || e.installation >= static_cast<int>(design.installations.size()))
    return "";
  const SetupUncertainty u = design.setup_of(e.installation);
  const double t = setup_std_um(u, e.kind);
  return t > 0 ? " (beyond its declared tolerance, " + n3(t) + " um)" : "";
}

std::string chi_short(const Estimate& e) {
  return "chi2 " + fmt_num(e.chi2, 4) + " on " + std::to_string(e.dof) + " dof, p " +
         (e.p_value ? p_text(*e.p_value) : std::string("undefined"));
}

}  // namespace

std::vector<BriefItem> diagnose_brief(const Design& design, const DiagnoseResult& r) {
  std::vector<BriefItem> out;
  auto add = [&](const std::string& topic, const std::string& text) {
    add_brief_item(out, topic, text);
  };
  // What is wrong, grouped by where it is.
  if (!r.added.empty()) {
    std::vector<std::pair<std::string, std::vector<std::string>>> by_where;
    for (const AddedEffect& a : r.added) {
      const std::string w = where_phrase(design, a);
      auto g = std::find_if(by_where.begin(), by_where.end(),
                            [&](const auto& x) { return x.first == w; });
      if (g == by_where.end()) g = by_where.insert(by_where.end(), {w, {}});
      g->second.push_back(effect_phrase(a) + beyond_tolerance(design, a));
    }
    std::vector<std::string> groups;
    for (const auto& [w, phrases] : by_where)
      groups.push_back(listed(phrases, 120) + (w.empty() ? "" : " " + w));
    add("found", "Found: " + listed(groups, 200) + ".");
  } else if (!r.gross.empty()) {
    // The most significant (the first); the data may not tell it from others.
    const GrossReading& g = r.gross.front();
    const std::string at = g.reading ? "installation " + g.reading->installation + " at " +
                                           fmt_num(g.reading->angle_deg, 4) + " deg"
                                     : std::string("a reading");
    add("found",
        "Found: " + std::to_string(r.gross.size()) + " gross reading(s); the most significant " +
            (g.alternatives.empty() ? "is " + at
                                    : "is one of " + std::to_string(g.alternatives.size() + 1) +
                                          " readings the data cannot tell apart, such as " + at) +
            ", off by " + n3(g.value_um) + " um.");
  } else if (!r.before.p_value) {
    add("residual", "Nothing can be tested: the design leaves no redundant reading.");
  } else if (!r.significant_before) {
    add("residual", "Nothing to explain: the residual agrees with the declared noise (" +
                        chi_short(r.before) + ").");
    // What would have been found: the smallest limit of each kind.
    std::vector<std::string> limits;
    const std::vector<KindLimits> kinds = limits_by_kind(r.detection_limits);
    for (const KindLimits& k : kinds) {
      if (!k.least_label.empty())
        limits.push_back(k.kind + " of " + fmt_num(k.least, 2) + " " + k.unit);
    }
    if (!limits.empty())
      add("evidence",
          "Where this design can see them, these would have been found (power 0.9 at the "
          "declared noise): " +
              listed(limits, 100) + " or more (each candidate in the JSON).");
    if (const std::vector<std::string> unseen = unseen_kinds(kinds); !unseen.empty())
      add("blind", "This design cannot see " + comma_listed(unseen) +
                       ": no machine or bar has an effect that large or that fast; evaluate "
                       "states what an undetected drift moves.");
  } else {
    add("residual", "No effect of the library explains the residual (" + chi_short(r.before) +
                        "); the errors' uncertainties do not hold as stated.");
  }
  // How sure: the evidence and what fits almost as well.
  if (!r.added.empty()) {
    std::vector<std::string> close;
    for (const AddedEffect& a : r.added)
      close.insert(close.end(), a.close_alternatives.begin(), a.close_alternatives.end());
    std::vector<std::string> substitutes;
    for (const Substitution& s : r.substitutions) {
      std::vector<std::string> by;
      for (const EffectBlock& b : s.by) by.push_back(b.label);
      substitutes.push_back(family_phrase(design, by));
    }
    std::string alt;
    if (!close.empty()) alt = family_phrase(design, close);
    for (const std::string& s : substitutes) alt += (alt.empty() ? "" : "; or ") + s;
    add("evidence", "Evidence: with " + std::string(r.added.size() == 1 ? "it" : "them") +
                        " the residual falls from chi2 " + fmt_num(r.before.chi2, 4) + " on " +
                        std::to_string(r.before.dof) + " dof to " + fmt_num(r.after.chi2, 3) +
                        " on " + std::to_string(r.after.dof) + " dof (p " +
                        (r.after.p_value ? p_text(*r.after.p_value) : std::string("undefined")) +
                        ")" +
                        (alt.empty() ? "; nothing else in the library fits almost as well."
                                     : "; " + alt + " fits almost as well."));
    // What it changes.
    int t = -1, q = -1;
    for (int k = 0; k < 6; ++k) {
      if (!r.largest_change_of_errors[k] || *r.largest_change_of_errors[k] < 1e-6) continue;
      int& best = k < 3 ? t : q;
      if (best < 0 || *r.largest_change_of_errors[k] > *r.largest_change_of_errors[best]) best = k;
    }
    std::vector<std::string> moved;
    for (int k : {t, q}) {
      if (k >= 0)
        moved.push_back(n3(*r.largest_change_of_errors[k]) + " " + kErrorUnits[k] + " (" +
                        kErrorNames[k] + ")");
    }
    if (!moved.empty())
      add("changes", "Correcting for " + std::string(r.added.size() == 1 ? "it" : "them") +
                         " moves the axis errors by up to " + listed(moved) + ".");
  }
  // What fitted significantly at a size no machine or bar has: not a finding, but a sign of
  // something the library lacks.
  std::vector<std::string> absurd;
  for (const CandidateStatus& c : r.candidates) {
    if (c.state != CandidateState::kImplausible) continue;
    const std::string label = c.other.empty() ? c.label : c.other;
    absurd.push_back(c.reason == CandidateReason::kBeyondDriftRate
                         ? label + ", " + rate_phrase(c) + " (beyond the " + fmt_num(c.level, 3) +
                               " um/min of instrument.max_drift_um_per_min)"
                         : label + ", moving the bar " + fmt_num(c.implied_um, 3) +
                               " um (beyond the instrument's +-" + fmt_num(c.level, 3) + " um)");
  }
  if (!absurd.empty())
    add("left out", "Not a finding: " + listed(absurd, 150) +
                        ": significant, but no machine or bar has it; something the library "
                        "lacks behaves like it.");
  // The location errors a choice the readings cannot make leaves uncertain.
  if (!r.attributions.empty()) {
    std::vector<std::string> uncertain, hold;
    bool convention = false;
    for (std::size_t i = 0; i < r.iso_after.location.size(); ++i) {
      const IsoQuantity& loc = r.iso_after.location[i];
      if (!loc.value.determined) continue;
      double share2 = 0;
      for (const Attribution& at : r.attributions) {
        if (i >= at.iso_change.size()) continue;
        share2 += at.iso_change[i] * at.iso_change[i] / (at.convention ? 1.0 : 3.0);
        convention = convention || (at.convention && at.iso_change[i] > 0);
      }
      if (share2 > 0.5 * loc.value.std * loc.value.std) {
        uncertain.push_back(loc.name + " (" + n3(loc.value.value) + " +- " + n3(2 * loc.value.std) +
                            " " + loc.unit + ")");
      } else {
        hold.push_back(loc.name);
      }
    }
    if (!uncertain.empty()) {
      add("uncertainty", std::string(convention ? "Because the readings cannot make that choice, "
                                                : "Because the alternatives fit almost as well, ") +
                             listed(uncertain, 140) + (uncertain.size() == 1 ? " is" : " are") +
                             " uncertain (k = 2)" +
                             (hold.empty() ? "" : "; " + listed(hold) + " hold") + ".");
    }
  }
  // What to do next.
  std::vector<std::string> next;
  auto action = [&](const std::string& a) {
    if (std::find(next.begin(), next.end(), a) == next.end()) next.push_back(a);
  };
  if (!r.gross.empty()) action("check the gross reading(s) at the machine and measure again");
  bool remeasure = false;  // a set-up to redo: measure it again after
  for (const AddedEffect& a : r.added) {
    const EffectCandidate& e = a.block.effect;
    std::string inst = e.installation >= 0 ? installation_of(design, e) : std::string();
    std::vector<std::string> ids{inst};
    for (const std::string& l : a.equivalent_to) {
      const std::optional<EffectCandidate> o = parsed(design, l);
      if (!o || o->installation < 0) continue;
      const std::string id = installation_of(design, *o);
      if (std::find(ids.begin(), ids.end(), id) != ids.end()) continue;
      ids.push_back(id);
      inst += " or " + id;
    }
    const EffectInfo& info = effect_info(e.kind);
    const char* step = design.axis.head() && info.next_step_on_head ? info.next_step_on_head
                       : inst.empty() && info.next_step_whole_test  ? info.next_step_whole_test
                                                                    : info.next_step;
    action(filled(step, {{"{where}", inst},
                         {"{settle_min}", n3(3 * fitted_tau_min(a))},
                         {"{harmonic}", std::to_string(e.harmonic)}}));
    remeasure = remeasure || info.redo_setup;
  }
  if (remeasure) action("then measure again");
  bool convention = false;
  for (const Attribution& at : r.attributions) convention = convention || at.convention;
  if (convention)
    action(std::string("to tell the equivalent effects apart, add ") +
           instrument_info(design.instrument).item + " that separates them");
  if (r.significant_after && r.order && r.order->p < r.level)
    action("set errors.order to " + std::to_string(r.order->suggested) + " in the design");
  if (r.noise_larger_than_declared)
    action("state the uncertainties from the scatter (identify --type-a) or check the instrument");
  if (!r.setup_risks.empty() && !design.setup_nuisance_declared())
    action(
        "declare set-up tolerances (setup_std) in the design: without them the intervals "
        "assume a perfect set-up");
  if (next.empty() && !r.significant_after)
    action("enter the errors (compensation) or decide on them (--tolerances)");
  add_next_items(out, next);
  return out;
}

}  // namespace dbbkit::io
