// dbbkit as a library: build a design in code, ask what it can identify, then
// identify simulated readings. Built against the installed package
// (find_package(dbbkit)) by the test ConsumerOfInstalledPackage.
#include <dbbkit/identify.hpp>
#include <dbbkit/kinematics.hpp>
#include <dbbkit/observability.hpp>
#include <dbbkit/simulate.hpp>
#include <iostream>

int main() {
  using namespace dbbkit;
  Design d;
  d.name = "three positions";
  d.axis = AxisFrame::c_turntable();
  for (int a = 0; a <= 360; a += 30) d.angles_deg.push_back(a);
  d.noise.half_width_um = 1.25;  // rectangular +-1.25 um
  auto ball = [&](const char* id, double L, double H, Direction::Kind k) {
    Installation in;
    in.id = id;
    in.L_mm = L;
    in.H_mm = H;
    in.direction = Direction::named(AxisFrame::c_turntable(), k);
    d.installations.push_back(in);
  };
  using K = Direction::Kind;
  ball("1r", 100, 60, K::kRadial), ball("1t", 100, 60, K::kTangential),
      ball("1a", 0, 60, K::kAxial);
  ball("2r", 200, 60, K::kRadial), ball("2t", 200, 60, K::kTangential);
  ball("3r", 100, 160, K::kRadial), ball("3t", 100, 160, K::kTangential);
  validate_design(d);

  const Evaluation ev = evaluate_design(d, 100.0);
  std::cout << "rank " << ev.prior.rank << " of " << ev.prior.n_unknowns << ", worst_std_um "
            << *ev.worst.worst_std_um << " um\n";

  Truth truth;  // position-independent errors: dx..ez = 1, 2, 3 um and 4, 5, 6 urad
  truth.model = {ErrorModel::Kind::kFourier, 0};
  for (int k = 0; k < 6; ++k) truth.coefficients[k] = {k + 1.0};
  const std::vector<Reading> readings = simulate(d, truth, 42);
  const IdentifyResult r = identify(d, readings);
  const ErrorsAtAngle& at0 = r.errors.front();
  for (int k = 0; k < 6; ++k) {
    std::cout << kErrorNames[k] << " = " << at0.errors[k].value << " +- " << at0.errors[k].std
              << " " << kErrorUnits[k] << "\n";
  }
  std::cout << "chi2 " << r.estimate.chi2 << " on " << r.estimate.dof << " dof\n";
  return r.estimate.rank == r.estimate.n_unknowns ? 0 : 1;
}
