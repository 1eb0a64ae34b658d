#include "dbbkit/kit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include "dbbkit/axis_frame.hpp"
#include "dbbkit/error.hpp"
#include "dbbkit/instrument.hpp"
#include "dbbkit/kinematics.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/user_text.hpp"
#include "number_text.hpp"
#include "tolerances.hpp"

namespace dbbkit {

namespace {

void require(bool ok, const std::string& source, const std::string& key, const std::string& what) {
  if (!ok) throw InputError(source, key, what);
}

bool finite(double x) { return std::isfinite(x); }

// Largest number of blocks (their subsets are enumerated) and of angles per step.
constexpr size_t kMaxBlocks = 16;
constexpr double kMaxAngles = 100000;
constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;

// The extent of a + b cos(g) + c sin(g) over the arc [lo, hi] (degrees):
// the end points and the stationary points inside the arc.
// (sin, cos) of the arc's two ends, found once for its three coordinates.
struct ArcEnds {
  double lo_deg, hi_deg, s_lo, c_lo, s_hi, c_hi;
  bool full;  // a whole turn or more: every angle is on the arc
  ArcEnds(double lo, double hi) : lo_deg(lo), hi_deg(hi), full(hi - lo >= 360.0) {
    sincos_deg(lo, s_lo, c_lo);
    sincos_deg(hi, s_hi, c_hi);
  }
};

std::pair<double, double> arc_extent(double a, double b, double c, const ArcEnds& ends) {
  const double lo_deg = ends.lo_deg, hi_deg = ends.hi_deg;
  double v0 = a + b * ends.c_lo + c * ends.s_lo;
  const double v1 = a + b * ends.c_hi + c * ends.s_hi;
  double mn = std::min(v0, v1), mx = std::max(v0, v1);
  const double amp = std::hypot(b, c);
  if (amp > 0 && ends.full) {
    mx = std::max(mx, a + amp);
    mn = std::min(mn, a - amp);
  } else if (amp > 0) {
    const double g_max = std::atan2(c, b) * kDegPerRad;  // where the value is a + amp
    for (const double g : {g_max, g_max + 180.0}) {
      // Is g (modulo 360) inside [lo, hi]?
      const double k = std::ceil((lo_deg - g) / 360.0);
      if (g + 360.0 * k <= hi_deg) {
        if (g == g_max) {
          mx = std::max(mx, a + amp);
        } else {
          mn = std::min(mn, a - amp);
        }
      }
    }
  }
  return {mn, mx};
}

// The arc the angles span (absent without angles).
std::optional<ArcEnds> arc_of(const std::vector<double>& angles_deg) {
  if (angles_deg.empty()) return std::nullopt;
  const auto [lo_it, hi_it] = std::minmax_element(angles_deg.begin(), angles_deg.end());
  return ArcEnds(*lo_it, *hi_it);
}

// The travel violation of the point G turned over the arc (travel_violation_mm: the following
// ball's path), each coordinate k reaching below[k] lower and above[k] higher than the point (a
// probe's approach about a sphere's centre; zero for a ball).
double arc_travel_violation(const Kit& kit, const RotationHarmonics& h, const Eigen::Vector3d& G,
                            const ArcEnds& ends,
                            const Eigen::Vector3d& below = Eigen::Vector3d::Zero(),
                            const Eigen::Vector3d& above = Eigen::Vector3d::Zero()) {
  const Eigen::Vector3d a = h.A0 * G, b = h.A1 * G, c = h.A2 * G;
  double worst = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    const auto [mn, mx] = arc_extent(a(k), b(k), c(k), ends);
    worst = std::max(
        {worst, kit.travel_mm[k].min - (mn - below(k)), (mx + above(k)) - kit.travel_mm[k].max});
  }
  return worst;
}

// How far a circle of diameter footprint_mm about the table point P (x, y at angle 0) overhangs a
// "C" table's outline (<= 0: on the table): a cup and its blocks, a sphere's stand.
double footprint_overhang_mm(const Workspace& w, const Eigen::Vector3d& P) {
  const double f = w.footprint_mm / 2;
  if (w.table_diameter_mm) return std::hypot(P.x(), P.y()) + f - *w.table_diameter_mm / 2;
  return std::max({w.table_x_mm->min - (P.x() - f), (P.x() + f) - w.table_x_mm->max,
                   w.table_y_mm->min - (P.y() - f), (P.y() + f) - w.table_y_mm->max});
}

}  // namespace

std::optional<Pattern> builtin_pattern(const std::string& name, const AxisFrame& axis,
                                       TableCarriage carriage, InstrumentKind instrument) {
  auto var = [](const char* v) { return PatternCoordinate{v, 0}; };
  Pattern p;
  p.name = name;
  p.builtin = true;
  if (instrument == InstrumentKind::kProbe) {
    if (name != "spheres" || !axis.table()) return std::nullopt;
    // Spheres s1, s2, s3, each at its own place and height (three off one line determine every
    // error at every angle; one determines the location errors); s2 and s3 optional.
    const bool across = carriage == TableCarriage::kAcrossAxis;
    const char* names[3][3] = {{"L1", "D1", "H1"}, {"L2", "D2", "H2"}, {"L3", "D3", "H3"}};
    const char* trunnion[3][3] = {{"H1", "D1", "S1"}, {"H2", "D2", "S2"}, {"H3", "D3", "S3"}};
    for (int i = 0; i < 3; ++i) {
      const auto& n = across ? trunnion[i] : names[i];
      PatternPosition s;
      s.id = "s" + std::to_string(i + 1);
      s.L = var(n[0]);
      s.D = var(n[1]);
      s.H = var(n[2]);
      s.optional = i > 0;
      p.positions.push_back(s);
    }
    p.interchangeable = true;
    return p;
  }
  if (name != "three_position") return std::nullopt;
  using K = Direction::Kind;
  const PatternCoordinate zero{};
  if (axis.table() && carriage == TableCarriage::kAcrossAxis) {
    // A trunnion: the blocks set the balls' distance from the axis line (L, heights H1 and
    // H3), the cup slides across the table (D) and along the axis (S). Balls at (H1, D1, S1)
    // read radially, tangentially and axially, (H1, D2, S2) and (H3, D3, S2) radially and
    // tangentially: two share a plane across the axis, the first lies apart along it (on a
    // small kit the search over S3 free finds nothing better); H1 != H3.
    p.positions = {
        {"1",
         var("H1"),
         var("D1"),
         var("S1"),
         {K::kRadial, K::kTangential, K::kAxial},
         true,
         false,
         false},
        {"2", var("H1"), var("D2"), var("S2"), {K::kRadial, K::kTangential}, true, false, false},
        {"3", var("H3"), var("D3"), var("S2"), {K::kRadial, K::kTangential}, true, false, false},
    };
    p.distinct = {{"H1", "H3"}};
  } else if (axis.table()) {
    // Balls at (L1, D1, H1), (L2, D2, H1), (L3, D3, H3) read radially and tangentially, the
    // axial reading on the axis at H1; H1 != H3.
    p.positions = {
        {"1", var("L1"), var("D1"), var("H1"), {K::kRadial, K::kTangential}, true, false, false},
        {"1", zero, zero, var("H1"), {K::kAxial}, false, false, false},
        {"2", var("L2"), var("D2"), var("H1"), {K::kRadial, K::kTangential}, true, false, false},
        {"3", var("L3"), var("D3"), var("H3"), {K::kRadial, K::kTangential}, true, false, false},
    };
    p.distinct = {{"H1", "H3"}};
  } else {
    // Balls at L1 and L2 on the tool axis read in all three directions; where the kit allows,
    // a third at L3 off the axis, radial and tangential (without it, rank 5 at every angle):
    // offset along the axis, the "B" shorthand's D, the general form's H.
    const bool general = axis.has_H();
    p.positions = {
        {"1", var("L1"), zero, zero, {K::kRadial, K::kTangential, K::kAxial}, true, false, false},
        {"2", var("L2"), zero, zero, {K::kRadial, K::kTangential, K::kAxial}, true, false, false},
        {"3",
         var("L3"),
         general ? zero : var("D3"),
         general ? var("S3") : zero,
         {K::kRadial, K::kTangential},
         true,
         true,
         true},
    };
  }
  return p;
}

TableCarriage table_carriage(const Kit& kit) {
  if (kit.axis.head()) return TableCarriage::kAlongAxis;
  return std::abs(kit.table_normal.dot(kit.axis.direction())) > 0.5 ? TableCarriage::kAlongAxis
                                                                    : TableCarriage::kAcrossAxis;
}

std::string reference_length_basis_text(const Kit& kit) {
  switch (kit.reference_length_basis) {
    case Kit::ReferenceLengthBasis::kTableRadius:
      return std::string("the table's radius (") +
             (kit.machine ? "its disc in the machine file" : "workspace.table.diameter_mm / 2") +
             "), the kit stating no reference_length_mm";
    case Kit::ReferenceLengthBasis::kTableCorner:
      return "the table's farthest corner from the axis (workspace.table), the kit stating no "
             "reference_length_mm";
    case Kit::ReferenceLengthBasis::kToolReach:
      return "the farthest ball position along the tool (L_mm.max), the kit stating no "
             "reference_length_mm";
    case Kit::ReferenceLengthBasis::kStated:
      break;
  }
  return "the kit's reference_length_mm";
}

int height_coordinate(const Kit& kit) {
  if (kit.axis.head()) return -1;
  return table_carriage(kit) == TableCarriage::kAlongAxis ? 2 : 0;
}

const PatternCoordinate& coordinate_of(const PatternPosition& position, int coordinate) {
  return coordinate == 0 ? position.L : coordinate == 1 ? position.D : position.H;
}

const PatternCoordinate& height_of(const Kit& kit, const PatternPosition& position) {
  return coordinate_of(position, std::max(0, height_coordinate(kit)));
}

namespace {
// The sign of the table's normal along the frame's direction of its height coordinate.
double height_sign(const Kit& kit) {
  const int c = height_coordinate(kit);
  const Eigen::Vector3d& e = c == 0 ? kit.axis.e_L() : kit.axis.e_H();
  return kit.table_normal.dot(e) < 0 ? -1.0 : 1.0;
}
}  // namespace

double height_to_coordinate(const Kit& kit, double height_mm) {
  return height_sign(kit) * (kit.table_surface_mm + height_mm);
}

bool stack_is_H(const Kit& kit) { return kit.axis.shorthand() == "C"; }

double height_above_table(const Kit& kit, const Installation& in) {
  const double coordinate = height_coordinate(kit) == 0 ? in.L_mm : in.H_mm;
  return height_sign(kit) * coordinate - kit.table_surface_mm;
}

std::optional<Stack> stack_of_height(const std::vector<Stack>& stacks, double height_mm) {
  for (const Stack& st : stacks)
    if (std::abs(st.height_mm - height_mm) <= kAssemblyTolerance_mm) return st;
  return std::nullopt;
}

std::optional<Stack> stack_at(const Kit& kit, const Installation& in) {
  if (height_coordinate(kit) < 0) return std::nullopt;
  return stack_of_height(block_stacks(kit), height_above_table(kit, in));
}

Interval coordinate_range(const Kit& kit, int coordinate) {
  if (coordinate == height_coordinate(kit)) return {};
  return coordinate == 0 ? kit.L_mm : coordinate == 1 ? kit.D_mm : kit.axial_mm;
}

std::string installation_id(const PatternPosition& position, Direction::Kind kind) {
  switch (kind) {
    case Direction::Kind::kRadial:
      return position.id + "r";
    case Direction::Kind::kTangential:
      return position.id + "t";
    case Direction::Kind::kAxial:
      return position.id + "a";
    case Direction::Kind::kVector:
      break;
  }
  return position.id + "v";
}

bool allows_offset(const Kit& kit) {
  return kit.D_mm.min < 0 || kit.D_mm.max > 0 || kit.axial_mm.min < 0 || kit.axial_mm.max > 0;
}

std::vector<int> offered_optional_positions(const Kit& kit) {
  const bool offset = allows_offset(kit);
  std::vector<int> out;
  for (int i = 0; i < static_cast<int>(kit.pattern.positions.size()); ++i) {
    const PatternPosition& p = kit.pattern.positions[i];
    if (p.optional && (offset || !p.needs_offset)) out.push_back(i);
  }
  return out;
}

int max_installations(const Kit& kit) {
  int n = 0;
  for (const PatternPosition& p : kit.pattern.positions)
    n += kit.instrument == InstrumentKind::kProbe ? 3 : static_cast<int>(p.directions.size());
  return n;
}

namespace {

// The most optional positions, variables and discrete choices a pattern may have: the
// search's work grows with each.
constexpr size_t kMaxPositions = 16;
constexpr size_t kMaxHeightVariables = 4;
constexpr double kMaxChoices = 20000;

void validate_pattern(const Kit& k, const std::string& source) {
  const Pattern& p = k.pattern;
  require(!p.positions.empty(), source, "pattern.positions", "no positions");
  require(p.positions.size() <= kMaxPositions, source, "pattern.positions",
          "more than 16 positions");
  std::map<std::string, char> role;  // variable -> 'L', 'D' or 'H'
  // The coordinate a table's heights lie along (its variables are discrete); none on a head.
  const int hc = height_coordinate(k);
  const char height_letter = hc < 0 ? '\0' : "LDH"[hc];
  std::vector<std::string> ids;
  std::vector<std::string> heights;
  bool any_required = false;
  for (size_t i = 0; i < p.positions.size(); ++i) {
    const PatternPosition& pos = p.positions[i];
    const int own = static_cast<int>(i) - p.inherited_positions;  // index in the file's list
    const std::string key =
        own >= 0 ? "pattern.positions[" + std::to_string(own) + "]" : "pattern.extends";
    any_required = any_required || !pos.optional;
    require(!pos.id.empty(), source, key + ".id", "is empty");
    // The position's id plus its direction's letter is an installation id (user_text.hpp).
    if (k.instrument != InstrumentKind::kProbe && pos.id.size() + 1 > limits::kMaxIdBytes) {
      throw InputError(source, key + ".id",
                       quote_value(pos.id) + ": at most " +
                           std::to_string(limits::kMaxIdBytes - 1) +
                           " bytes (with its direction's letter, an installation id of at most " +
                           std::to_string(limits::kMaxIdBytes) + ")");
    }
    if (k.instrument == InstrumentKind::kProbe) {
      // A position is a sphere: its id is the sphere's, its channels x, y, z.
      if (const auto problem = sphere_id_problem(pos.id))
        throw InputError(source, key + ".id", quote_value(pos.id) + ": " + *problem);
      require(std::find(ids.begin(), ids.end(), pos.id) == ids.end(), source, key + ".id",
              "sphere " + quote_value(pos.id) + " appears twice in the pattern");
      ids.push_back(pos.id);
    } else if (const auto problem = id_problem(pos.id + "r")) {
      throw InputError(source, key + ".id", quote_value(pos.id) + ": " + *problem);
    }
    require(k.instrument == InstrumentKind::kProbe || !pos.directions.empty(), source,
            key + ".directions", "no directions");
    for (Direction::Kind d : pos.directions) {
      require(d != Direction::Kind::kVector, source, key + ".directions",
              "must be radial, tangential or axial");
      const std::string id = installation_id(pos, d);
      require(std::find(ids.begin(), ids.end(), id) == ids.end(), source, key + ".directions",
              "installation '" + id + "' appears twice in the pattern");
      ids.push_back(id);
    }
    const std::pair<const PatternCoordinate*, char> coords[] = {
        {&pos.L, 'L'}, {&pos.D, 'D'}, {&pos.H, 'H'}};
    for (const auto& [c, name] : coords) {
      const std::string ckey = key + "." + std::string(1, name);
      if (!c->is_variable()) {
        require(length_within_limits(c->value), source, ckey,
                "must be a length in mm within +-10000 mm");
        continue;
      }
      auto [it, fresh] = role.emplace(c->variable, name);
      require(it->second == name, source, ckey,
              "variable '" + c->variable + "' is used as " + std::string(1, it->second) +
                  " and as " + std::string(1, name));
      if (name == height_letter && fresh) heights.push_back(c->variable);
    }
    if (!k.axis.has_H()) {
      require(!pos.H.is_variable() && pos.H.value == 0, source, key + ".H",
              "H is not used for the swinging head B (ball at (L sin b, D, L cos b))");
    }
  }
  require(any_required, source, "pattern.positions",
          "every position is optional: at least one must be required");
  require(heights.size() <= kMaxHeightVariables, source, "pattern.positions",
          "more than 4 height variables");
  const size_t n_stacks = k.axis.table() ? block_stacks(k).size() : 0;
  for (size_t g = 0; g < p.distinct.size(); ++g) {
    const std::string key = "pattern.distinct[" + std::to_string(g) + "]";
    for (const std::string& v : p.distinct[g]) {
      const auto it = role.find(v);
      require(it != role.end() && height_letter && it->second == height_letter, source, key,
              "'" + v + "' is not a height variable of the pattern");
    }
    require(n_stacks >= p.distinct[g].size(), source, p.builtin ? "H_mm" : key,
            "needs " + std::to_string(p.distinct[g].size()) +
                " different heights, the blocks give " + std::to_string(n_stacks) +
                (p.builtin ? " (the three_position pattern needs two heights, H3 != H1: "
                             "at least one block and max_stack >= 1)"
                           : ""));
  }
  const double choices = static_cast<double>(k.angle_steps_deg.size()) *
                         std::pow(static_cast<double>(std::max<size_t>(n_stacks, 1)),
                                  static_cast<double>(heights.size())) *
                         static_cast<double>(offered_optional_positions(k).size() + 1);
  require(choices <= kMaxChoices, source, "pattern",
          "gives more than 20000 discrete choices (angle steps x heights^height variables x "
          "optional positions)");
}

}  // namespace

std::optional<std::string> probe_kit_axis_problem(const AxisFrame& axis) {
  if (axis.table()) return std::nullopt;
  return "a probe kit places spheres on a table: axis " + axis.label() +
         " carries the head (write a head's probe design by hand, docs/formats.md)";
}

void validate_kit(const Kit& k, const std::string& source) {
  // The kit's name names the designs optimize writes (user_text.hpp).
  if (const auto p = text_problem(k.name, limits::kMaxKitNameBytes))
    throw InputError(source, "name", quote_value(k.name) + ": " + *p);
  validate_noise_and_model(k.noise, k.errors, k.axis, source);
  require(finite(k.reference_length_mm) && k.reference_length_mm > 0, source, "reference_length_mm",
          "must be a positive length in mm (it converts angular uncertainty to um)");

  require(finite(k.reference_length_mm) && k.reference_length_mm <= limits::kMaxLength_mm, source,
          "reference_length_mm", "must be at most 10000 mm");
  require(length_within_limits(k.L_mm.min) && length_within_limits(k.L_mm.max), source, "L_mm",
          "min and max must be finite numbers of mm within +-10000 mm");
  require(k.L_mm.min >= 0, source, "L_mm.min", "must be >= 0 mm");
  require(k.L_mm.min <= k.L_mm.max, source, "L_mm", "min is larger than max");
  require(length_within_limits(k.D_mm.min) && length_within_limits(k.D_mm.max), source, "D_mm",
          "min and max must be finite numbers of mm within +-10000 mm");
  require(k.D_mm.min <= k.D_mm.max, source, "D_mm", "min is larger than max");
  require(length_within_limits(k.axial_mm.min) && length_within_limits(k.axial_mm.max), source,
          "axial_mm", "min and max must be finite numbers of mm within +-10000 mm");
  require(k.axial_mm.min <= k.axial_mm.max, source, "axial_mm", "min is larger than max");
  if (k.axis.head()) {
    require(k.D_mm.contains(0.0), source, "D_mm",
            "the head's pattern puts two balls on the tool axis (D = 0): the range must "
            "include 0");
    require(k.axial_mm.contains(0.0), source, "axial_mm",
            "the head's pattern puts two balls on the tool axis (H = 0): the range must "
            "include 0");
  }
  if (k.axis.table()) {
    require(std::abs(k.table_normal.norm() - 1) <= kFrameTolerance, source, "table.normal",
            "must be a unit vector");
    const double along = std::abs(k.table_normal.dot(k.axis.direction())),
                 across = std::abs(k.table_normal.dot(k.axis.reference()));
    require(std::abs(along - 1) <= kFrameTolerance || std::abs(across - 1) <= kFrameTolerance,
            source, "table.normal",
            "lies neither along the axis' direction (a C table, a machining centre's B table) "
            "nor along its reference (a trunnion): write the frame's reference along the "
            "table's normal at angle 0");
    require(length_within_limits(k.table_surface_mm), source, "table.surface_mm",
            "must be a length in mm within +-10000 mm");
  }

  if (k.axis.table()) {
    require(length_within_limits(k.H_base_mm) && k.H_base_mm >= 0, source, "H_mm.base",
            "must be a height in [0, 10000] mm");
    require(k.blocks_mm.size() <= kMaxBlocks, source, "H_mm.blocks", "more than 16 blocks");
    for (size_t i = 0; i < k.blocks_mm.size(); ++i) {
      require(length_within_limits(k.blocks_mm[i]) && k.blocks_mm[i] > 0, source,
              "H_mm.blocks[" + std::to_string(i) + "]", "must be a positive height in mm");
    }
    require(k.max_stack >= 0, source, "H_mm.max_stack", "must be an integer >= 0");
  }
  if (k.bar_set) {
    const BarSet& b = *k.bar_set;
    require(length_within_limits(b.base_mm) && b.base_mm > 0, source, "bars.base_mm",
            "must be a positive length in mm, at most 10000 mm");
    require(static_cast<int>(b.extensions_mm.size()) <= kMaxBarExtensions, source,
            "bars.extensions_mm", "more than " + std::to_string(kMaxBarExtensions) + " extensions");
    if (b.max_extensions) {
      require(*b.max_extensions >= 0, source, "bars.max_extensions", "must be an integer >= 0");
    }
    for (size_t i = 0; i < b.extensions_mm.size(); ++i) {
      require(length_within_limits(b.extensions_mm[i]) && b.extensions_mm[i] > 0, source,
              "bars.extensions_mm[" + std::to_string(i) + "]",
              "must be a positive length in mm, at most 10000 mm");
    }
  }
  require(k.instrument == InstrumentKind::kProbe || !k.bars_mm.empty(), source, "bars_mm",
          "no bars");
  if (k.instrument == InstrumentKind::kProbe) {
    if (const auto p = probe_kit_axis_problem(k.axis))
      throw InputError(source, "instrument.kind", *p);
    require(finite(k.probe.approach_mm) && k.probe.approach_mm > 0 &&
                k.probe.approach_mm <= limits::kMaxLength_mm,
            source, "instrument.approach_mm",
            "must be a positive distance in mm (the tip's centre from the sphere's centre where "
            "a touch starts), at most 10000 mm");
    require(k.min_separation_mm > 0, source, "min_separation_mm",
            "a probe kit states how far apart two spheres' stands stand on the table (at least "
            "their footprint), above 0 mm");
    if (k.probe.max_stem_tilt_deg)
      require(finite(*k.probe.max_stem_tilt_deg) && *k.probe.max_stem_tilt_deg > 0 &&
                  *k.probe.max_stem_tilt_deg <= 180,
              source, "instrument.max_stem_tilt_deg", "must be an angle in (0, 180] deg");
  }
  for (size_t i = 0; i < k.bars_mm.size(); ++i) {
    require(length_within_limits(k.bars_mm[i]) && k.bars_mm[i] > 0, source,
            "bars_mm[" + std::to_string(i) + "]",
            "must be a positive length in mm, at most 10000 mm");
  }
  const char* xyz[] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    const Interval& t = k.travel_mm[i];
    require(length_within_limits(t.min) && length_within_limits(t.max) && t.min < t.max, source,
            std::string("travel_mm.") + xyz[i],
            "must be [min, max] with min < max, in mm, within +-10000 mm");
  }
  require(length_within_limits(k.min_separation_mm) && k.min_separation_mm >= 0, source,
          "min_separation_mm", "must be a distance in [0, 10000] mm");

  const Interval& r = k.angle_range_deg;
  require(finite(r.min) && finite(r.max) && r.min < r.max, source, "angles_deg.range",
          "must be [first, last] with first < last, in degrees");
  if (k.axis.full_turn()) {
    require(r.width() <= 360.0 + kAngleTolerance_deg, source, "angles_deg.range",
            "spans more than one turn");
  } else {
    require(r.min >= k.axis.travel_min_deg() && r.max <= k.axis.travel_max_deg(), source,
            "angles_deg.range",
            "is outside [" + text::significant(k.axis.travel_min_deg(), 12) + ", " +
                text::significant(k.axis.travel_max_deg(), 12) + "] deg, the travel of axis " +
                k.axis.label());
  }
  require(!k.angle_steps_deg.empty(), source, "angles_deg.steps", "no angle steps");
  if (k.angle_max_step_deg) {
    const double m = *k.angle_max_step_deg;
    require(finite(m) && m > 0, source, "angles_deg.max_step",
            "must be a positive step in degrees");
    require(std::any_of(k.angle_steps_deg.begin(), k.angle_steps_deg.end(),
                        [&](double st) { return st <= m + kAngleTolerance_deg; }),
            source, "angles_deg.max_step",
            "is finer than every step of angles_deg.steps: no step is at most " +
                text::significant(m, 12) + " deg");
  }
  for (size_t i = 0; i < k.angle_steps_deg.size(); ++i) {
    const std::string key = "angles_deg.steps[" + std::to_string(i) + "]";
    const double st = k.angle_steps_deg[i];
    require(finite(st) && st > 0, source, key, "must be a positive step in degrees");
    const double m = r.width() / st;
    require(m + 1 <= kMaxAngles, source, key, "gives more than 100000 angles");
    require(std::abs(m - std::round(m)) <= tol::kWholeSteps * std::max(1.0, m), source, key,
            "does not divide the range into a whole number of steps");
    for (size_t j = 0; j < i; ++j) {
      require(std::abs(k.angle_steps_deg[j] - st) > kAngleTolerance_deg, source, key,
              "repeats angles_deg.steps[" + std::to_string(j) + "]");
    }
    // Over an arc through 0 the designs measure the axis' zero (the reference position the
    // location errors and the other axes are set at).
    if (!k.axis.full_turn() && r.min < 0 && r.max > 0) {
      const double z = -r.min / st;
      require(std::abs(z - std::round(z)) <= tol::kWholeSteps * std::max(1.0, z), source, key,
              "steps of " + text::significant(st, 12) + " deg from " +
                  text::significant(r.min, 12) + " deg never reach " +
                  std::string(1, k.axis.letter()) +
                  " = 0, which the range includes: take a range or step that does");
    }
  }
  require(finite(k.time_per_reading_s) && k.time_per_reading_s >= 0, source, "time_s.per_reading",
          "must be a time >= 0 s");
  require(finite(k.time_per_installation_s) && k.time_per_installation_s >= 0, source,
          "time_s.per_installation", "must be a time >= 0 s");
  require(finite(k.time_per_position_s) && k.time_per_position_s >= 0, source,
          "time_s.per_position", "must be a time >= 0 s");
  if (k.resolution_mm) {
    require(finite(*k.resolution_mm) && *k.resolution_mm >= limits::kMinResolution_mm &&
                *k.resolution_mm <= limits::kMaxResolution_mm,
            source, "resolution_mm",
            "must be in [" + text::significant(limits::kMinResolution_mm, 6) + ", " +
                text::significant(limits::kMaxResolution_mm, 6) + "] mm");
  }
  if (k.time_budget_s) {
    require(finite(*k.time_budget_s) && *k.time_budget_s > 0, source, "time_s.budget",
            "must be a positive time in s");
  }
  if (k.workspace) {
    const Workspace& w = *k.workspace;
    auto length = [&](std::optional<double> v, const std::string& key, bool positive) {
      if (!v) return;
      require(length_within_limits(*v) && (positive ? *v > 0 : *v >= 0), source, "workspace." + key,
              positive ? "must be a positive length in mm, at most 10000 mm"
                       : "must be a length in [0, 10000] mm");
    };
    length(w.table_diameter_mm, "table.diameter_mm", true);
    for (const auto& [iv, key] :
         {std::pair{&w.table_x_mm, "table.x_mm"}, std::pair{&w.table_y_mm, "table.y_mm"}}) {
      if (*iv) {
        require(length_within_limits((*iv)->min) && length_within_limits((*iv)->max) &&
                    (*iv)->min < (*iv)->max,
                source, std::string("workspace.") + key,
                "must be [min, max] with min < max, in mm, within +-10000 mm");
      }
    }
    length(w.footprint_mm, "footprint_mm", false);
    length(w.table_ball_height_mm, "table_ball_height_mm", false);
    length(w.spindle_diameter_mm, "spindle.diameter_mm", false);
    length(w.ball_to_nose_mm, "spindle.ball_to_nose_mm", false);
    length(w.clearance_mm, "clearance_mm", false);
    if (w.table_diameter_mm) {
      require(w.footprint_mm < *w.table_diameter_mm, source, "workspace.footprint_mm",
              "is as wide as the table");
    }
  }
  validate_pattern(k, source);
  // On a table in the general form a height the pattern fixes must be one a stack of the kit
  // builds: its designs do not state their stacks, the set-up sheet finds them from the kit.
  // (The "C" shorthand's designs state H, and a height no stack builds is said as H.)
  if (k.axis.table() && k.axis.shorthand().empty()) {
    const std::vector<Stack> stacks = block_stacks(k);
    for (size_t i = 0; i < k.pattern.positions.size(); ++i) {
      const PatternCoordinate& h = height_of(k, k.pattern.positions[i]);
      if (h.is_variable()) continue;
      const int own = static_cast<int>(i) - k.pattern.inherited_positions;
      if (!stack_of_height(stacks, h.value) && own >= 0) {
        throw InputError(
            source, "pattern.positions[" + std::to_string(own) + "]." + "LDH"[height_coordinate(k)],
            "fixes a height of " + text::significant(h.value, 6) +
                " mm above the table, which no stack of the kit's cup and blocks "
                "(H_mm) builds");
      }
    }
  }
}

std::vector<Stack> block_stacks(const Kit& kit) {
  std::map<double, std::vector<double>> by_height;  // height -> fewest blocks
  const size_t nb = kit.blocks_mm.size();
  for (unsigned mask = 0; mask < (1u << nb); ++mask) {
    std::vector<double> used;
    double h = kit.H_base_mm;
    for (size_t i = 0; i < nb; ++i) {
      if (mask & (1u << i)) {
        used.push_back(kit.blocks_mm[i]);
        h += kit.blocks_mm[i];
      }
    }
    if (static_cast<int>(used.size()) > kit.max_stack) continue;
    // Heights closer than 1 um are the same height.
    const double key = std::round(h * 1000.0) / 1000.0;
    auto it = by_height.find(key);
    if (it == by_height.end() || used.size() < it->second.size()) by_height[key] = used;
  }
  std::vector<Stack> out;
  for (auto& [h, used] : by_height) out.push_back({h, used});
  return out;
}

std::vector<double> kit_angles(const Kit& kit, double step_deg) {
  const long m = std::lround(kit.angle_range_deg.width() / step_deg);
  std::vector<double> a;
  for (long i = 0; i <= m; ++i)
    a.push_back(i == m ? kit.angle_range_deg.max : kit.angle_range_deg.min + i * step_deg);
  return a;
}

std::vector<double> assembled_bars(const BarSet& set) {
  const int n = static_cast<int>(set.extensions_mm.size());
  std::vector<double> out;
  for (unsigned mask = 0; mask < (1u << n); ++mask) {
    if (set.max_extensions && __builtin_popcount(mask) > *set.max_extensions) continue;
    double L = set.base_mm;
    for (int k = 0; k < n; ++k)
      if (mask & (1u << k)) L += set.extensions_mm[k];
    out.push_back(L);
  }
  std::sort(out.begin(), out.end());
  out.erase(
      std::unique(out.begin(), out.end(),
                  [](double a, double b) { return std::abs(a - b) <= kAssemblyTolerance_mm; }),
      out.end());
  return out;
}

std::vector<double> bar_parts(const Kit& kit, double length_mm) {
  if (!kit.bar_set) {
    for (double b : kit.bars_mm)
      if (std::abs(b - length_mm) <= kAssemblyTolerance_mm) return {b};
    return {};
  }
  const BarSet& set = *kit.bar_set;
  const int n = static_cast<int>(set.extensions_mm.size());
  std::vector<double> best;
  for (unsigned mask = 0; mask < (1u << n); ++mask) {
    if (set.max_extensions && __builtin_popcount(mask) > *set.max_extensions) continue;
    std::vector<double> parts = {set.base_mm};
    double L = set.base_mm;
    for (int k = 0; k < n; ++k) {
      if (mask & (1u << k)) {
        parts.push_back(set.extensions_mm[k]);
        L += set.extensions_mm[k];
      }
    }
    if (std::abs(L - length_mm) <= kAssemblyTolerance_mm &&
        (best.empty() || parts.size() < best.size()))
      best = parts;
  }
  return best;
}

int ball_positions(const Design& design) {
  std::vector<Eigen::Vector3d> seen;
  for (const Installation& in : design.installations) {
    const Eigen::Vector3d p(in.L_mm, in.D_mm, in.H_mm);
    if (std::none_of(seen.begin(), seen.end(), [&](const Eigen::Vector3d& q) {
          return (p - q).cwiseAbs().maxCoeff() <= kAssemblyTolerance_mm;
        }))
      seen.push_back(p);
  }
  return static_cast<int>(seen.size());
}

TimeEstimate design_time(const Kit& kit, const Design& design, int sweeps) {
  TimeEstimate t;
  if (design.instrument == InstrumentKind::kProbe) {
    // A sphere set up is a position; one probing of a sphere gives its three channels.
    t.positions = static_cast<int>(design.spheres.size());
    t.readings = design.readings_per_round() / 3 * sweeps;
  } else {
    t.positions = ball_positions(design);
    t.installations = static_cast<int>(design.installations.size());
    t.readings = design.readings_per_round() * sweeps;
  }
  t.setups_s = (kit.time_per_position_s > 0 ? t.positions * kit.time_per_position_s : 0.0) +
               t.installations * kit.time_per_installation_s;
  t.readings_s = t.readings * kit.time_per_reading_s;
  t.total_s = t.setups_s + t.readings_s;
  return t;
}

double design_time_s(const Kit& kit, const Design& design) {
  return design_time(kit, design).total_s;
}

double travel_violation_mm(const Kit& kit, const AxisFrame& axis, const Installation& inst,
                           const std::vector<double>& angles_deg) {
  const std::optional<ArcEnds> ends = arc_of(angles_deg);
  if (!ends || !inst.bar_mm) return 0.0;
  const Eigen::Vector3d G =
      ball_body_mm(axis, inst) - inst.sign * *inst.bar_mm * inst.direction.body;
  // R(g) = A0 + cos g A1 + sin g A2
  return arc_travel_violation(kit, rotation_harmonics(axis), G, *ends);
}

namespace {

// The lowest value of a + b cos g + c sin g over the arc.
double arc_min(double a, double b, double c, const ArcEnds& ends) {
  return arc_extent(a, b, c, ends).first;
}

// Distance from the point q to the segment [p0, p1].
double segment_distance(const Eigen::Vector3d& q, const Eigen::Vector3d& p0,
                        const Eigen::Vector3d& p1) {
  const Eigen::Vector3d d = p1 - p0;
  const double n2 = d.squaredNorm();
  const double t = n2 > 0 ? std::clamp((q - p0).dot(d) / n2, 0.0, 1.0) : 0.0;
  return (q - (p0 + t * d)).norm();
}

// Closest distance between the segments [p0, p1] and [q0, q1].
double segments_distance(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                         const Eigen::Vector3d& q0, const Eigen::Vector3d& q1) {
  const Eigen::Vector3d d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  double s = 0, t = 0;
  if (a <= 0 && e <= 0) return r.norm();
  if (a <= 0) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= 0) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2), denom = a * e - b * b;
      s = denom > 0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0, s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1, s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return ((p0 + s * d1) - (q0 + t * d2)).norm();
}

// A table in the general form (installation_clashes): its normal n and surface s (heights
// above it are n . X - s in the body frame, which turns with the table, so the following ball's
// height does not change over the arc). The spindle's tool line is the machine's Z, the nose
// above the spindle ball. Its rim's lowest point above the table's plane is a convex function of
// c(g) = (R(g) n) . Z, itself a sinusoid of the angle: exact over the arc from c's extent. Its
// distance from the cup's axis (both as capsules, which hold the cylinders) is sampled at most
// 1 deg apart, less what a point of the nose can move between samples (the check errs on the
// safe side). The table's plane is taken without edges: a nose beyond its edge is flagged too.
template <typename Note>
void general_table_clash(const Kit& kit, const AxisFrame& axis, const Eigen::Vector3d& P0,
                         const Eigen::Vector3d& G, const ArcEnds& ends, Note& note) {
  const Workspace* w = kit.workspace ? &*kit.workspace : nullptr;
  const Eigen::Vector3d& n = kit.table_normal;
  const double surface = kit.table_surface_mm;
  const bool along = table_carriage(kit) == TableCarriage::kAlongAxis;
  // The table's own axes in its plane: (L, D) on a table turning about its normal, (H, D) on
  // a trunnion; its outline is centred where the frame's origin meets the table.
  const Eigen::Vector3d& u = along ? axis.e_L() : axis.e_H();
  const Eigen::Vector3d& v = axis.e_D();
  if (w && (w->table_diameter_mm || w->table_x_mm)) {
    const double f = w->footprint_mm / 2, x = P0.dot(u), y = P0.dot(v);
    const double by = w->table_diameter_mm
                          ? std::hypot(x, y) + f - *w->table_diameter_mm / 2
                          : std::max({w->table_x_mm->min - (x - f), (x + f) - w->table_x_mm->max,
                                      w->table_y_mm->min - (y - f), (y + f) - w->table_y_mm->max});
    note("the cup and blocks overhang the table", by);
  }
  const double g_height = n.dot(G) - surface;
  note("the spindle ball is below a cup's height", kit.H_base_mm - g_height);
  note("the bar dips into the table ball's cup", below_cup_mm(n.dot(G - P0), (G - P0).norm()));
  if (!w || w->ball_to_nose_mm <= 0) return;
  const double r = w->spindle_diameter_mm / 2, b = w->ball_to_nose_mm;
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  const RotationHarmonics& h = rotation_harmonics(axis);
  // f(c) = b c - r sqrt(1 - c^2) is convex: its least value over [c_lo, c_hi] is at the
  // clamped stationary point c* = -b / sqrt(b^2 + r^2).
  const auto [c_lo, c_hi] = arc_extent(z.dot(h.A0 * n), z.dot(h.A1 * n), z.dot(h.A2 * n), ends);
  const double c = std::clamp(-b / std::hypot(b, r), std::max(-1.0, c_lo), std::min(1.0, c_hi));
  note("the spindle nose reaches the table",
       w->clearance_mm - (g_height + b * c - r * std::sqrt(std::max(0.0, 1 - c * c))));
  // In the body frame the cup's axis is fixed (from the table's surface below the ball up to
  // the ball) and the nose turns about the axis through G. The nose's start is at most
  // d = b + (the cup's farthest point from G) from the cup, so no point of the nose beyond 2 d
  // from G is nearer; a point at t from G moves at most t dg / 2 to the nearest sample (samples
  // dg apart, at most 0.5 deg).
  const Eigen::Vector3d cup_foot = P0 - (n.dot(P0) - surface) * n;
  const double need = r + w->footprint_mm / 2 + w->clearance_mm;
  // First the exact bound: tool(g) . (X - G) is a sinusoid of the angle; where the cup lies
  // behind the plane across the tool line through the nose's start by `need` over the whole
  // arc, no point of the nose comes nearer (the gap stated is that bound, a lower bound).
  double ahead = -std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& X : {cup_foot, P0}) {
    const Eigen::Vector3d a = X - G;
    ahead =
        std::max(ahead, arc_extent(z.dot(h.A0 * a), z.dot(h.A1 * a), z.dot(h.A2 * a), ends).second);
  }
  if (b - ahead >= need) {
    note("the spindle nose reaches the table cup", need - (b - ahead));
    return;
  }
  const double d = b + std::max((G - P0).norm(), (G - cup_foot).norm());
  const double span = ends.hi_deg - ends.lo_deg;
  const int steps = std::max(1, static_cast<int>(std::ceil(span / 0.5)));
  const double slack = 2 * d * (span / steps) * (3.14159265358979323846 / 180.0) / 2;
  // The tool line in the body frame, tool(g) = R(g)^T Z = t0 + cos g t1 + sin g t2, its angle
  // stepped by rotating (cos, sin).
  const Eigen::Vector3d t0 = h.A0.transpose() * z, t1 = h.A1.transpose() * z,
                        t2 = h.A2.transpose() * z;
  double cg = ends.c_lo, sg = ends.s_lo, cd = 1, sd = 0;
  sincos_deg(span / steps, sd, cd);
  double apart = std::numeric_limits<double>::infinity();
  for (int k = 0; k <= steps; ++k) {
    const Eigen::Vector3d tool = t0 + cg * t1 + sg * t2;
    apart = std::min(apart, segments_distance(G + b * tool, G + 2 * d * tool, cup_foot, P0));
    const double c_next = cg * cd - sg * sd;
    sg = sg * cd + cg * sd;
    cg = c_next;
  }
  if (span > 0) apart -= slack;
  note("the spindle nose reaches the table cup", need - apart);
}

// The clashes of installation_clashes over the arc; with `out`, each kind's by_mm listed
// (whatever its sign); returns the largest (-infinity when no check applies).
// The same for the ball P0 and the following ball G = P0 - s bar u, body frame at angle 0.
double clash_extent(const Kit& kit, const AxisFrame& axis, const Eigen::Vector3d& P0,
                    const Eigen::Vector3d& G, const ArcEnds& ends, std::vector<Clash>* out) {
  double worst = -std::numeric_limits<double>::infinity();
  auto note = [&](const char* what, double by) {
    worst = std::max(worst, by);
    if (out) out->push_back({what, by});
  };
  const RotationHarmonics& h = rotation_harmonics(axis);
  const Workspace* w = kit.workspace ? &*kit.workspace : nullptr;
  if (axis.table() && axis.shorthand().empty()) {
    general_table_clash(kit, axis, P0, G, ends, note);
    return worst;
  }
  if (axis.table()) {
    // C: the table turns about +Z with its surface at z = 0; ball and spindle ball turn together,
    // so their heights and horizontal distance do not change over the arc.
    if (w && (w->table_diameter_mm || w->table_x_mm))
      note("the cup and blocks overhang the table", footprint_overhang_mm(*w, P0));
    const Eigen::Vector3d a = h.A0 * G, b = h.A1 * G, c = h.A2 * G;
    const double z_low = arc_min(a.z(), b.z(), c.z(), ends);
    note("the spindle ball is below a cup's height", kit.H_base_mm - z_low);
    note("the bar dips into the table ball's cup", below_cup_mm(G.z() - P0.z(), (G - P0).norm()));
    if (w && w->ball_to_nose_mm > 0) {
      const double nose_z = z_low + w->ball_to_nose_mm;
      note("the spindle nose reaches the table", w->clearance_mm - nose_z);
      const double apart = std::hypot(G.x() - P0.x(), G.y() - P0.y());
      if (apart < (w->spindle_diameter_mm + w->footprint_mm) / 2)
        note("the spindle nose reaches the table cup", P0.z() + w->clearance_mm - nose_z);
    }
    return worst;
  }
  // Head: the table ball stays put (work frame origin); a head point X (pivot frame at angle
  // 0) stands at R(g) (X - G). Heights are along the way the table faces (table_up: against
  // the spindle at the axis' zero, +Z under a head turning about Z), the table surface
  // table_ball_height_mm below the origin.
  const Eigen::Vector3d up = *table_up(axis, kit.machine, 0);
  auto lowest = [&](const Eigen::Vector3d& X) {
    const Eigen::Vector3d d = X - G;
    return arc_min(up.dot(h.A0 * d), up.dot(h.A1 * d), up.dot(h.A2 * d), ends);
  };
  // The spindle ball's lowest place against the table ball's: below_cup_mm with v . up at its
  // least over the arc (v's length, the bar, does not change).
  note("the bar dips into the table ball's cup", below_cup_mm(lowest(P0), (P0 - G).norm()));
  if (!w || !w->table_ball_height_mm) return worst;
  const double surface = -*w->table_ball_height_mm;
  note("the spindle ball nears the table", surface + w->clearance_mm - lowest(P0));
  if (w->ball_to_nose_mm > 0) {
    const Eigen::Vector3d& ref = axis.reference();
    const double along = std::max(0.0, P0.dot(ref) - w->ball_to_nose_mm);
    const Eigen::Vector3d X1 = along * ref, X2 = Eigen::Vector3d::Zero();
    const double r = w->spindle_diameter_mm / 2;
    // The cylinder's lowest point is an end's centre less r times the tool's tilt from the
    // vertical: sampled at most 0.25 deg apart (the error below 1e-5 of the head's size).
    const double span = ends.hi_deg - ends.lo_deg;
    const int n = std::max(1, static_cast<int>(std::ceil(span / 0.25)));
    double low = std::numeric_limits<double>::infinity();
    for (int k = 0; k <= n; ++k) {
      const Eigen::Matrix3d R = axis_rotation(axis, ends.lo_deg + span * k / n);
      const double tz = (R * ref).dot(up);
      const double tilt = r * std::sqrt(std::max(0.0, 1 - tz * tz));
      low = std::min({low, (R * (X1 - G)).dot(up) - tilt, (R * (X2 - G)).dot(up) - tilt});
    }
    note("the spindle nose reaches the table", surface + w->clearance_mm - low);
    note("the spindle nose reaches the table ball",
         r + w->clearance_mm - segment_distance(G, X1, X2));
  }
  return worst;
}

double clash_extent(const Kit& kit, const AxisFrame& axis, const Installation& inst,
                    const ArcEnds& ends, std::vector<Clash>* out) {
  if (!inst.bar_mm) return -std::numeric_limits<double>::infinity();
  const Eigen::Vector3d P0 = ball_body_mm(axis, inst);
  return clash_extent(kit, axis, P0, P0 - inst.sign * *inst.bar_mm * inst.direction.body, ends,
                      out);
}

}  // namespace

std::vector<Clash> installation_clashes(const Kit& kit, const AxisFrame& axis,
                                        const Installation& inst,
                                        const std::vector<double>& angles_deg,
                                        double tolerance_mm) {
  std::vector<Clash> all, out;
  const std::optional<ArcEnds> ends = arc_of(angles_deg);
  if (!ends) return out;
  clash_extent(kit, axis, inst, *ends, &all);
  for (const Clash& c : all)
    if (c.by_mm > tolerance_mm) out.push_back(c);
  return out;
}

namespace {

// sphere_clashes over the arc, each check passed to note(what, by_mm).
template <class Note>
void sphere_checks(const Kit& kit, const AxisFrame& axis, const Sphere& sphere, const ArcEnds& ends,
                   Note&& note) {
  const RotationHarmonics& h = rotation_harmonics(axis);
  const Eigen::Vector3d B = axis.body_point(sphere.L_mm, sphere.D_mm, sphere.H_mm);
  // x, y: touched from both sides at the centre's height; z: from above only.
  const double r = kit.probe.approach_mm;
  note("the probe's approach leaves the travel",
       arc_travel_violation(kit, h, B, ends, Eigen::Vector3d(r, r, 0), Eigen::Vector3d(r, r, r)));
  if (kit.probe.max_stem_tilt_deg) {
    // The stem along the table's normal, turned: its z a sinusoid of the angle.
    const Eigen::Vector3d n = kit.table_normal;
    const double z_low = arc_extent((h.A0 * n).z(), (h.A1 * n).z(), (h.A2 * n).z(), ends).first;
    const double tilt = std::acos(std::clamp(z_low, -1.0, 1.0)) * kDegPerRad;
    note("the sphere's stem tilts too far", tilt - *kit.probe.max_stem_tilt_deg);
  }
  const Workspace* w = kit.workspace ? &*kit.workspace : nullptr;
  if (w && axis.shorthand() == "C" && (w->table_diameter_mm || w->table_x_mm))
    note("the sphere's stand overhangs the table", footprint_overhang_mm(*w, B));
}

}  // namespace

std::vector<Clash> sphere_clashes(const Kit& kit, const AxisFrame& axis, const Sphere& sphere,
                                  const std::vector<double>& angles_deg, double tolerance_mm) {
  std::vector<Clash> out;
  const std::optional<ArcEnds> ends = arc_of(angles_deg);
  if (!ends) return out;
  sphere_checks(kit, axis, sphere, *ends, [&](const char* what, double by) {
    if (by > tolerance_mm) out.push_back({what, by});
  });
  return out;
}

double fit_spheres(const Kit& kit, const Design& design) {
  double worst = -std::numeric_limits<double>::infinity();
  const std::optional<ArcEnds> ends = arc_of(design.angles_deg);
  if (!ends) return worst;
  for (const Sphere& sp : design.spheres)
    sphere_checks(kit, design.axis, sp, *ends,
                  [&](const char*, double by) { worst = std::max(worst, by); });
  return worst;
}

std::vector<std::string> workspace_checks(const Kit& kit) {
  std::vector<std::string> out;
  const Workspace* w = kit.workspace ? &*kit.workspace : nullptr;
  if (kit.axis.table()) {
    if (w && (w->table_diameter_mm || w->table_x_mm))
      out.push_back("the cup's and blocks' footprint (" + text::significant(w->footprint_mm, 6) +
                    " mm) on the table");
    out.push_back("the spindle ball at least a cup's height (" +
                  text::significant(kit.H_base_mm, 6) + " mm) above the table surface");
    if (w && w->ball_to_nose_mm > 0)
      out.push_back(
          "the spindle nose clear of the table and the table cup by " +
          text::significant(w->clearance_mm, 6) + " mm" +
          (kit.axis.shorthand().empty() ? " (the table's plane taken without its edges)" : ""));
  } else if (w && w->table_ball_height_mm) {
    out.push_back("the spindle ball at least " + text::significant(w->clearance_mm, 6) +
                  " mm above the table surface (" + text::significant(*w->table_ball_height_mm, 6) +
                  " mm below the table ball)");
    if (w->ball_to_nose_mm > 0)
      out.push_back("the spindle nose clear of the table and the table ball by " +
                    text::significant(w->clearance_mm, 6) + " mm");
  }
  out.push_back("the bar at most " + text::significant(kMaxBarBelowCup_deg, 3) +
                " deg below the plane of the table ball's cup");
  return out;
}

double workspace_violation_mm(const Kit& kit, const AxisFrame& axis, const Installation& inst,
                              const std::vector<double>& angles_deg) {
  const std::optional<ArcEnds> ends = arc_of(angles_deg);
  if (!ends) return -std::numeric_limits<double>::infinity();
  return clash_extent(kit, axis, inst, *ends, nullptr);
}

namespace {

// The kit's bars, shortest first (the kit's own list when it is sorted already).
const std::vector<double>& sorted_bars(const Kit& kit, std::vector<double>& storage) {
  if (std::is_sorted(kit.bars_mm.begin(), kit.bars_mm.end())) return kit.bars_mm;
  storage = kit.bars_mm;
  std::sort(storage.begin(), storage.end());
  return storage;
}

double fit_bar_on(const Kit& kit, const AxisFrame& axis, Installation& inst,
                  const std::vector<double>& bars, const std::optional<ArcEnds>& ends);

}  // namespace

double fit_bar(const Kit& kit, const AxisFrame& axis, Installation& inst,
               const std::vector<double>& angles_deg) {
  std::vector<double> storage;
  return fit_bar_on(kit, axis, inst, sorted_bars(kit, storage), arc_of(angles_deg));
}

double fit_bars(const Kit& kit, Design& design) {
  std::vector<double> storage;
  const std::vector<double>& bars = sorted_bars(kit, storage);
  const std::optional<ArcEnds> ends = arc_of(design.angles_deg);
  double worst = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < design.installations.size(); ++i) {
    Installation& in = design.installations[i];
    // Each over its own arc (the design's, or the installation's angles).
    worst = std::max(worst, fit_bar_on(kit, design.axis, in, bars,
                                       in.angles_deg.empty() ? ends : arc_of(in.angles_deg)));
  }
  return worst;
}

namespace {

// fit_bar with the bars sorted and the arc formed.
double fit_bar_on(const Kit& kit, const AxisFrame& axis, Installation& inst,
                  const std::vector<double>& bars, const std::optional<ArcEnds>& ends) {
  double best = std::numeric_limits<double>::infinity();
  double best_bar = bars.front();
  int best_sign = table_ball_beyond_tool(axis, inst.direction, 1) ? 1 : -1;
  // Each bar and sign moves only the following ball.
  const RotationHarmonics& h = rotation_harmonics(axis);
  const Eigen::Vector3d ball = ball_body_mm(axis, inst);
  for (double bar : bars) {
    for (int sign : {1, -1}) {
      if (!table_ball_beyond_tool(axis, inst.direction, sign)) continue;  // inside the head
      double v = ends ? arc_travel_violation(kit, h, ball - sign * bar * inst.direction.body, *ends)
                      : 0.0;  // no angle: nothing turns (travel_violation_mm)
      if (ends)
        v = std::max(v, clash_extent(kit, axis, ball, ball - sign * bar * inst.direction.body,
                                     *ends, nullptr));
      if (v <= 0) {
        inst.bar_mm = bar;
        inst.sign = sign;
        return v;
      }
      if (v < best) best = v, best_bar = bar, best_sign = sign;
    }
  }
  inst.bar_mm = best_bar;
  inst.sign = best_sign;
  return best;
}

}  // namespace

}  // namespace dbbkit
