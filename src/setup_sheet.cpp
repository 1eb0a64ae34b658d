#include "dbbkit/setup_sheet.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/observability.hpp"
#include "dbbkit/user_text.hpp"
#include "number_text.hpp"

namespace dbbkit {

namespace {

// One stack change outweighs every bar change (a design has far fewer than 1000 bars).
constexpr long kStackWeight = 1000;
// The exact order's table holds 2^positions x positions x ways states at most this many.
constexpr size_t kMaxExactStates = size_t{1} << 20;

bool same(double a, double b) { return std::abs(a - b) <= kAssemblyTolerance_mm; }

bool same_lengths(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!same(a[i], b[i])) return false;
  return true;
}

bool same_ball_position(const Installation& a, const Installation& b) {
  return same(a.L_mm, b.L_mm) && same(a.D_mm, b.D_mm) && same(a.H_mm, b.H_mm);
}

bool same_stack(const AxisFrame& axis, const Installation& a, const Installation& b,
                std::optional<int> coordinate) {
  if (!axis.table()) return true;
  if (a.cup_mm && b.cup_mm)
    return same(*a.cup_mm, *b.cup_mm) && same_lengths(a.blocks_mm, b.blocks_mm);
  if (!coordinate && !axis.shorthand().empty()) coordinate = 2;
  if (!coordinate) return same(a.L_mm, b.L_mm) && same(a.H_mm, b.H_mm);
  return *coordinate == 0 ? same(a.L_mm, b.L_mm) : same(a.H_mm, b.H_mm);
}

bool same_bar(const Installation& a, const Installation& b) {
  if (a.bar_mm.has_value() != b.bar_mm.has_value()) return false;
  if (a.bar_mm && !same(*a.bar_mm, *b.bar_mm)) return false;
  return a.bar_parts_mm.empty() || b.bar_parts_mm.empty() ||
         same_lengths(a.bar_parts_mm, b.bar_parts_mm);
}

double bar_length(const Installation& in) { return in.bar_mm.value_or(0.0); }

// The installations at one ball position. Installations with the same bar form a class and
// follow each other; any class may come first and any other last (the order of those between
// does not change the count), so each (first, last) pair is one way to set the position up.
// A way is kept as its pair alone: the cost of joining two positions depends only on the
// installations at their ends, and the order is formed for the ways chosen (memory grows as
// the square of the bar lengths at one position, not as their cube).
struct Group {
  std::vector<std::vector<int>> classes;  // by bar length
  std::vector<std::pair<int, int>> ways;  // (first class, last class)

  int first(size_t w) const { return classes[ways[w].first].front(); }
  int last(size_t w) const { return classes[ways[w].second].back(); }
  void append_order(size_t w, std::vector<int>& order) const {
    const auto [f, l] = ways[w];
    order.insert(order.end(), classes[f].begin(), classes[f].end());
    for (int c = 0; c < static_cast<int>(classes.size()); ++c)
      if (c != f && c != l) order.insert(order.end(), classes[c].begin(), classes[c].end());
    if (l != f) order.insert(order.end(), classes[l].begin(), classes[l].end());
  }
};

// The steps along an order of installations: the cup moves (and the position number grows)
// where the ball position changes, the stack and the bar where they differ from the step
// before; the first step sets everything up.
std::vector<SetupStep> steps_along(const Design& d, const std::vector<int>& order,
                                   std::optional<int> coordinate) {
  std::vector<SetupStep> steps;
  int positions = 0;
  for (size_t k = 0; k < order.size(); ++k) {
    const Installation& in = d.installations[order[k]];
    const Installation* prev = k ? &d.installations[order[k - 1]] : nullptr;
    SetupStep s;
    s.installation = order[k];
    s.moves_cup = !prev || !same_ball_position(*prev, in);
    positions += s.moves_cup;
    s.position = positions;
    s.changes_stack = d.axis.table() && (!prev || !same_stack(d.axis, *prev, in, coordinate));
    s.changes_bar = !prev || !same_bar(*prev, in);
    steps.push_back(s);
  }
  return steps;
}

// The changes after the first step: (stack, bar, cup), in the order they are minimised.
std::tuple<int, int, int> changes(const std::vector<SetupStep>& steps) {
  int stacks = 0, bars = 0, cups = 0;
  for (size_t k = 1; k < steps.size(); ++k) {
    stacks += steps[k].changes_stack;
    bars += steps[k].changes_bar;
    cups += steps[k].moves_cup;
  }
  return {stacks, bars, cups};
}

// A kit of the design's axis, or none.
void check_kit_axis(const Kit* kit, const Design& design) {
  if (kit && !kit->axis.same_as(design.axis))
    throw InputError(option_name("--kit"), "axis",
                     std::string("the kit is for axis ") + kit->axis.label() +
                         ", the design for axis " + design.axis.label() + " (the kit's " +
                         axis_difference(kit->axis, design.axis) + ")");
  // The "B" shorthand's D is the general form's H: a kit and a design of one axis in the two
  // forms would place the ball differently.
  if (kit && kit->axis.shorthand() != design.axis.shorthand())
    throw InputError(option_name("--kit"), "axis",
                     "the kit and the design give axis " + design.axis.label() +
                         " in different forms (" +
                         (kit->axis.shorthand().empty() ? "general" : "shorthand") + " and " +
                         (design.axis.shorthand().empty() ? "general" : "shorthand") +
                         "): write both as the shorthand or both in the general form");
}

}  // namespace

SetupOrder setup_order(const Design& design, std::optional<int> stack_coordinate) {
  const std::vector<Installation>& ins = design.installations;
  // The ball positions, in the order they first appear, and the bar classes at each.
  std::vector<std::vector<int>> members;
  for (int i = 0; i < static_cast<int>(ins.size()); ++i) {
    auto it = std::find_if(members.begin(), members.end(), [&](const std::vector<int>& g) {
      return same_ball_position(ins[g.front()], ins[i]);
    });
    if (it == members.end())
      members.push_back({i});
    else
      it->push_back(i);
  }
  std::vector<Group> groups;
  for (const std::vector<int>& m : members) {
    std::vector<std::vector<int>> classes;
    for (int i : m) {
      auto it = std::find_if(classes.begin(), classes.end(), [&](const std::vector<int>& c) {
        return same_bar(ins[c.front()], ins[i]);
      });
      if (it == classes.end())
        classes.push_back({i});
      else
        it->push_back(i);
    }
    std::stable_sort(classes.begin(), classes.end(),
                     [&](const std::vector<int>& a, const std::vector<int>& b) {
                       return bar_length(ins[a.front()]) < bar_length(ins[b.front()]);
                     });
    Group g;
    const int k = static_cast<int>(classes.size());
    for (int f = 0; f < k; ++f) {
      for (int l = 0; l < k; ++l) {
        if (k > 1 && f == l) continue;
        if (k == 1 && l != f) continue;
        g.ways.emplace_back(f, l);
      }
    }
    g.classes = std::move(classes);
    groups.push_back(std::move(g));
  }
  const int n = static_cast<int>(groups.size());
  size_t ways = 1;
  for (const Group& g : groups) ways = std::max(ways, g.ways.size());
  auto join = [&](int g, int gw, int h, int hw) -> long {
    const Installation &a = ins[groups[g].last(gw)], &b = ins[groups[h].first(hw)];
    return kStackWeight * !same_stack(design.axis, a, b, stack_coordinate) + !same_bar(a, b);
  };
  std::vector<std::pair<int, int>> path;  // (group, way)
  SetupOrder out;
  if (n <= kMaxExactPositions && (size_t{1} << n) * n * ways <= kMaxExactStates) {
    // best[mask][g][w]: the least cost of setting up the positions in mask, ending at g set up
    // the way w; from[...] the state before.
    const size_t W = ways;
    const size_t states = (size_t{1} << n) * n * W;
    std::vector<long> best(states, std::numeric_limits<long>::max());
    std::vector<long> from(states, -1);
    auto at = [&](size_t mask, int g, size_t w) { return (mask * n + g) * W + w; };
    for (int g = 0; g < n; ++g)
      for (size_t w = 0; w < groups[g].ways.size(); ++w) best[at(size_t{1} << g, g, w)] = 0;
    for (size_t mask = 1; mask < (size_t{1} << n); ++mask) {
      for (int g = 0; g < n; ++g) {
        if (!(mask & (size_t{1} << g))) continue;
        for (size_t w = 0; w < groups[g].ways.size(); ++w) {
          const long c = best[at(mask, g, w)];
          if (c == std::numeric_limits<long>::max()) continue;
          for (int h = 0; h < n; ++h) {
            if (mask & (size_t{1} << h)) continue;
            for (size_t v = 0; v < groups[h].ways.size(); ++v) {
              const size_t next = at(mask | (size_t{1} << h), h, v);
              const long cost = c + join(g, static_cast<int>(w), h, static_cast<int>(v));
              if (cost < best[next]) {  // strict: among equal orders the first found stays
                best[next] = cost;
                from[next] = static_cast<long>(at(mask, g, w));
              }
            }
          }
        }
      }
    }
    const size_t full = (size_t{1} << n) - 1;
    size_t end = at(full, 0, 0);
    for (int g = 0; g < n; ++g)
      for (size_t w = 0; w < groups[g].ways.size(); ++w)
        if (best[at(full, g, w)] < best[end]) end = at(full, g, w);
    for (long st = static_cast<long>(end); st >= 0; st = from[st]) {
      const int w = static_cast<int>(st % static_cast<long>(W));
      const int g = static_cast<int>((st / static_cast<long>(W)) % n);
      path.emplace_back(g, w);
    }
    std::reverse(path.begin(), path.end());
  } else {
    out.exhaustive = false;
    std::vector<bool> used(n, false);
    path.emplace_back(0, 0);
    used[0] = true;
    for (int k = 1; k < n; ++k) {
      std::pair<int, int> next{-1, 0};
      long least = std::numeric_limits<long>::max();
      for (int h = 0; h < n; ++h) {
        if (used[h]) continue;
        for (size_t v = 0; v < groups[h].ways.size(); ++v) {
          const long c = join(path.back().first, path.back().second, h, static_cast<int>(v));
          if (c < least) least = c, next = {h, static_cast<int>(v)};
        }
      }
      used[next.first] = true;
      path.push_back(next);
    }
  }
  std::vector<int> order, given(ins.size());
  for (const auto& [g, w] : path) groups[g].append_order(w, order);
  for (size_t i = 0; i < ins.size(); ++i) given[i] = static_cast<int>(i);
  const std::vector<SetupStep> found = steps_along(design, order, stack_coordinate),
                               designed = steps_along(design, given, stack_coordinate);
  std::tie(out.design_stack_changes, out.design_bar_changes, out.design_cup_moves) =
      changes(designed);
  // The design's own order stays where no order changes less (stack, then bar, then cup).
  out.steps = changes(designed) <= changes(found) ? designed : found;
  std::tie(out.stack_changes, out.bar_changes, out.cup_moves) = changes(out.steps);
  return out;
}

std::vector<int> run_rank(const Design& design) {
  std::vector<int> rank(design.installations.size(), 0);
  const SetupOrder order = setup_order(design);
  for (std::size_t k = 0; k < order.steps.size(); ++k)
    rank[static_cast<std::size_t>(order.steps[k].installation)] = static_cast<int>(k);
  return rank;
}

std::vector<double> run_starts(const Design& design, const std::vector<double>& duration_s) {
  const std::vector<int> rank = run_rank(design);
  const std::size_t n = rank.size();
  std::vector<double> start(n, 0.0);
  const bool equal = std::all_of(duration_s.begin(), duration_s.end(),
                                 [&](double d) { return d == duration_s.front(); });
  if (equal) {
    for (std::size_t k = 0; k < n; ++k) start[k] = static_cast<double>(rank[k]) * duration_s[k];
    return start;
  }
  std::vector<std::size_t> by_rank(n);
  for (std::size_t k = 0; k < n; ++k) by_rank[static_cast<std::size_t>(rank[k])] = k;
  double t = 0;
  for (const std::size_t k : by_rank) start[k] = t, t += duration_s[k];
  return start;
}

RoundedDesign round_design(const Design& design, double r, const Kit* kit) {
  if (!(std::isfinite(r) && r >= 1e-3 && r <= 10))
    throw InputError(option_name("--resolution-mm"), "",
                     "must be in [0.001, 10] mm, got " + text::significant(r, 6));
  if (!design.reference_length_mm)
    throw InputError("design", "reference_length_mm",
                     "needed to state the worst case of the rounded design");
  check_kit_axis(kit, design);
  RoundedDesign out;
  out.resolution_mm = r;
  out.design = design;
  auto round = [&](double x) { return std::round(x / r) * r; };
  // A table kit's coordinate along the table's normal (H, or a trunnion's L) is set by a cup
  // and its blocks where the ball stands on a stack of the kit: as exact as they are.
  const int hc = kit ? height_coordinate(*kit) : -1;
  const std::vector<Stack> stacks = hc >= 0 ? block_stacks(*kit) : std::vector<Stack>{};
  for (Installation& in : out.design.installations) {
    const bool on_stack =
        hc >= 0 && stack_of_height(stacks, height_above_table(*kit, in)).has_value();
    const double L = on_stack && hc == 0 ? in.L_mm : round(in.L_mm), D = round(in.D_mm);
    // H is set by the cup and its blocks when they are given: it is as exact as they are.
    const double H =
        in.cup_mm || !design.axis.has_H() || (on_stack && hc == 2) ? in.H_mm : round(in.H_mm);
    out.largest_shift_mm = std::max({out.largest_shift_mm, std::abs(L - in.L_mm),
                                     std::abs(D - in.D_mm), std::abs(H - in.H_mm)});
    in.L_mm = L, in.D_mm = D, in.H_mm = H;
  }
  validate_design(out.design);
  const WorstCase before = design_worst_case(design, *design.reference_length_mm);
  const WorstCase after = design_worst_case(out.design, *design.reference_length_mm);
  out.worst_std_um = before.worst_std_um;
  out.rounded_worst_std_um = after.worst_std_um;
  if (design.setup_nuisance_declared()) {
    out.worst_total_std_um =
        design_worst_total(design, *design.reference_length_mm).total.worst_std_um;
    out.rounded_worst_total_std_um =
        design_worst_total(out.design, *design.reference_length_mm).total.worst_std_um;
  }
  if (kit) {
    out.travel_checked = true;
    for (std::size_t i = 0; i < out.design.installations.size(); ++i) {
      const Installation& in = out.design.installations[i];
      const double v =
          travel_violation_mm(*kit, design.axis, in, out.design.angles_of(static_cast<int>(i)));
      if (v > kAssemblyTolerance_mm) out.outside_travel.emplace_back(in.id, v);
    }
  }
  return out;
}

SetupSheet make_setup_sheet(const Design& design, const ProgramOptions& program,
                            std::optional<double> resolution_mm, const Kit* kit) {
  require_ballbar(design, "design", "a set-up sheet");
  SetupSheet sheet;
  sheet.design = design;
  check_kit_axis(kit, design);
  if (resolution_mm) {
    sheet.rounding = round_design(design, *resolution_mm, kit);
    sheet.design = sheet.rounding->design;
  }
  if (kit) {
    sheet.travel_checked = true;
    for (const auto& [from, to] : {std::pair{&design, &sheet.outside_travel_as_given},
                                   {&sheet.design, &sheet.outside_travel}}) {
      for (std::size_t i = 0; i < from->installations.size(); ++i) {
        const Installation& in = from->installations[i];
        const double v =
            travel_violation_mm(*kit, design.axis, in, from->angles_of(static_cast<int>(i)));
        if (v > kAssemblyTolerance_mm) to->emplace_back(in.id, v);
      }
    }
  }
  if (kit) {
    sheet.workspace_checks = workspace_checks(*kit);
    sheet.workspace_stated = kit->workspace.has_value();
    for (std::size_t i = 0; i < sheet.design.installations.size(); ++i) {
      const Installation& in = sheet.design.installations[i];
      for (const Clash& c :
           installation_clashes(*kit, design.axis, in, sheet.design.angles_of(static_cast<int>(i)),
                                kAssemblyTolerance_mm))
        sheet.clashes.emplace_back(in.id, c);
    }
  }
  if (kit && kit->axis.table() && kit->axis.shorthand().empty()) {
    const std::vector<Stack> stacks = block_stacks(*kit);
    sheet.kit_table =
        SetupSheet::KitTable{kit->table_normal, kit->table_surface_mm, table_carriage(*kit)};
    for (const Installation& in : sheet.design.installations) {
      const double height = height_above_table(*kit, in);
      sheet.kit_stacks.push_back(stack_of_height(stacks, height));
      if (sheet.kit_stacks.back() || stacks.empty()) continue;
      double off = std::numeric_limits<double>::infinity();
      for (const Stack& st : stacks) off = std::min(off, std::abs(st.height_mm - height));
      sheet.clashes.emplace_back(
          in.id, Clash{"no stack of the kit's cup and blocks builds the ball's height above the "
                       "table (" +
                           text::rounded(height, 3) + " mm); the nearest misses it",
                       off});
    }
  }
  ProgramOptions options = program;
  if (kit && kit->axis.table()) options.stack_coordinate = height_coordinate(*kit);
  sheet.order = setup_order(sheet.design, options.stack_coordinate);
  sheet.program = measurement_program(sheet.design, options);
  sheet.total_time_s = sheet.program.motion_time_s;
  if (kit) {
    const int sweeps = program.sweeps == ProgramOptions::Sweeps::kBoth ? 2 : 1;
    sheet.time = design_time(*kit, sheet.design, sweeps);
    for (const SetupStep& s : sheet.order.steps) {
      const double per_sweep =
          static_cast<double>(sheet.design.readings_per_sweep(s.installation)) * sweeps *
          kit->time_per_reading_s;
      const double t =
          (s.moves_cup ? kit->time_per_position_s : 0.0) + kit->time_per_installation_s;
      sheet.setup_time_s.push_back(t);
      sheet.step_time_s.push_back(t + per_sweep);
    }
    sheet.total_time_s = sheet.time->total_s;
    if (design.axis.table())
      sheet.clearance_above_travel_mm = sheet.program.clearance_z_mm - kit->travel_mm[2].max;
  }
  return sheet;
}

}  // namespace dbbkit
