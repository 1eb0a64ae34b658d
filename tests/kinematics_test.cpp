#include <gtest/gtest.h>
#include "dbbkit/kinematics.hpp"
TEST(Kinematics, Placeholder) {}
