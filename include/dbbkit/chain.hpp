#pragma once
// The machine as a chain (formats.md, "Machine file"): the location errors of several rotary
// axes, each identified on a design that names the machine, combined on the controller's
// reference. Each axis' real line is its nominal one (the machine file's point and direction)
// moved by its location errors; an axis carried by another is seen with its carrier at the park
// angle 0, and the carrier's zero-position error turns it there, so it is turned back about the
// carrier's real line: what remains is the axis in its carrier's body, what a kinematics table
// holds. The chain terms are the relations the controller's model fixes between two axes: the
// shortest distance between their lines (two axes on one side) and their angle (any two), each
// as the real one minus the nominal one.
//
// Uncertainty: the axes' results come from independent tests, so their location errors'
// covariances (iso230.location_covariance) add as blocks; every output is a smooth function of
// them, propagated to first order by its Jacobian (central differences, steps of 1e-3 um and
// urad). U = k u with k the normal quantile of the coverage probability.

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "dbbkit/machine.hpp"

namespace dbbkit {

// One axis' result as `chain` uses it.
struct ChainInput {
  std::string source;  // the result's file, for messages
  std::string sha256;  // SHA-256 of the result's file, or empty when it came from no file
  char letter = 'C';
  std::vector<double> park_deg;  // every axis' angle while this one was measured
  Eigen::Vector3d origin_mm = Eigen::Vector3d::Zero();
  std::array<std::string, 5> names;  // X0C, Y0C, A0C, B0C, C0C (um, um, urad, urad, urad)
  std::array<std::optional<double>, 5> value;
  Eigen::Matrix<double, 5, 5> covariance = Eigen::Matrix<double, 5, 5>::Zero();
  // The result's warnings (what makes its stated uncertainty unreliable): the chain carries them.
  std::vector<std::string> warnings;
};

struct ChainQuantity {
  std::string name, unit;
  std::optional<double> value, std, U;  // absent: a location error it needs is not determined
};

struct ChainAxis {
  char letter = 'C';
  std::string source, sha256;
  std::vector<std::string> warnings;  // its result's, as written
  // Its location errors against the machine file's line, in its carrier's body (the machine
  // frame with every axis at zero).
  std::vector<ChainQuantity> location;
  // The location errors as its result gives them (with its carriers at their zero errors).
  std::array<std::optional<double>, 5> measured;
  // Each location error's direction in the machine frame: the offset's (X0C: +X), the tilt's
  // rotation axis (A0C: +X), the zero error's (the axis' own direction).
  std::array<Eigen::Vector3d, 5> vector;
};

struct ChainTerm {
  char a = 'A', b = 'C';
  std::string name;    // "distance" or "squareness"
  ChainQuantity q;     // the real relation minus the nominal one (um or urad)
  double nominal = 0;  // mm (distance) or deg (angle)
  // distance: the nominal common normal, its largest component positive
  Eigen::Vector3d along = Eigen::Vector3d::Zero();
};

struct ChainResult {
  std::vector<ChainAxis> axes;
  std::vector<ChainTerm> terms;
  double coverage_probability = 0.95;
  double k = 1.959963984540054;
  // The covariance of every axis' location errors as `axes` lists them (5 per axis, um and
  // urad; rows of an undetermined one zero): what a value combined from several needs.
  Eigen::MatrixXd location_covariance;
};

// Throws InputError(source, key) when a result does not belong to the machine (another axis
// frame, another origin), two results name one axis, or an axis was measured with a carrier
// away from 0.
ChainResult chain_machine(const Machine& machine, const std::vector<ChainInput>& axes,
                          double coverage_probability = 0.95);

}  // namespace dbbkit
