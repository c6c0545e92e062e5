// SPDX-License-Identifier: BSD-3-Clause
// MeasureSimplex against values worked out by hand from Verdict's definitions (the filter test
// TestSimplexQualityAgreesWithVerdict compares with vtkMeshQuality on random simplices) and the
// paper's own examples of Table 2's caption.

#include "Check/SimplexQuality.h"

#include <gtest/gtest.h>

#include <cmath>

namespace
{

constexpr double Tolerance = 1e-12;

template <int Dim>
stm::SimplexShape<Dim> Measure(const double (&corners)[Dim + 1][Dim])
{
  const double* pointers[Dim + 1];
  for (int v = 0; v <= Dim; ++v)
  {
    pointers[v] = corners[v];
  }
  return stm::MeasureSimplex<Dim>(pointers);
}

TEST(SimplexQuality, RegularSimplicesHaveConditionOne)
{
  const double segment[2][1] = { { 0.25 }, { 1.75 } };
  EXPECT_NEAR(Measure<1>(segment).Condition, 1.0, Tolerance);
  EXPECT_EQ(Measure<1>(segment).MinDihedralDegrees, 180.0);

  const double h = std::sqrt(3.0) / 2.0;
  const double triangle[3][2] = { { 0, 0 }, { 2, 0 }, { 1, 2 * h } };
  EXPECT_NEAR(Measure<2>(triangle).Condition, 1.0, Tolerance);
  EXPECT_NEAR(Measure<2>(triangle).MinDihedralDegrees, 60.0, 1e-10);

  // Alternate corners of a cube.
  const double tetrahedron[4][3] = { { 0, 0, 0 }, { 1, 1, 0 }, { 0, 1, 1 }, { 1, 0, 1 } };
  const auto shape = Measure<3>(tetrahedron);
  EXPECT_NEAR(shape.Condition, 1.0, Tolerance);
  EXPECT_NEAR(shape.MinDihedralDegrees, std::acos(1.0 / 3.0) * 180.0 / M_PI, 1e-10);
  EXPECT_NEAR(shape.Determinant, 2.0, Tolerance);

  // The regular 4-simplex with unit edges: the origin and e_i / sqrt(2) + c (1, 1, 1, 1), where
  // 4 c^2 + sqrt(2) c = 1 / 2 makes the edges from the origin unit long too.
  const double c = (std::sqrt(10.0) - std::sqrt(2.0)) / 8.0;
  const double s = 1.0 / std::sqrt(2.0);
  const double simplex4[5][4] = { { 0, 0, 0, 0 }, { s + c, c, c, c }, { c, s + c, c, c },
    { c, c, s + c, c }, { c, c, c, s + c } };
  EXPECT_NEAR(Measure<4>(simplex4).Condition, 1.0, 1e-10);
  EXPECT_NEAR(Measure<4>(simplex4).MinDihedralDegrees, std::acos(0.25) * 180.0 / M_PI, 1e-9);
}

TEST(SimplexQuality, RightCornersMatchVerdict)
{
  // Verdict's triangle condition is (sum of squared edges) / (4 sqrt(3) area).
  const double triangle[3][2] = { { 0, 0 }, { 1, 0 }, { 0, 1 } };
  EXPECT_NEAR(Measure<2>(triangle).Condition, 4.0 / (2.0 * std::sqrt(3.0)), Tolerance);
  EXPECT_NEAR(Measure<2>(triangle).MinDihedralDegrees, 45.0, 1e-10);
  // The corner tetrahedron of a cube: sqrt(13.5) / 3; its slanted face meets the others at
  // acos(1 / sqrt(3)).
  const double corner[4][3] = { { 0, 0, 0 }, { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 } };
  EXPECT_NEAR(Measure<3>(corner).Condition, std::sqrt(13.5) / 3.0, Tolerance);
  EXPECT_NEAR(
    Measure<3>(corner).MinDihedralDegrees, std::acos(1.0 / std::sqrt(3.0)) * 180.0 / M_PI, 1e-10);
}

TEST(SimplexQuality, FlatTetrahedraOfThePapersCaption)
{
  // "a tet spanned by the scaled unit vectors e1, e2 and a e3 gets quality values 2.5 (a = 0.25)
  // and 5.8 (a = 0.1)"; exactly sqrt(1.5 (2 + a^2) (2 + 1 / a^2)) / 3.
  for (const double a : { 0.25, 0.1 })
  {
    const double flat[4][3] = { { 0, 0, 0 }, { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, a } };
    const double expected = std::sqrt(1.5 * (2 + a * a) * (2 + 1 / (a * a))) / 3.0;
    EXPECT_NEAR(Measure<3>(flat).Condition, expected, 1e-12);
  }
  const double quarter[4][3] = { { 0, 0, 0 }, { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 0.25 } };
  EXPECT_NEAR(Measure<3>(quarter).Condition, 2.5, 0.02);
  const double tenth[4][3] = { { 0, 0, 0 }, { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 0.1 } };
  EXPECT_NEAR(Measure<3>(tenth).Condition, 5.8, 0.06);
}

TEST(SimplexQuality, InvertedAndDegenerateSimplicesAreInfinitelyBad)
{
  const double inverted[3][2] = { { 0, 0 }, { 0, 1 }, { 1, 0 } };
  const auto shape = Measure<2>(inverted);
  EXPECT_LT(shape.Determinant, 0.0);
  EXPECT_TRUE(std::isinf(shape.Condition));
  EXPECT_EQ(shape.MinDihedralDegrees, 0.0);
  const double flat[4][3] = { { 0, 0, 0 }, { 1, 0, 0 }, { 0, 1, 0 }, { 1, 1, 0 } };
  EXPECT_EQ(Measure<3>(flat).Determinant, 0.0);
  EXPECT_TRUE(std::isinf(Measure<3>(flat).Condition));
}

TEST(SimplexQuality, ConditionIsInvariantUnderSimilarity)
{
  const double tetrahedron[4][3] = { { 0.1, 0.2, 0.3 }, { 1.3, 0.1, 0.2 }, { 0.4, 1.1, 0.0 },
    { 0.2, 0.5, 0.9 } };
  double moved[4][3];
  const double angle = 0.7, scale = 3.5;
  for (int v = 0; v < 4; ++v)
  {
    const double* p = tetrahedron[v];
    moved[v][0] = scale * (std::cos(angle) * p[0] - std::sin(angle) * p[1]) + 2.0;
    moved[v][1] = scale * (std::sin(angle) * p[0] + std::cos(angle) * p[1]) - 1.0;
    moved[v][2] = scale * p[2] + 0.5;
  }
  const auto a = Measure<3>(tetrahedron);
  const auto b = Measure<3>(moved);
  EXPECT_NEAR(a.Condition, b.Condition, 1e-12);
  EXPECT_NEAR(a.MinDihedralDegrees, b.MinDihedralDegrees, 1e-10);
  EXPECT_NEAR(b.Determinant, a.Determinant * scale * scale * scale, 1e-12);
}

} // namespace
