#pragma once
// One warning of a result (warnings.hpp says which there are and when).

#include <string>

namespace dbbkit {

struct Warning {
  std::string kind;  // residual, first_order, setup_undeclared, noise_scale
  std::string text;  // one or two sentences: what, and what to do
};

}  // namespace dbbkit
