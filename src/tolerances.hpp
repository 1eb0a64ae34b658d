#pragma once
// Fixed numerical tolerances shared by more than one source file, each named once and
// documented by the inequality it tests. Tolerances a caller may change are in the Options
// of their operation (EstimateOptions::min_relative_singular_value, ...); tolerances used by
// one file only are named at the top of that file.

#include <cmath>

namespace dbbkit::tol {

// A reading sees a column x of an effect when |x_i| > kSeenValue at some reading i (um per
// unit of the effect): smaller values are the rounding of a zero lever arm. effect_block
// (effects.cpp) and the closed-form set-up information (observability.cpp) apply it alike.
constexpr double kSeenValue = 1e-12;

// The fast worst case (observability.cpp) answers only where its bound on the condition
// number of the equilibrated problem holds, far inside the solver's rank tolerance (1e9):
//   per angle:  sqrt(6 tr(A) tr(A^-1)) <= kFastPerAngleCondition   (A the 6 x 6 information)
//   series:     p tr(Ms^-1) <= kFastSeriesCondition                 (Ms the p x p information)
// and every column scale c_j > kMinColumnScale max_k c_k; otherwise the general solver answers.
constexpr double kFastPerAngleCondition = 1e5;
constexpr double kFastSeriesCondition = 1e10;
constexpr double kMinColumnScale = 1e-12;

// A step h divides a range of width w into m = w / h steps when |m - round(m)| <=
// kWholeSteps max(1, |m|) (kit angle steps, design angle grids); a search grid of step h over
// [lo, hi] has ceil((hi - lo) / h - kWholeSteps) steps.
constexpr double kWholeSteps = 1e-9;

// An explicit reading direction is a unit vector when ||v| - 1| <= kUnitVectorTolerance (a
// vector written with six digits); design.cpp and the design reader apply it alike.
constexpr double kUnitVectorTolerance = 1e-6;

// Where a largest value is named (the worst uncertainty's error and angle, the largest bias of
// a set-up effect), values within kTieRelative of one another are a tie, and the first offered
// (stations in angle order, errors dx..ez) is named: a symmetric design has exact ties that
// rounding would otherwise break one way or the other (PlaceOfLargest). The order of
// significance of residual features (more_significant, residual_checks.hpp, public) ties its
// p-values by the same relative width, kSignificanceTie.
constexpr double kTieRelative = 1e-9;

}  // namespace dbbkit::tol

namespace dbbkit {

// The place of the largest of the values offered, ties (tol::kTieRelative) to the first: offer
// says whether this value takes the place. Every value offered is at most (1 + kTieRelative)
// times the value at the place.
class PlaceOfLargest {
 public:
  bool offer(double v) {
    if (!(v > (taken_ ? at_ * (1.0 + tol::kTieRelative) : -HUGE_VAL))) return false;  // NaN: no
    at_ = v;
    taken_ = true;
    return true;
  }

 private:
  double at_ = 0;
  bool taken_ = false;
};

}  // namespace dbbkit
