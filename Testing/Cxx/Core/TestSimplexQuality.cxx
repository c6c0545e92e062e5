// SPDX-License-Identifier: BSD-3-Clause
// MeasureSimplex against values worked out by hand from Verdict's definitions (the filter test
// TestSimplexQualityAgreesWithVerdict compares with vtkMeshQuality on random simplices) and the
// paper's own examples of Table 2's caption.

#include "Check/SimplexQuality.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

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

/// The Gram matrix definitions of the header's comment, computed directly (inverse by
/// cofactors), as the reference of the closed forms that MeasureSimplex uses for triangles and
/// tetrahedra.
template <int Dim>
void GramReference(const double (&x)[Dim + 1][Dim], double& condition, double& largestCosine)
{
  double m[Dim][Dim];
  for (int i = 0; i < Dim; ++i)
  {
    for (int j = 0; j < Dim; ++j)
    {
      m[i][j] = 0.0;
      for (int r = 0; r < Dim; ++r)
      {
        m[i][j] += (x[i + 1][r] - x[0][r]) * (x[j + 1][r] - x[0][r]);
      }
    }
  }
  double inverse[Dim][Dim];
  if constexpr (Dim == 2)
  {
    const double det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    inverse[0][0] = m[1][1] / det;
    inverse[1][1] = m[0][0] / det;
    inverse[0][1] = inverse[1][0] = -m[0][1] / det;
  }
  else
  {
    for (int i = 0; i < 3; ++i)
    {
      for (int j = 0; j < 3; ++j)
      {
        const int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
        inverse[i][j] = m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1];
      }
    }
    const double det = m[0][0] * inverse[0][0] + m[0][1] * inverse[1][0] + m[0][2] * inverse[2][0];
    for (auto& row : inverse)
    {
      for (double& v : row)
      {
        v /= det;
      }
    }
  }
  double traceM = 0.0, sumM = 0.0, traceInverse = 0.0, sumInverse = 0.0;
  double products[Dim + 1][Dim + 1];
  for (int i = 0; i < Dim; ++i)
  {
    traceM += m[i][i];
    traceInverse += inverse[i][i];
    double column = 0.0;
    for (int j = 0; j < Dim; ++j)
    {
      sumM += m[i][j];
      sumInverse += inverse[i][j];
      column += inverse[j][i];
      products[i + 1][j + 1] = inverse[i][j];
    }
    products[0][i + 1] = products[i + 1][0] = -column;
  }
  products[0][0] = sumInverse;
  condition =
    std::sqrt(2.0 * (traceM - sumM / (Dim + 1)) * 0.5 * (traceInverse + sumInverse)) / Dim;
  largestCosine = -1.0;
  for (int i = 0; i <= Dim; ++i)
  {
    for (int j = i + 1; j <= Dim; ++j)
    {
      largestCosine =
        std::max(largestCosine, -products[i][j] / std::sqrt(products[i][i] * products[j][j]));
    }
  }
}

/// Corners uniform in [-1, 1]^Dim, and pointers to them.
template <int Dim>
void RandomSimplex(
  std::mt19937& random, double (&x)[Dim + 1][Dim], const double* (&corners)[Dim + 1])
{
  std::uniform_real_distribution<double> coordinate(-1.0, 1.0);
  for (int v = 0; v <= Dim; ++v)
  {
    for (double& c : x[v])
    {
      c = coordinate(random);
    }
    corners[v] = x[v];
  }
}

template <int Dim>
void CheckClosedForms()
{
  std::mt19937 random(11);
  int checked = 0, sure = 0;
  for (int trial = 0; trial < 20000; ++trial)
  {
    double x[Dim + 1][Dim];
    const double* corners[Dim + 1];
    RandomSimplex<Dim>(random, x, corners);
    const stm::SimplexCosines shape = stm::MeasureSimplexCosines<Dim>(corners);
    if (!(shape.Determinant > 0.0) || shape.Condition > 100.0)
    {
      continue;
    }
    double condition = 0.0, cosine = 0.0;
    GramReference<Dim>(x, condition, cosine);
    // The Gram matrix squares the simplex's conditioning, so the reference's own rounding
    // grows like condition^2 eps.
    const double tolerance = 1e-12 * condition * condition;
    EXPECT_NEAR(shape.Condition, condition, tolerance * condition);
    EXPECT_NEAR(shape.LargestDihedralCosine, cosine, tolerance);
    EXPECT_EQ(
      Measure<Dim>(x).MinDihedralDegrees, stm::DihedralDegrees(shape.LargestDihedralCosine));
    // The bounds test decides only what the measure confirms, also right at the figures.
    for (const double scale : { 1.0, 1.0 + 1e-13, 1.0 + 1e-9, 1.5 })
    {
      const double maxCondition = shape.Condition * scale;
      const double maxCosine = std::min(1.0, std::max(0.0, shape.LargestDihedralCosine) * scale);
      if (stm::SimplexSurelyWithin<Dim>(corners, maxCondition, maxCosine))
      {
        EXPECT_LE(shape.Condition, maxCondition);
        EXPECT_LE(shape.LargestDihedralCosine, maxCosine);
        sure += scale == 1.5;
      }
      else
      {
        EXPECT_NE(scale, 1.5) << "a clear case undecided";
      }
    }
    ++checked;
  }
  EXPECT_GT(checked, 5000);
  EXPECT_EQ(sure, checked);
}

// SimplexCondition is MeasureSimplex's condition number, bit for bit, inverted and flat
// simplices included.
template <int Dim>
void CheckConditionAlone()
{
  std::mt19937 random(17);
  int inverted = 0;
  for (int trial = 0; trial < 5000; ++trial)
  {
    double x[Dim + 1][Dim];
    const double* corners[Dim + 1];
    RandomSimplex<Dim>(random, x, corners);
    if (trial % 100 == 0)
    {
      std::copy(x[0], x[0] + Dim, x[1]); // flat
    }
    const double condition = stm::SimplexCondition<Dim>(corners);
    const stm::SimplexShape<Dim> shape = stm::MeasureSimplex<Dim>(corners);
    ASSERT_EQ(condition, shape.Condition) << "trial " << trial;
    inverted += std::isinf(condition) ? 1 : 0;
  }
  EXPECT_GT(inverted, 500);
}

TEST(SimplexQuality, ConditionAloneIsTheMeasuresCondition)
{
  CheckConditionAlone<1>();
  CheckConditionAlone<2>();
  CheckConditionAlone<3>();
  CheckConditionAlone<4>();
}

TEST(SimplexQuality, ClosedFormsAgreeWithTheGramMatrix)
{
  CheckClosedForms<2>();
  CheckClosedForms<3>();
}

// Moves of the corners whose lengths add up to the slack keep a simplex surely within the
// bounds: every corner moved at random with the slack shared at random, and all of it on one
// corner.
template <int Dim>
void CheckSlack()
{
  constexpr double MaxCondition = 3.5;
  const double maxCosine = std::cos(15.0 * 3.14159265358979323846 / 180.0);
  std::mt19937 random(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> gaussian;
  int withSlack = 0;
  for (int trial = 0; trial < 20000; ++trial)
  {
    double x[Dim + 1][Dim];
    const double* corners[Dim + 1];
    RandomSimplex<Dim>(random, x, corners);
    const double slack = stm::SimplexSlack<Dim>(corners, MaxCondition, maxCosine);
    ASSERT_EQ(slack >= 0.0, stm::SimplexSurelyWithin<Dim>(corners, MaxCondition, maxCosine));
    if (slack <= 0.0)
    {
      continue;
    }
    ++withSlack;
    for (int move = 0; move < 20; ++move)
    {
      double weights[Dim + 1], total = 0.0;
      for (int v = 0; v <= Dim; ++v)
      {
        weights[v] = move < Dim + 1 ? (v == move ? 1.0 : 0.0) : unit(random);
        total += weights[v];
      }
      double moved[Dim + 1][Dim];
      const double* movedCorners[Dim + 1];
      for (int v = 0; v <= Dim; ++v)
      {
        double direction[Dim], length = 0.0;
        for (double& c : direction)
        {
          c = gaussian(random);
          length += c * c;
        }
        length = std::sqrt(length);
        for (int c = 0; c < Dim; ++c)
        {
          moved[v][c] = x[v][c] + slack * weights[v] / total * direction[c] / length;
        }
        movedCorners[v] = moved[v];
      }
      ASSERT_TRUE(stm::SimplexSurelyWithin<Dim>(movedCorners, MaxCondition, maxCosine))
        << "trial " << trial << ", move " << move << ", slack " << slack;
    }
  }
  EXPECT_GT(withSlack, 500);
}

// The slack against the moves that hurt most to first order: each corner alone, or the
// corners together with the slack shared, along the gradients (by central differences) of the
// condition number, of the largest dihedral cosine and of minus the determinant. Simplices at
// random and the regular one jittered, so that many lie close to the bounds.
template <int Dim>
void CheckSlackAgainstGradients()
{
  constexpr double MaxCondition = 3.5;
  const double maxCosine = std::cos(15.0 * 3.14159265358979323846 / 180.0);
  std::mt19937 random(17);
  std::uniform_real_distribution<double> jitter(-0.35, 0.35);
  // Unit edges: the triangle, and the tetrahedron over it.
  const double h = std::sqrt(3.0) / 2.0;
  const double regular[4][3] = { { 0, 0, 0 }, { 1, 0, 0 }, { 0.5, h, 0 },
    { 0.5, h / 3.0, std::sqrt(2.0 / 3.0) } };
  int withSlack = 0;
  for (int trial = 0; trial < 6000; ++trial)
  {
    double x[Dim + 1][Dim];
    const double* corners[Dim + 1];
    if (trial % 2 == 0)
    {
      RandomSimplex<Dim>(random, x, corners);
    }
    else
    {
      for (int v = 0; v <= Dim; ++v)
      {
        for (int c = 0; c < Dim; ++c)
        {
          x[v][c] = regular[v][c] + jitter(random);
        }
        corners[v] = x[v];
      }
    }
    const double slack = stm::SimplexSlack<Dim>(corners, MaxCondition, maxCosine);
    if (slack <= 0.0)
    {
      continue;
    }
    ++withSlack;
    // The gradients of the three figures in each corner.
    constexpr int Figures = 3;
    double gradients[Figures][Dim + 1][Dim];
    auto figure = [&](int which)
    {
      const stm::SimplexCosines shape = stm::MeasureSimplexCosines<Dim>(corners);
      return which == 0 ? shape.Condition
        : which == 1    ? shape.LargestDihedralCosine
                        : -shape.Determinant;
    };
    for (int which = 0; which < Figures; ++which)
    {
      for (int v = 0; v <= Dim; ++v)
      {
        for (int c = 0; c < Dim; ++c)
        {
          const double step = 1e-6, kept = x[v][c];
          x[v][c] = kept + step;
          const double above = figure(which);
          x[v][c] = kept - step;
          const double below = figure(which);
          x[v][c] = kept;
          gradients[which][v][c] = (above - below) / (2.0 * step);
        }
      }
    }
    for (int which = 0; which < Figures; ++which)
    {
      // Moves 0 to Dim: that corner alone; move Dim + 1: every corner, the slack shared.
      for (int move = 0; move <= Dim + 1; ++move)
      {
        double moved[Dim + 1][Dim];
        const double* movedCorners[Dim + 1];
        for (int v = 0; v <= Dim; ++v)
        {
          const double share = move == Dim + 1 ? 1.0 / (Dim + 1) : (v == move ? 1.0 : 0.0);
          double length = 0.0;
          for (int c = 0; c < Dim; ++c)
          {
            length += gradients[which][v][c] * gradients[which][v][c];
          }
          length = std::sqrt(length);
          for (int c = 0; c < Dim; ++c)
          {
            moved[v][c] =
              x[v][c] + (length > 0.0 ? slack * share * gradients[which][v][c] / length : 0.0);
          }
          movedCorners[v] = moved[v];
        }
        ASSERT_TRUE(stm::SimplexSurelyWithin<Dim>(movedCorners, MaxCondition, maxCosine))
          << "trial " << trial << ", figure " << which << ", move " << move << ", slack " << slack;
      }
    }
  }
  EXPECT_GT(withSlack, 1000);
}

TEST(SimplexQuality, SlackHoldsAlongTheGradients)
{
  CheckSlackAgainstGradients<2>();
  CheckSlackAgainstGradients<3>();
}

TEST(SimplexQuality, SlackKeepsTheSimplexWithinTheBounds)
{
  CheckSlack<2>();
  CheckSlack<3>();
  // Segments and 4-simplices have no closed forms: never a slack.
  const double segment[2][1] = { { 0.0 }, { 1.0 } };
  const double* segmentCorners[2] = { segment[0], segment[1] };
  EXPECT_EQ(stm::SimplexSlack<1>(segmentCorners, 3.5, 0.9), -1.0);
}

TEST(SimplexQuality, SlackOfRegularSimplices)
{
  // Unit edges, the smoother's default bounds: the slack is a sizeable part of an edge (what
  // lets the smoother skip most measures), and below the distance that breaks the bounds. The
  // bounds that take one corner's move at a time give 0.354, 0.322 and 0.260 below; taking each
  // edge as changing on its own gave 0.223, 0.134 and 0.135.
  const double maxCosine = std::cos(15.0 * 3.14159265358979323846 / 180.0);
  const double h = std::sqrt(3.0) / 2.0;
  const double triangle[3][2] = { { 0, 0 }, { 1, 0 }, { 0.5, h } };
  const double* triangleCorners[3] = { triangle[0], triangle[1], triangle[2] };
  const double triangleSlack = stm::SimplexSlack<2>(triangleCorners, 3.5, maxCosine);
  EXPECT_GT(triangleSlack, 0.35);
  EXPECT_LT(triangleSlack, h);
  const double tetrahedron[4][3] = { { 0, 0, 0 }, { 1, 0, 0 }, { 0.5, h, 0 },
    { 0.5, h / 3.0, std::sqrt(2.0 / 3.0) } };
  const double* tetrahedronCorners[4] = { tetrahedron[0], tetrahedron[1], tetrahedron[2],
    tetrahedron[3] };
  const double tetrahedronSlack = stm::SimplexSlack<3>(tetrahedronCorners, 3.5, maxCosine);
  EXPECT_GT(tetrahedronSlack, 0.32);
  EXPECT_LT(tetrahedronSlack, std::sqrt(2.0 / 3.0));
  // The checkerboard's corner tetrahedron (right angles at the origin): the lead of its
  // smallest angles (between the slanted face and the others) is shared by turn rate, so the
  // slanted face, whose normal turns slowest, takes the smaller share.
  const double corner[4][3] = { { 0, 0, 0 }, { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 } };
  const double* cornerCorners[4] = { corner[0], corner[1], corner[2], corner[3] };
  EXPECT_GT(stm::SimplexSlack<3>(cornerCorners, 3.5, maxCosine), 0.25);
  // At the bounds themselves, no slack is left.
  const stm::SimplexCosines shape = stm::MeasureSimplexCosines<3>(tetrahedronCorners);
  EXPECT_EQ(
    stm::SimplexSlack<3>(tetrahedronCorners, shape.Condition * (1.0 + 1e-10), maxCosine), 0.0);
}

} // namespace
