#include "dbbkit/instrument.hpp"

#include <Eigen/Geometry>

#include "dbbkit/error.hpp"
#include "dbbkit/limits.hpp"
#include "dbbkit/user_text.hpp"

namespace dbbkit {

const char* instrument_name(InstrumentKind kind) {
  return kind == InstrumentKind::kProbe ? "probe" : "ballbar";
}

const char* setup_effect_nouns(InstrumentKind kind) {
  return kind == InstrumentKind::kProbe ? "trigger offset and sphere placement"
                                        : "length offset and centring";
}

const char* setup_tolerance_keys(InstrumentKind kind) {
  return kind == InstrumentKind::kProbe ? "trigger_offset_um, placement_um"
                                        : "length_offset_um, centring_um";
}

const char* setup_tolerance_phrase(InstrumentKind kind) {
  return kind == InstrumentKind::kProbe ? "a trigger offset or placement tolerance"
                                        : "a length offset or centring tolerance";
}

const char* measured_item(InstrumentKind kind) {
  return kind == InstrumentKind::kProbe ? "a sphere" : "an installation";
}

const char* measured_items(InstrumentKind kind) {
  return kind == InstrumentKind::kProbe ? "spheres" : "installations";
}

std::size_t measured_count(const Design& design) {
  return design.instrument == InstrumentKind::kProbe ? design.spheres.size()
                                                     : design.installations.size();
}

void require_ballbar(const Design& design, const std::string& source, const std::string& what) {
  if (design.instrument == InstrumentKind::kBallbar) return;
  throw InputError(source, "instrument.kind",
                   what +
                       " is a ball bar's; this design's instrument is a touch probe (its "
                       "spheres are probed by the controller's own cycle, e.g. "
                       "KinematicsOpt's or CYCLE996's, at the design's angles)");
}

std::string probe_channel_id(const std::string& sphere_id, int coordinate) {
  return sphere_id + ":" + kProbeCoordinates[static_cast<std::size_t>(coordinate)];
}

std::vector<Installation> probe_channels(const AxisFrame& axis,
                                         const std::vector<Sphere>& spheres) {
  std::vector<Installation> out;
  out.reserve(3 * spheres.size());
  for (std::size_t s = 0; s < spheres.size(); ++s) {
    for (int k = 0; k < 3; ++k) {
      Installation c;
      c.id = probe_channel_id(spheres[s].id, k);
      c.L_mm = spheres[s].L_mm;
      c.D_mm = spheres[s].D_mm;
      c.H_mm = spheres[s].H_mm;
      c.direction = Direction::vector(Eigen::Vector3d::Unit(k));
      c.sign = axis.head() ? -1 : +1;
      c.sphere = static_cast<int>(s);
      c.coordinate = k;
      out.push_back(c);
    }
  }
  return out;
}

std::optional<std::string> setup_tolerance_problem(const SetupUncertainty& u, InstrumentKind kind) {
  if (kind == InstrumentKind::kProbe &&
      (u.placement() || u.length_offset_um != 0 || u.centring_um != 0))
    return std::string(
        "a probe's set-up tolerances are trigger_offset_um and placement_um (a ball bar's "
        "length offset, centring and ball placement have no meaning for it)");
  if (kind == InstrumentKind::kBallbar && (u.trigger_offset_um != 0 || u.placement_um != 0))
    return std::string(
        "trigger_offset_um and placement_um are a touch probe's set-up tolerances (instrument."
        "kind probe)");
  return std::nullopt;
}

std::optional<std::string> sphere_id_problem(const std::string& id) {
  if (const auto p = id_problem(id)) return p;
  if (id == "all")
    return std::string(
        "\"all\" names the whole test in an effect's label ([all]): give the sphere "
        "another id");
  if (id.find(':') != std::string::npos)
    return std::string("a sphere's id holds no ':' (its channels' ids are id:x, id:y, id:z)");
  if (id.size() + 2 > limits::kMaxIdBytes)
    return "a sphere's id is at most " + std::to_string(limits::kMaxIdBytes - 2) +
           " bytes (its channels' ids add \":x\")";
  return std::nullopt;
}

int find_sphere(const Design& design, const std::string& id) {
  for (std::size_t s = 0; s < design.spheres.size(); ++s)
    if (design.spheres[s].id == id) return static_cast<int>(s);
  return -1;
}

double exact_probe_reading_um(const AxisFrame& axis, const Installation& c, double angle_deg,
                              const Vector6d& e6, const SetupError& setup) {
  const Eigen::Matrix3d R = axis_rotation(axis, angle_deg);
  const Eigen::Vector3d nominal = R * axis.body_point(c.L_mm, c.D_mm, c.H_mm);
  const Eigen::Vector3d placed =
      R * axis.body_point(c.L_mm + setup.ball_mm(0), c.D_mm + setup.ball_mm(1),
                          axis.has_H() ? c.H_mm + setup.ball_mm(2) : c.H_mm);
  const Eigen::Vector3d real = error_rotation(e6) * placed + 1e-3 * e6.head<3>();
  const int k = c.coordinate;
  return c.sign * 1e3 * (real(k) - nominal(k)) + setup.length_offset_um + setup.centring_um(k);
}

double exact_instrument_reading_um(const AxisFrame& axis, const Installation& inst,
                                   double angle_deg, const Vector6d& e6, double bar_mm,
                                   const SetupError& setup) {
  if (inst.probe_channel()) return exact_probe_reading_um(axis, inst, angle_deg, e6, setup);
  return exact_setup_reading_um(axis, inst, angle_deg, e6, bar_mm, setup);
}

}  // namespace dbbkit
