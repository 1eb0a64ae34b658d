#pragma once
// The library's side of the work counters (dbbkit/cost.hpp): each kernel adds what it does.

#include "dbbkit/cost.hpp"

namespace dbbkit::cost::detail {

Counts& counters();

}  // namespace dbbkit::cost::detail
