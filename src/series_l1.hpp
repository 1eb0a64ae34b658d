#pragma once
// Internal: what Gain::left_l1 of a series (series_l1.cpp) does with the readings' angles.

#include "dbbkit/linear_model.hpp"

namespace dbbkit::detail {

// Whether the bias bound's tiles pair the angles with their reflections (the even and odd
// basis functions summed apart, half the products): the basis has odd functions and at most
// a quarter more slots than angles are needed.
bool series_angles_paired(const SeriesRows& s);

}  // namespace dbbkit::detail
