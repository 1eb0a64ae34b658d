#include "dbbkit/chain.hpp"

#include <Eigen/Geometry>
#include <boost/math/distributions/normal.hpp>
#include <cmath>

#include "dbbkit/error.hpp"
#include "dbbkit/iso230.hpp"
#include "dbbkit/user_text.hpp"
#include "number_text.hpp"

namespace dbbkit {

namespace {

struct Line {
  Eigen::Vector3d point, direction;
};

// Turns a line by angle phi (rad) about the line (a, u).
Line turned(const Line& l, const Eigen::Vector3d& a, const Eigen::Vector3d& u, double phi) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(phi, u.normalized()).toRotationMatrix();
  return {a + R * (l.point - a), R * l.direction};
}

// Where every input stands in the machine, and what the outputs are made of.
struct Setup {
  const Machine* m = nullptr;
  std::vector<int> index;        // the machine axis of each input
  std::vector<AxisFrame> frame;  // each input's frame (its carriers at 0)
  std::vector<IsoFrame> iso;
  std::vector<Eigen::Vector3d> origin;
};

// The outputs at the location errors x (5 per input, um and urad): every input's location errors
// in its carrier's body, then the chain terms (`terms` says which).
Eigen::VectorXd outputs(const Setup& s, const Eigen::VectorXd& x,
                        const std::vector<ChainTerm>& terms) {
  const std::size_t n = s.index.size();
  std::vector<Line> real(n);
  std::vector<double> zero(n);
  for (std::size_t i = 0; i < n; ++i) {
    const IsoFrame& f = s.iso[i];
    const Eigen::Vector3d d0 = s.frame[i].direction();
    const Eigen::Vector3d alpha = 1e-6 * (x(5 * i + 2) * f.p1 + x(5 * i + 3) * f.p2);
    real[i].point = s.origin[i] + 1e-3 * (x(5 * i) * f.p1 + x(5 * i + 1) * f.p2);
    real[i].direction = (d0 + alpha.cross(d0)).normalized();
    zero[i] = 1e-6 * x(5 * i + 4);  // about +q
  }
  // An axis seen with its carriers at 0: each carrier's zero-position error turned it about the
  // carrier's real line; turn it back, the carrier nearest the frame first.
  std::vector<Line> body = real;
  for (std::size_t i = 0; i < n; ++i) {
    for (const int c : s.m->carriers(s.index[i])) {
      for (std::size_t j = 0; j < n; ++j) {
        if (s.index[j] != c) continue;
        body[i] = turned(body[i], real[j].point, s.iso[j].q, -zero[j]);
      }
    }
  }
  Eigen::VectorXd out(5 * n + terms.size());
  for (std::size_t i = 0; i < n; ++i) {
    const IsoFrame& f = s.iso[i];
    const Eigen::Vector3d d0 = s.frame[i].direction(), o = s.origin[i];
    const Line& l = body[i];
    // The line where it crosses the plane through the nominal point across the axis.
    const double t = -(l.point - o).dot(d0) / l.direction.dot(d0);
    const Eigen::Vector3d p = l.point + t * l.direction;
    const Eigen::Vector3d alpha = d0.cross(l.direction);
    out(5 * i) = 1e3 * (p - o).dot(f.p1);
    out(5 * i + 1) = 1e3 * (p - o).dot(f.p2);
    out(5 * i + 2) = 1e6 * alpha.dot(f.p1);
    out(5 * i + 3) = 1e6 * alpha.dot(f.p2);
    out(5 * i + 4) = x(5 * i + 4);
  }
  for (std::size_t t = 0; t < terms.size(); ++t) {
    const ChainTerm& term = terms[t];
    std::size_t i = 0, j = 0;
    for (std::size_t k = 0; k < n; ++k) {
      if (s.m->rotary[s.index[k]].letter == term.a) i = k;
      if (s.m->rotary[s.index[k]].letter == term.b) j = k;
    }
    const Line &a = body[i], &b = body[j];
    if (term.name == "squareness") {
      const double angle =
          std::atan2(a.direction.cross(b.direction).norm(), a.direction.dot(b.direction));
      out(5 * n + t) = 1e6 * (angle - term.nominal * M_PI / 180);
    } else {
      Eigen::Vector3d normal = a.direction.cross(b.direction).normalized();
      if (normal.dot(term.along) < 0) normal = -normal;
      out(5 * n + t) = 1e3 * ((b.point - a.point).dot(normal) - term.nominal);
    }
  }
  return out;
}

}  // namespace

ChainResult chain_machine(const Machine& m, const std::vector<ChainInput>& inputs,
                          double coverage_probability) {
  if (inputs.size() < 2)
    throw InputError("chain", "results",
                     "the chain needs the results of at least two of the machine's axes");
  Setup s;
  s.m = &m;
  for (const ChainInput& in : inputs) {
    const int k = m.find(in.letter);
    if (k < 0)
      throw InputError(
          in.source, "design.machine.axis",
          std::string("axis ") + in.letter + " is not an axis of machine " + quote_value(m.name));
    for (const int other : s.index)
      if (other == k)
        throw InputError(in.source, "design.machine.axis",
                         std::string("a second result of axis ") + in.letter);
    for (const int c : m.carriers(k)) {
      if (in.park_deg[c] != 0)
        throw InputError(in.source, "design.machine.park_deg",
                         std::string("axis ") + in.letter + " was measured with its carrier " +
                             m.rotary[c].letter + " at " + text::significant(in.park_deg[c], 7) +
                             " deg: the chain takes an axis measured with its carriers at 0 (at "
                             "another angle the carrier's error motion there would enter)");
    }
    const Eigen::Vector3d nominal = m.point_at(k, in.park_deg);
    if ((nominal - in.origin_mm).norm() > 1e-6)
      throw InputError(in.source, "design.machine.origin_mm",
                       "the result's preset is not axis " + std::string(1, in.letter) +
                           "'s point in this machine file (was the file changed since?)");
    s.index.push_back(k);
    s.frame.push_back(m.axis_frame(k, in.park_deg));
    s.iso.push_back(iso_frame(s.frame.back()));
    s.origin.push_back(in.origin_mm);
  }
  const std::size_t n = inputs.size();
  // The terms: every pair's angle; the distance of two on one side that are not parallel.
  std::vector<ChainTerm> terms;
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      const RotaryAxisSpec &a = m.rotary[s.index[i]], &b = m.rotary[s.index[j]];
      // In the chain's order: the carrier (or the one nearer the frame) first.
      const bool swap = s.index[j] < s.index[i];
      const RotaryAxisSpec& first = swap ? b : a;
      const RotaryAxisSpec& second = swap ? a : b;
      ChainTerm sq;
      sq.a = first.letter, sq.b = second.letter, sq.name = "squareness";
      sq.nominal = std::atan2(first.direction.cross(second.direction).norm(),
                              first.direction.dot(second.direction)) *
                   180 / M_PI;
      terms.push_back(sq);
      const Eigen::Vector3d cross = first.direction.cross(second.direction);
      if (first.side == second.side && cross.norm() > 1e-9) {
        ChainTerm d;
        d.a = first.letter, d.b = second.letter, d.name = "distance";
        // The common normal, its largest component positive (along +Y rather than -Y).
        d.along = cross.normalized();
        Eigen::Index big = 0;
        d.along.cwiseAbs().maxCoeff(&big);
        if (d.along(big) < 0) d.along = -d.along;
        d.nominal = (second.point_mm - first.point_mm).dot(d.along);
        terms.push_back(d);
      }
    }
  }
  Eigen::VectorXd x = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(5 * n));
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(5 * n, 5 * n);
  std::vector<bool> known(5 * n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int e = 0; e < 5; ++e) {
      known[5 * i + e] = inputs[i].value[e].has_value();
      x(5 * i + e) = inputs[i].value[e].value_or(0.0);
    }
    C.block<5, 5>(5 * i, 5 * i) = inputs[i].covariance;
  }
  const Eigen::VectorXd y = outputs(s, x, terms);
  Eigen::MatrixXd J(y.size(), x.size());
  constexpr double h = 1e-3;
  for (Eigen::Index c = 0; c < x.size(); ++c) {
    Eigen::VectorXd up = x, down = x;
    up(c) += h, down(c) -= h;
    J.col(c) = (outputs(s, up, terms) - outputs(s, down, terms)) / (2 * h);
  }
  const Eigen::MatrixXd cov = J * C * J.transpose();
  ChainResult r;
  r.coverage_probability = coverage_probability;
  r.k = boost::math::quantile(boost::math::normal(), 0.5 + coverage_probability / 2);
  auto quantity = [&](Eigen::Index row, const std::string& name, const std::string& unit) {
    ChainQuantity q;
    q.name = name, q.unit = unit;
    for (Eigen::Index c = 0; c < x.size(); ++c)
      if (!known[static_cast<std::size_t>(c)] && std::abs(J(row, c)) > 1e-9) return q;
    q.value = y(row) + 0.0;  // -0 is 0
    q.std = std::sqrt(std::max(0.0, cov(row, row)));
    q.U = r.k * *q.std;
    return q;
  };
  for (std::size_t i = 0; i < n; ++i) {
    ChainAxis a;
    a.letter = inputs[i].letter;
    a.source = inputs[i].source;
    a.sha256 = inputs[i].sha256;
    a.measured = inputs[i].value;
    a.warnings = inputs[i].warnings;
    const IsoFrame& f = s.iso[i];
    a.vector = {f.p1, f.p2, f.p1, f.p2, f.q};
    for (int e = 0; e < 5; ++e)
      a.location.push_back(quantity(static_cast<Eigen::Index>(5 * i + e), inputs[i].names[e],
                                    e < 2 ? "um" : "urad"));
    r.axes.push_back(a);
  }
  r.location_covariance = cov.topLeftCorner(5 * n, 5 * n);
  for (Eigen::Index row = 0; row < static_cast<Eigen::Index>(5 * n); ++row) {
    if (!r.axes[static_cast<std::size_t>(row) / 5].location[row % 5].value) {
      r.location_covariance.row(row).setZero();
      r.location_covariance.col(row).setZero();
    }
  }
  for (std::size_t t = 0; t < terms.size(); ++t) {
    ChainTerm term = terms[t];
    term.q = quantity(static_cast<Eigen::Index>(5 * n + t), term.name,
                      term.name == "distance" ? "um" : "urad");
    r.terms.push_back(term);
  }
  return r;
}

}  // namespace dbbkit
