// SPDX-License-Identifier: BSD-3-Clause
// ProjectToLevelSet on spheres and planes in 2D and 3D, and its refusals.

#include "Cut/LevelSetProjection.h"

#include <gtest/gtest.h>

#include <cmath>

namespace
{

template <int Dim>
double SquaredSphere(const double* x, double* gradient)
{
  // |x|^2 - 1: not a distance, so Newton needs several steps.
  double value = -1.0;
  for (int c = 0; c < Dim; ++c)
  {
    value += x[c] * x[c];
    gradient[c] = 2.0 * x[c];
  }
  return value;
}

TEST(LevelSetProjection, ReachesTheSphereAlongTheNormal)
{
  stm::LevelSetProjectionOptions options;
  options.MaxDistance = 5.0;
  double x3[3] = { 1.2, -0.9, 1.5 };
  const double norm = std::sqrt(1.2 * 1.2 + 0.9 * 0.9 + 1.5 * 1.5);
  ASSERT_TRUE(stm::ProjectToLevelSet<3>(x3, SquaredSphere<3>, options));
  EXPECT_NEAR(x3[0], 1.2 / norm, 1e-12);
  EXPECT_NEAR(x3[1], -0.9 / norm, 1e-12);
  EXPECT_NEAR(x3[2], 1.5 / norm, 1e-12);

  double x2[2] = { 0.1, 0.2 };
  ASSERT_TRUE(stm::ProjectToLevelSet<2>(x2, SquaredSphere<2>, options));
  EXPECT_NEAR(std::hypot(x2[0], x2[1]), 1.0, 1e-12);
  EXPECT_NEAR(x2[1] / x2[0], 2.0, 1e-12);
}

TEST(LevelSetProjection, UsesTheIsoValue)
{
  auto plane = [](const double* x, double* gradient)
  {
    gradient[0] = 0.0;
    gradient[1] = 2.0;
    return 2.0 * x[1];
  };
  stm::LevelSetProjectionOptions options;
  options.IsoValue = 1.0;
  double x[2] = { 3.0, 0.25 };
  ASSERT_TRUE(stm::ProjectToLevelSet<2>(x, plane, options));
  EXPECT_EQ(x[0], 3.0);
  EXPECT_EQ(x[1], 0.5);
}

TEST(LevelSetProjection, RefusesAndLeavesThePointAlone)
{
  stm::LevelSetProjectionOptions options;
  // The gradient vanishes at the centre.
  double centre[3] = { 0.0, 0.0, 0.0 };
  EXPECT_FALSE(stm::ProjectToLevelSet<3>(centre, SquaredSphere<3>, options));
  EXPECT_EQ(centre[0], 0.0);
  // Too far: the sphere is 2 away.
  options.MaxDistance = 1.0;
  double far[3] = { 3.0, 0.0, 0.0 };
  EXPECT_FALSE(stm::ProjectToLevelSet<3>(far, SquaredSphere<3>, options));
  EXPECT_EQ(far[0], 3.0);
  // NaN values.
  auto broken = [](const double*, double* gradient)
  {
    gradient[0] = 1.0;
    return std::nan("");
  };
  double x[1] = { 0.5 };
  EXPECT_FALSE(stm::ProjectToLevelSet<1>(x, broken, options));
  EXPECT_EQ(x[0], 0.5);
}

} // namespace
