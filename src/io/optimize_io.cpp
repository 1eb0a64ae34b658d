#include "dbbkit/io/optimize_io.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/io/design_io.hpp"
#include "dbbkit/io/result_io.hpp"
#include "dbbkit/io/text.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/user_text.hpp"
#include "result_blocks.hpp"

namespace dbbkit::io {

using nlohmann::json;

namespace {

std::string where(const WorstCase& w) {
  if (w.at_error < 0) return "";
  return std::string(" (") + kErrorNames[w.at_error] + " at " + fmt_num(w.at_angle_deg, 6) +
         " deg)";
}

json candidate_json(const Kit& kit, const Candidate& c) {
  json j;
  j["choice"] = choice_label(kit, c.choice);
  j["step_deg"] = c.choice.step_deg;
  // A probe's design counts its spheres (each three channels, the design's installations).
  const std::string items = instrument_info(kit.instrument).items;
  j["n_" + items] = measured_count(c.design);
  j["added_" + items] = added_installations(kit, c);
  j["n_angles"] = c.design.angles_deg.size();
  j["time_s"] = c.time_s;
  j["worst_std_um"] = optional_number(c.worst.worst_std_um);
  j["worst_determined_std_um"] = optional_number(c.worst.worst_determined_std_um);
  j["n_undetermined"] = c.n_undetermined;
  j["objective"] = c.objective_defined ? json(c.objective) : json(nullptr);
  const PatternSpace& space = c.choice.space;
  json vars = json::object();
  for (size_t i = 0; i < space.names.size(); ++i) vars[space.names[i]] = c.x[i];
  j["variables_mm"] = vars;
  if (c.detection) {
    const Candidate::Detection& d = *c.detection;
    j["setup_detection"] = {
        {"level", d.settings.level},
        {"n_tests", d.settings.n_tests},
        {"power", d.settings.power},
        {"largest_ratio", std::isfinite(d.ratio) ? json(d.ratio) : json(nullptr)},
        {"effect", d.effect},
        {"detection_limit_um", optional_number(d.limit_um)},
        {"declared_std_um", d.declared_std_um},
        {"met", d.ratio <= 1.0}};
  }
  return j;
}

}  // namespace

std::string drift_text(const DriftChecks& d, InstrumentKind instrument) {
  if (!instrument_info(instrument).has_clock)
    return std::string("not checked: ") + instrument_info(instrument).no_clock_reason;
  for (const DriftCheck& c : d.effects) {
    if (c.kind != EffectKind::kDrift) continue;
    std::string t = "over the " + fmt_num(d.test_min, 3) + " min test (the kit's clock): ";
    t += c.detection_limit_um ? "detected from " + fmt_num(*c.detection_limit_um, 3) + " um"
                              : std::string("not detectable");
    if (c.bias_per_um)
      t += "; 1 um undetected moves " + std::string(kErrorNames[c.bias_error]) + " at " +
           fmt_num(c.bias_angle_deg) + " deg by " + fmt_num(*c.bias_per_um, 3) + " " +
           kErrorUnits[c.bias_error];
    return t;
  }
  return "the test has one time only";
}

std::string detection_text(const Candidate::Detection& d) {
  std::string t =
      "required of every declared set-up effect and drift (found by diagnose at its declared "
      "size, power " +
      fmt_num(d.settings.power) + " at level " + fmt_num(d.settings.level) +
      (d.settings.n_tests > 1 ? " / " + std::to_string(d.settings.n_tests) + " candidates" : "") +
      "): ";
  if (d.effect.empty()) return t + "no declared effect changes a reading";
  t += d.ratio <= 1.0 ? "met; the closest is " : "not met; ";
  t += d.effect;
  if (d.limit_um) {
    t += ", detected from " + fmt_num(*d.limit_um, 4) + " um" +
         (d.effect.rfind("drift", 0) == 0 ? " over the test (required " : " (declared ") +
         fmt_num(d.declared_std_um, 4) + " um)";
  } else {
    t += ", which the axis errors take (not detectable)";
  }
  return t;
}

Design optimized_design(const Kit& kit, const OptimizeResult& res, const std::string& kit_file) {
  Design d = res.best->design;
  const Evaluation& ev = res.best_evaluation;
  // The kit's path as text the design may hold (user_text.hpp): escaped, at most 300 bytes.
  d.description = "Found by dbbkit optimize in kit " + printable(kit_file, 300) + " (criterion " +
                  criterion_name(res.criterion) + "): " + choice_label(kit, res.best->choice) + ".";
  Prediction p;
  p.criterion = criterion_name(res.criterion);
  p.worst_std_um = ev.worst.worst_std_um;
  p.worst_determined_std_um = ev.worst.worst_determined_std_um;
  if (ev.worst_total) p.worst_total_std_um = ev.worst_total->worst_std_um;
  p.rank = ev.prior.rank;
  p.n_unknowns = ev.prior.n_unknowns;
  p.time_s = res.best->time_s;
  d.predicted = p;
  return d;
}

std::string choice_status_text(const Kit& kit, const ChoiceResult& cr) {
  auto mm = [](double x) { return fmt_rounded(x, 3); };
  switch (cr.state) {
    case ChoiceState::kSearched:
      return "searched";
    case ChoiceState::kOverTimeBudget:
      return "over the time budget (" + mm(cr.time_s) + " s > " +
             mm(kit.time_budget_s.value_or(0.0)) + " s)";
    case ChoiceState::kUndetectableEverywhere: {
      std::string list;
      if (cr.best && cr.best->detection) {
        for (const std::string& e : cr.best->detection->undetectable)
          list += (list.empty() ? "" : ", ") + e;
      }
      return std::string("no position lets diagnose detect every declared set-up effect") +
             (kit.require_drift_detection_um ? " (and the drift required)" : "") +
             ": the axis errors take " + list + " at every position of this choice";
    }
    case ChoiceState::kOutsideTravel:
      if (cr.best && !cr.best->machine_clash.empty())
        return "no position is one the machine's program takes (the nearest: " +
               cr.best->machine_clash + ")";
      if (kit.instrument == InstrumentKind::kProbe)
        return "no position keeps the probe's approach inside travel" +
               std::string(kit.probe.max_stem_tilt_deg ? ", the stems within their tilt" : "") +
               (kit.workspace ? ", the stands on the table" : "") + " (least excursion " +
               mm(cr.best ? cr.best->travel_violation_mm : 0.0) +
               (kit.probe.max_stem_tilt_deg ? " mm, or deg of a stem's tilt)" : " mm)");
      return std::string(kit.workspace || kit.axis.table()
                             ? "no position keeps the following ball inside travel and the "
                               "set-up clear of the workspace (least excursion "
                             : "no position keeps the following ball inside travel (least "
                               "excursion ") +
             mm(cr.best ? cr.best->travel_violation_mm : 0.0) + " mm)";
    case ChoiceState::kTooClose:
      return std::string("no position keeps the ") + instrument_info(kit.instrument).points +
             " min_separation_mm apart";
    case ChoiceState::kSetupNotDetected: {
      if (!cr.best || !cr.best->detection) break;
      const Candidate::Detection& d = *cr.best->detection;
      const bool drift = d.effect.rfind("drift", 0) == 0;
      return std::string("no position lets diagnose detect every declared set-up effect") +
             (kit.require_drift_detection_um ? " (and the drift required)" : "") +
             " at its declared size: " + d.effect +
             (d.limit_um ? " is detected from " + mm(*d.limit_um) +
                               (drift ? " um over the test (required " : " um (declared ") +
                               mm(d.declared_std_um) + " um)"
                         : " cannot be told from the axis errors");
    }
    case ChoiceState::kNoFeasiblePosition:
      break;
  }
  return "no feasible position";
}

std::string time_sum(const Kit& kit, int positions, int installations, int readings) {
  std::string t;
  if (kit.instrument == InstrumentKind::kProbe)
    return std::to_string(positions) + (positions == 1 ? " sphere x " : " spheres x ") +
           fmt_num(kit.time_per_position_s) + " s + " + std::to_string(readings) + " probings x " +
           fmt_num(kit.time_per_reading_s) + " s";
  if (kit.time_per_position_s > 0)
    t = std::to_string(positions) + " positions x " + fmt_num(kit.time_per_position_s) + " s + ";
  return t + std::to_string(installations) + " installations x " +
         fmt_num(kit.time_per_installation_s) + " s + " + std::to_string(readings) +
         " readings x " + fmt_num(kit.time_per_reading_s) + " s";
}

std::string rounding_text(const OptimizeResult& res) {
  if (!res.rounding || !res.best) return "";
  const OptimizeResult::Rounding& r = *res.rounding;
  const std::string head = "positions rounded to the kit's resolution of " +
                           fmt_num(r.resolution_mm) + " mm (" + std::to_string(r.tried) +
                           " rounded designs checked and scored): ";
  if (!r.applied)
    return head +
           (r.tried == 0 ? "a position's range holds no multiple of it" : "none is feasible") +
           ", the positions are written as searched (not rounded)";
  std::string t = head + criterion_name(res.criterion) + " " + fmt_num(r.unrounded.objective, 6) +
                  " as searched, " + fmt_num(res.best->objective, 6) + " rounded";
  if (r.unrounded.objective > 0)
    t += " (" + std::string(res.best->objective >= r.unrounded.objective ? "+" : "") +
         fmt_rounded(100.0 * (res.best->objective / r.unrounded.objective - 1.0), 2) + " %)";
  return t;
}

std::string binding_text(const Kit& kit, const OptimizeResult& res) {
  return binding_text(kit, res, binding_constraints(kit, res));
}

std::string binding_text(const Kit& kit, const OptimizeResult& res,
                         const std::vector<BindingConstraint>& binding) {
  const size_t total = res.choices.size();
  std::string out;
  for (const BindingConstraint& b : binding) {
    const ChoiceResult& cr = res.choices[b.closest];
    std::string t;
    if (b.state == ChoiceState::kOverTimeBudget) {
      t = std::string(binding.size() > 1 ? "the shortest of them, " : "the shortest design, ") +
          time_sum(kit, b.positions, b.installations, b.readings) + " = " +
          fmt_rounded(b.time_s, 3) + " s, already exceeds the time budget of " +
          fmt_rounded(kit.time_budget_s.value_or(0.0), 3) + " s";
    } else {
      t = choice_status_text(kit, cr);
      if (b.state == ChoiceState::kOutsideTravel || b.state == ChoiceState::kTooClose ||
          b.state == ChoiceState::kSetupNotDetected)
        t += " (nearest: " + cr.label + ")";
    }
    if (binding.size() > 1)
      t = std::to_string(b.choices) + " of " + std::to_string(total) + " choices: " + t;
    else
      t += " (all " + std::to_string(total) + " choices)";
    out += (out.empty() ? "" : "; ") + t;
  }
  return out.empty() ? "no choice was searched" : out;
}

json optimize_to_json(const Kit& kit, const OptimizeResult& res, const std::string& kit_file,
                      double seconds, const std::optional<Reference>& reference) {
  json j;
  j["format"] = "dbbkit.optimize/1";
  j["dbbkit_version"] = DBBKIT_VERSION;
  j["summary"] = brief_to_json(optimize_brief(kit, res, reference));
  j["kit_file"] = kit_file;
  j["axis"] = axis_to_json(kit.axis);
  j["pattern"] = kit.pattern.name;
  j["criterion"] = criterion_name(res.criterion);
  j["reference_length_mm"] = kit.reference_length_mm;
  j["reference_length_from"] = reference_length_basis_text(kit);
  j["noise"] = noise_to_json(kit.noise);
  j["evaluations"] = res.evaluations;
  j["seconds"] = seconds;
  if (res.rank_five != OptimizeResult::RankFiveCause::kNone) j["note"] = rank_five_note(kit, res);
  if (res.best) {
    const Evaluation& ev = res.best_evaluation;
    json b = candidate_json(kit, *res.best);
    b["design"] = design_to_json(optimized_design(kit, res, kit_file));
    add_rank_block(b, ev.prior);
    b["worst_std_um"] = optional_number(ev.worst.worst_std_um);
    b["worst_determined_std_um"] = optional_number(ev.worst.worst_determined_std_um);
    b["worst_total_std_um"] =
        ev.worst_total ? optional_number(ev.worst_total->worst_std_um) : json(nullptr);
    b["setup_note"] = evaluation_setup_note(ev);
    b["errors"] = errors_to_json(ev.errors, false);
    b["unidentifiable"] = unidentifiable_to_json(ev.unidentifiable);
    j["best"] = b;
  } else {
    j["best"] = nullptr;
  }
  json choices = json::array();
  for (const ChoiceResult& cr : res.choices) {
    json c = cr.best ? candidate_json(kit, *cr.best) : json{{"choice", cr.label}};
    c["status"] = choice_status_text(kit, cr);
    c["state"] = choice_state_name(cr.state);
    c["budget_exhausted"] = cr.budget_exhausted;
    choices.push_back(c);
  }
  j["choices"] = choices;
  json front = json::array();
  for (const Candidate& c : res.pareto) front.push_back(candidate_json(kit, c));
  j["pareto"] = front;
  if (res.rounding) {
    j["rounding"] = {{"resolution_mm", res.rounding->resolution_mm},
                     {"applied", res.rounding->applied},
                     {"tried", res.rounding->tried},
                     {"as_searched", candidate_json(kit, res.rounding->unrounded)},
                     {"text", rounding_text(res)}};
  }
  if (!res.best) {
    const std::vector<BindingConstraint> constraints = binding_constraints(kit, res);
    json binding = json::array();
    for (const BindingConstraint& b : constraints) {
      json e = {{"state", choice_state_name(b.state)},
                {"choices", b.choices},
                {"nearest", res.choices[b.closest].label}};
      if (b.state == ChoiceState::kOverTimeBudget) {
        e["time_s"] = b.time_s;
        e["positions"] = b.positions;
        e["installations"] = b.installations;
        e["readings"] = b.readings;
      }
      binding.push_back(e);
    }
    j["binding"] = binding;
    j["binding_text"] = binding_text(kit, res, constraints);
  }
  if (reference) {
    json r = {
        {"file", reference->file},
        {"worst_std_um", optional_number(reference->worst.worst_std_um)},
        {"worst_determined_std_um", optional_number(reference->worst.worst_determined_std_um)},
        {"rank", reference->rank},
        {"n_unknowns", reference->n_unknowns}};
    const ReferenceRatios ratios = reference_ratios(res, *reference);
    r["ratio_worst_std_um"] = optional_number(ratios.worst_std_um);
    if (reference->worst_total) {
      r["worst_total_std_um"] = optional_number(reference->worst_total->worst_std_um);
      r["ratio_worst_total_std_um"] = optional_number(ratios.worst_total_std_um);
    }
    j["reference"] = r;
  }
  return j;
}

std::vector<BriefItem> optimize_brief(const Kit& kit, const OptimizeResult& res,
                                      const std::optional<Reference>& reference) {
  std::vector<BriefItem> out;
  auto add = [&](const std::string& topic, const std::string& text) {
    add_brief_item(out, topic, text);
  };
  if (!res.best) {
    add("best", "No design fits the kit: " + binding_text(kit, res));
    add("next", instrument_info(kit.instrument).widen_next);
    return out;
  }
  const Candidate& b = *res.best;
  const Evaluation& ev = res.best_evaluation;
  const std::size_t n = b.design.installations.size(), m = b.design.angles_deg.size();
  const bool probe = kit.instrument == InstrumentKind::kProbe;
  if (probe) {
    const std::size_t spheres = b.design.spheres.size();
    add("best", "Best: " + std::to_string(spheres) + " sphere" + (spheres == 1 ? "" : "s") + ", " +
                    std::to_string(m) + " angles (step " + fmt_num(b.choice.step_deg, 6) +
                    " deg), " + std::to_string(spheres * m) + " probed centres (" +
                    std::to_string(n * m) + " readings), about " + fmt_rounded(b.time_s / 60.0, 1) +
                    " min by the kit's time model.");
  } else {
    add("best", "Best: " + std::to_string(n) + " installations at " +
                    std::to_string(ball_positions(b.design)) + " ball positions, " +
                    std::to_string(m) + " angles (step " + fmt_num(b.choice.step_deg, 6) +
                    " deg), " + std::to_string(n * m) + " readings, about " +
                    fmt_rounded(b.time_s / 60.0, 1) + " min by the kit's time model.");
  }
  const std::string noise = worst_phrase(ev.worst, kit.reference_length_mm);
  // A design that leaves some errors undetermined states the worst of those it determines.
  const bool partial = ev.prior.rank < ev.prior.n_unknowns;
  const std::string lead = partial ? "Worst standard uncertainty of the determined errors (k = 1): "
                                   : "Worst standard uncertainty (k = 1): ";
  const std::string undetermined = partial ? "; rank " + std::to_string(ev.prior.rank) + " of " +
                                                 std::to_string(ev.prior.n_unknowns) +
                                                 ": the others are not determined"
                                           : "";
  if (ev.worst_total) {
    add("worst", lead + worst_phrase(*ev.worst_total, kit.reference_length_mm) +
                     " with the kit's set-up tolerances; " + noise + " from the reading noise" +
                     undetermined + ".");
  } else if (!noise.empty()) {
    add("worst", lead + noise + ", from the reading noise alone" + undetermined + ".");
  } else {
    add("worst", "Not determined: no error at any angle (rank " + std::to_string(ev.prior.rank) +
                     " of " + std::to_string(ev.prior.n_unknowns) +
                     "): the kit admits no design that measures them.");
  }
  // Where the kit states no lever arm, the summary says which it took (the text and the JSON
  // always do).
  if (kit.reference_length_basis != Kit::ReferenceLengthBasis::kStated)
    add("lever", "Angular errors weighed at " + fmt_num(kit.reference_length_mm, 6) +
                     " mm: " + reference_length_basis_text(kit) + ".");
  if (ev.worst_total_typical) {
    add("setup",
        "The kit declares no length offset or centring tolerance: with typical ones "
        "(length offset " +
            fmt_num(kTypicalLengthOffsetStd_um, 3) + " um, centring " +
            fmt_num(kTypicalCentringStd_um, 3) + " um) the worst would be " +
            worst_phrase(*ev.worst_total_typical, kit.reference_length_mm) + ".");
  }
  if (reference) {
    const ReferenceRatios r = reference_ratios(res, *reference);
    const std::optional<double>& ratio =
        r.worst_total_std_um ? r.worst_total_std_um : r.worst_std_um;
    if (ratio)
      add("reference", "Against the reference design: " + fmt_num(*ratio, 3) +
                           " times its worst standard uncertainty (" + reference->file + ").");
  }
  if (!kit.angle_max_step_deg && kit.angle_steps_deg.size() > 1 &&
      kit.errors.kind == ErrorModel::Kind::kPerAngle) {
    double coarsest = 0;
    for (double st : kit.angle_steps_deg) coarsest = std::max(coarsest, st);
    if (std::abs(b.choice.step_deg - coarsest) < kAngleTolerance_deg)
      add("angles", "The step is the kit's coarsest (" + fmt_num(coarsest, 6) +
                        " deg): per-angle errors are known as well at any step, so the shorter "
                        "measurement wins; set angles_deg.max_step to the resolution you need.");
  }
  if (noise.empty() && !ev.worst_total) {  // nothing determined: nothing to measure yet
    add("next", probe ? "Next: widen what binds (the time budget, the travel or approach_mm, the "
                        "blocks) until a design determines the errors."
                      : "Next: widen what binds (the time budget, the travel, the blocks or bars) "
                        "until a design determines the errors.");
    return out;
  }
  add("next", probe ? "Next: probe the spheres of the design written (--out) at its angles, "
                      "then dbbkit identify with the probed centres."
                    : "Next: dbbkit setup-sheet and program with the design written (--out), an "
                      "air run first.");
  return out;
}

std::string optimize_summary(const Kit& kit, const OptimizeResult& res, const std::string& kit_file,
                             double seconds, const std::optional<Reference>& reference,
                             bool pareto) {
  std::ostringstream s;
  s << brief_text(optimize_brief(kit, res, reference));
  int searched = 0;
  for (const ChoiceResult& cr : res.choices) searched += cr.state == ChoiceState::kSearched;
  s << "kit " << kit_file << ": axis " << kit.axis.label() << ", pattern " << kit.pattern.name
    << ", " << kit.errors.describe() << ", noise " << kit.noise.describe() << "\n";
  s << "criterion " << criterion_name(res.criterion) << "; " << res.choices.size()
    << " discrete choices, " << searched << " feasible; " << res.evaluations
    << " designs scored in " << fmt_num(seconds, 3) << " s\n";
  if (res.rank_five != OptimizeResult::RankFiveCause::kNone)
    s << "note: " << rank_five_note(kit, res) << "\n";
  if (!res.best) {
    s << "\nno design fits the kit: " << binding_text(kit, res) << "\n";
    return s.str();
  }
  const Candidate& b = *res.best;
  const Evaluation& ev = res.best_evaluation;
  const bool probe = kit.instrument == InstrumentKind::kProbe;
  s << "\nbest: " << choice_label(kit, b.choice) << "\n";
  // A coordinate that rounds to zero is written 0.00, not -0.00.
  auto mm = [](double x) { return std::abs(x) < 0.005 ? 0.0 : x; };
  const size_t n_inst = b.design.installations.size(), n_ang = b.design.angles_deg.size();
  if (probe) {
    s << std::setw(4) << "id" << std::setw(10) << "L [mm]" << std::setw(10) << "D [mm]"
      << std::setw(10) << "H [mm]"
      << "  stand\n";
    for (const Sphere& sp : b.design.spheres) {
      s << std::setw(4) << sp.id << std::fixed << std::setprecision(2) << std::setw(10)
        << mm(sp.L_mm) << std::setw(10) << mm(sp.D_mm) << std::setw(10) << mm(sp.H_mm) << "  "
        << sp.description << "\n";
      s.unsetf(std::ios::fixed);
    }
    const TimeEstimate t = design_time(kit, b.design);
    s << "time " << fmt_num(b.time_s, 6)
      << " s = " << time_sum(kit, t.positions, t.installations, t.readings);
  } else {
    s << std::setw(4) << "id" << std::setw(10) << "L [mm]" << std::setw(10) << "D [mm]";
    if (kit.axis.has_H()) s << std::setw(10) << "H [mm]";
    s << std::setw(13) << "direction" << std::setw(10) << "bar [mm]" << std::setw(6) << "sign"
      << "\n";
    for (const Installation& in : b.design.installations) {
      s << std::setw(4) << in.id << std::fixed << std::setprecision(2) << std::setw(10)
        << mm(in.L_mm) << std::setw(10) << mm(in.D_mm);
      if (kit.axis.has_H()) s << std::setw(10) << mm(in.H_mm);
      s << std::setw(13) << in.direction.label() << std::setw(10) << *in.bar_mm << std::setw(6)
        << in.sign << "\n";
      s.unsetf(std::ios::fixed);
    }
    s << "time " << fmt_num(b.time_s, 6) << " s = "
      << time_sum(kit, ball_positions(b.design), static_cast<int>(n_inst),
                  static_cast<int>(n_inst * n_ang));
  }
  if (kit.time_budget_s) s << " (budget " << fmt_num(*kit.time_budget_s, 6) << " s)";
  s << "\n";
  s << "rank " << ev.prior.rank << " of " << ev.prior.n_unknowns;
  if (ev.prior.condition_number) s << ", condition number " << fmt_num(*ev.prior.condition_number);
  s << "\n";
  if (ev.worst.worst_std_um) {
    s << "worst_std_um (k = 1) " << fmt_num(*ev.worst.worst_std_um) << " um" << where(ev.worst)
      << ", angular errors at " << fmt_num(kit.reference_length_mm)
      << " mm: " << reference_length_basis_text(kit) << "\n";
  } else if (ev.worst.worst_determined_std_um) {
    s << "worst_std_um: none (" << ev.worst.n_undetermined
      << " errors at angles not determined); worst determined "
      << fmt_num(*ev.worst.worst_determined_std_um) << " um" << where(ev.worst) << "\n";
  }
  if (res.criterion != Criterion::kWorst && b.objective_defined) {
    s << criterion_name(res.criterion) << " objective " << fmt_num(b.objective, 6) << "\n";
  }
  if (res.rounding) s << rounding_text(res) << "\n";
  if (b.detection) s << "set-up detection " << detection_text(*b.detection) << "\n";
  s << "drift " << drift_text(ev.drift, kit.instrument) << "\n";
  s << unidentifiable_text(ev.unidentifiable);
  if (ev.setup_included) {
    s << "\npredicted standard uncertainty (k = 1) at each angle, total (noise and the declared "
         "set-up "
         "tolerances):\n"
      << errors_table(ev.total_errors, false);
  } else {
    s << "\npredicted standard uncertainty (k = 1) at each angle (" << evaluation_setup_note(ev)
      << "):\n"
      << errors_table(ev.errors, false);
  }
  if (reference) {
    const ReferenceRatios ratios = reference_ratios(res, *reference);
    s << "\nreference " << reference->file << ": rank " << reference->rank << " of "
      << reference->n_unknowns;
    if (reference->worst.worst_std_um) {
      s << ", worst_std_um " << fmt_num(*reference->worst.worst_std_um) << " um"
        << where(reference->worst);
      if (ratios.worst_std_um)
        s << "\nratio optimised / reference: " << fmt_num(*ratios.worst_std_um, 3);
    } else {
      s << ", worst_std_um: none (not every error determined)";
    }
    if (reference->worst_total && reference->worst_total->worst_std_um) {
      s << "\nreference with the same set-up tolerances: worst_total_std_um "
        << fmt_num(*reference->worst_total->worst_std_um) << " um";
      if (ratios.worst_total_std_um) {
        s << "; optimised " << fmt_num(*ev.worst_total->worst_std_um) << " um, ratio "
          << fmt_num(*ratios.worst_total_std_um, 3);
      }
    }
    s << "\n";
  }
  if (kit.angle_max_step_deg) {
    s << "\nangle steps: at most " << fmt_num(*kit.angle_max_step_deg, 6)
      << " deg (the kit's angles_deg.max_step); coarser ones were not tried.\n";
  } else if (kit.errors.kind == ErrorModel::Kind::kPerAngle && kit.angle_steps_deg.size() > 1) {
    s << "\nper_angle errors: each angle has its own six unknowns, so a finer step adds angles, "
         "each known as "
         "well as before; between designs equally good the shorter measurement (the coarser step) "
         "is chosen. "
         "Leave out of the kit the steps coarser than the spacing the errors are needed at.\n";
  }
  if (pareto) {
    s << "\nPareto front, " << criterion_name(res.criterion)
      << " against time (designs that determine as much as "
      << "the best; each the best of its angle step and " << instrument_info(kit.instrument).items
      << "):\n";
    s << std::setw(10) << "time [s]" << std::setw(15) << instrument_info(kit.instrument).items
      << std::setw(8) << "angles" << std::setw(12) << "step [deg]" << std::setw(20)
      << criterion_name(res.criterion) << "  added (optional positions)\n";
    for (const Candidate& c : res.pareto) {
      s << std::setw(10) << fmt_num(c.time_s, 6) << std::setw(15) << measured_count(c.design)
        << std::setw(8) << c.design.angles_deg.size() << std::setw(12) << fmt_num(c.choice.step_deg)
        << std::setw(20) << fmt_num(c.objective, 5) << "  " << added_installations(kit, c) << "\n";
    }
  }
  return s.str();
}

std::string pareto_csv(const Kit& kit, const OptimizeResult& res) {
  std::ostringstream s;
  const char* items = instrument_info(kit.instrument).items;
  s << "time_s,n_" << items << ",n_angles,step_deg," << criterion_name(res.criterion) << ",added_"
    << items << "\n";
  s << std::setprecision(10);
  for (const Candidate& c : res.pareto) {
    s << c.time_s << "," << measured_count(c.design) << "," << c.design.angles_deg.size() << ","
      << c.choice.step_deg << "," << c.objective << "," << added_installations(kit, c) << "\n";
  }
  return s.str();
}

std::string rank_five_note(const Kit& kit, const OptimizeResult& res) {
  switch (res.rank_five) {
    case OptimizeResult::RankFiveCause::kNone:
      return "";
    case OptimizeResult::RankFiveCause::kNoLateralOffset:
      return "the kit allows no lateral offset (D_mm = [" + fmt_rounded(kit.D_mm.min, 3) + ", " +
             fmt_rounded(kit.D_mm.max, 3) + "]" +
             (kit.axis.has_H() ? ", axial_mm = [" + fmt_rounded(kit.axial_mm.min, 3) + ", " +
                                     fmt_rounded(kit.axial_mm.max, 3) + "]"
                               : std::string()) +
             "): every ball lies on the tool axis, so a rotation about that axis is unobservable "
             "(rank 5 of 6 at every angle); the search minimises what is identifiable";
    case OptimizeResult::RankFiveCause::kNoOffAxisDesignFits:
      return "no design with the off-axis position fits the kit (time budget or travel): rank 5 "
             "of 6 at every angle; the search minimises what is identifiable";
  }
  return "";
}

}  // namespace dbbkit::io
