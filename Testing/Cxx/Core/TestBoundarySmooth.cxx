// SPDX-License-Identifier: BSD-3-Clause
// Boundary smoothing in 2D and 3D on a ball cut by marching simplices from a uniform
// tessellation, and on a staircase two-material ball: no inverted cell after any number of
// iterations, Taubin keeps the volume and Laplacian shrinks it, the worst element never gets
// worse, the background box stays bit-identical, MaxDisplacement and the projector hold, the
// result does not depend on the threads, and the staircase gets smoother. 1D and 4D: the
// dimension-generic code on small meshes.

#include "CoreTestUtilities.h"

#include "Check/MeshInvariants.h"
#include "Check/SimplexQuality.h"
#include "Common/Execution.h"
#include "Cut/LevelSetProjection.h"
#include "Cut/MarchingSimplices.h"
#include "Smooth/BoundarySmooth.h"
#include "Spacetree/RootPieces.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <iostream>
#include <map>
#include <numeric>
#include <random>
#include <vector>

namespace
{
using namespace stmtest;

constexpr double Pi = 3.14159265358979323846;

template <int D>
struct SmoothMesh
{
  std::vector<double> Points;
  std::vector<std::int64_t> Cells;
  std::vector<std::int64_t> Materials;
  double Centre[D];
  double Radius = 0.0;
  std::int64_t Extent = 0;

  std::int64_t NumberOfPoints() const { return static_cast<std::int64_t>(this->Points.size()) / D; }
  std::int64_t NumberOfCells() const
  {
    return static_cast<std::int64_t>(this->Cells.size()) / (D + 1);
  }
};

/// The uniform tessellation (2 triangles, 5 tetrahedra per voxel) of [0, extent]^D.
template <int D>
SimplicialMesh<D> UniformMesh(std::int64_t extent, const LabelImage<D>& image, bool background)
{
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  EXPECT_TRUE(BuildTree<D>(image, 1, 0, false, executor, tree).IsOk());
  stm::SpacetreeTessellationOptions options;
  options.IncludeBackground = background;
  options.Template = D == 4 ? stm::CellTemplate::Kuhn : stm::CellTemplate::Checkerboard;
  SimplicialMesh<D> mesh;
  const stm::Status status = TessellateTree<D>(tree, options, executor, mesh);
  EXPECT_TRUE(status.IsOk()) << status.GetMessage();
  // The uniform templates insert no point.
  EXPECT_EQ(mesh.GetNumberOfPoints(), static_cast<std::int64_t>(std::pow(extent + 1, D)));
  return mesh;
}

/// Cuts a uniform mesh at the zero of point values: material 1 inside, 0 (the background)
/// outside; cells with only zero points keep the side of their material.
template <int D>
void CutMesh(const SimplicialMesh<D>& mesh, const std::vector<double>& values, SmoothMesh<D>& out)
{
  stm::SequentialExecutor executor;
  auto allZeroSide = [&](std::int64_t cell)
  { return mesh.Materials[cell] == 0 ? stm::CutSide::Outside : stm::CutSide::Inside; };
  const CutResult<D> cut = Cut<D>(mesh.Coordinates(), values, mesh.Connectivity,
    stm::MarchingSimplicesOptions(), executor, allZeroSide);
  EXPECT_TRUE(cut.Result.IsOk());
  out.Cells = cut.Connectivity;
  out.Points = cut.Coordinates;
  for (const std::uint8_t side : cut.Sides)
  {
    out.Materials.push_back(side == static_cast<std::uint8_t>(stm::CutSide::Inside) ? 1 : 0);
  }
}

/// The ball of radius `fraction` * extent around the box centre (shifted off the lattice),
/// cut from the uniform mesh at the analytic function.
template <int D>
SmoothMesh<D> CutBall(std::int64_t extent, double fraction)
{
  LabelImage<D> image(UniformExtents<D>(extent));
  std::fill(image.GetValues().begin(), image.GetValues().end(), stm::MaterialIndex{ 1 });
  const SimplicialMesh<D> mesh = UniformMesh<D>(extent, image, false);
  SmoothMesh<D> ball;
  ball.Extent = extent;
  ball.Radius = fraction * static_cast<double>(extent);
  for (int axis = 0; axis < D; ++axis)
  {
    ball.Centre[axis] = 0.5 * static_cast<double>(extent) + 0.05 * (axis + 1);
  }
  const std::vector<double> coordinates = mesh.Coordinates();
  std::vector<double> values(static_cast<std::size_t>(mesh.GetNumberOfPoints()));
  for (std::size_t p = 0; p < values.size(); ++p)
  {
    double r2 = 0.0;
    for (int axis = 0; axis < D; ++axis)
    {
      r2 += (coordinates[p * D + axis] - ball.Centre[axis]) *
        (coordinates[p * D + axis] - ball.Centre[axis]);
    }
    values[p] = r2 - ball.Radius * ball.Radius;
  }
  CutMesh<D>(mesh, values, ball);
  return ball;
}

/// The staircase ball: voxels whose centre lies within the radius are material 1, the others
/// the background, tessellated together (no cut).
template <int D>
SmoothMesh<D> StaircaseBall(std::int64_t extent, double fraction, bool labelsFunction)
{
  LabelImage<D> image(UniformExtents<D>(extent));
  SmoothMesh<D> ball;
  ball.Extent = extent;
  ball.Radius = fraction * static_cast<double>(extent);
  for (int axis = 0; axis < D; ++axis)
  {
    ball.Centre[axis] = 0.5 * static_cast<double>(extent);
  }
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      double r2 = 0.0;
      for (int axis = 0; axis < D; ++axis)
      {
        const double x = static_cast<double>(voxel[axis]) + 0.5 - ball.Centre[axis];
        r2 += x * x;
      }
      image.Set(voxel, r2 <= ball.Radius * ball.Radius ? 1 : 0);
    });
  const SimplicialMesh<D> mesh = UniformMesh<D>(extent, image, true);
  if (!labelsFunction)
  {
    ball.Points = mesh.Coordinates();
    ball.Cells = mesh.Connectivity;
    ball.Materials = mesh.MaterialsAsInt64();
    return ball;
  }
  // The labels function (paper 3.1): at a voxel corner, the mean of the body indicator (-1
  // body, +1 background) of the 2^D voxels around it.
  std::vector<double> values(static_cast<std::size_t>(mesh.GetNumberOfPoints()));
  for (std::size_t p = 0; p < values.size(); ++p)
  {
    const stm::LatticeIndex<D>& corner = mesh.HalfUnitPoints[p];
    double sum = 0.0;
    for (int k = 0; k < (1 << D); ++k)
    {
      stm::LatticeIndex<D> voxel;
      for (int axis = 0; axis < D; ++axis)
      {
        voxel[axis] = corner[axis] / 2 - ((k >> axis) & 1);
      }
      sum += image.At(voxel) == 1 ? -1.0 : 1.0;
    }
    values[p] = sum / (1 << D);
  }
  CutMesh<D>(mesh, values, ball);
  return ball;
}

template <int D>
stm::MeshInvariantReport Check(const SmoothMesh<D>& mesh)
{
  return stm::CheckSimplicialMesh<D>(mesh.Points, mesh.Cells, &mesh.Materials);
}

template <int D, class Executor>
stm::BoundarySmoothStats Smooth(SmoothMesh<D>& mesh, const stm::BoundarySmoothOptions& options,
  Executor& executor, std::vector<std::uint8_t>* roles = nullptr)
{
  stm::BoundarySmoother<D> smoother;
  const stm::Status status = smoother.Smooth(mesh.Points.data(), mesh.NumberOfPoints(),
    mesh.Cells.data(), mesh.NumberOfCells(), mesh.Materials.data(), options, executor);
  EXPECT_TRUE(status.IsOk()) << status.GetMessage();
  if (roles)
  {
    *roles = smoother.GetPointRoles();
  }
  return smoother.GetStats();
}

template <int D>
stm::BoundarySmoothStats Smooth(SmoothMesh<D>& mesh, const stm::BoundarySmoothOptions& options,
  std::vector<std::uint8_t>* roles = nullptr)
{
  stm::SequentialExecutor executor;
  return Smooth<D>(mesh, options, executor, roles);
}

/// Worst condition number and smallest dihedral angle, measured independently of the stats.
template <int D>
std::pair<double, double> Quality(const SmoothMesh<D>& mesh)
{
  double worst = 0.0, smallest = 180.0;
  for (std::int64_t c = 0; c < mesh.NumberOfCells(); ++c)
  {
    const double* corners[D + 1];
    for (int v = 0; v <= D; ++v)
    {
      corners[v] = mesh.Points.data() + mesh.Cells[c * (D + 1) + v] * D;
    }
    const stm::SimplexShape<D> shape = stm::MeasureSimplex<D>(corners);
    worst = std::max(worst, shape.Condition);
    smallest = std::min(smallest, shape.MinDihedralDegrees);
  }
  return { worst, smallest };
}

/// Measure of the interface between material 1 and the rest (length in 2D, area in 3D).
template <int D>
double InterfaceMeasure(const SmoothMesh<D>& mesh)
{
  std::map<std::vector<std::int64_t>, int> facets;
  for (std::int64_t c = 0; c < mesh.NumberOfCells(); ++c)
  {
    if (mesh.Materials[c] != 1)
    {
      continue;
    }
    for (int i = 0; i <= D; ++i)
    {
      std::vector<std::int64_t> facet;
      for (int v = 0; v <= D; ++v)
      {
        if (v != i)
        {
          facet.push_back(mesh.Cells[c * (D + 1) + v]);
        }
      }
      std::sort(facet.begin(), facet.end());
      ++facets[facet];
    }
  }
  double measure = 0.0;
  for (const auto& facet : facets)
  {
    if (facet.second != 1)
    {
      continue;
    }
    const double* a = mesh.Points.data() + facet.first[0] * D;
    const double* b = mesh.Points.data() + facet.first[1] * D;
    if (D == 2)
    {
      measure += std::hypot(b[0] - a[0], b[1] - a[1]);
    }
    else
    {
      const double* c = mesh.Points.data() + facet.first[2] * D;
      const double u[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] };
      const double w[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
      const double n[3] = { u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
        u[0] * w[1] - u[1] * w[0] };
      measure += 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    }
  }
  return measure;
}

template <int D>
double SphereMeasure(double radius)
{
  return D == 2 ? 2.0 * Pi * radius : 4.0 * Pi * radius * radius;
}

template <int D>
std::int64_t Extent()
{
  return D == 2 ? 32 : 20;
}

template <class T>
class BoundarySmoothTest : public ::testing::Test
{
};
using SmoothDimensions = ::testing::Types<Dim<2>, Dim<3>>;
TYPED_TEST_SUITE(BoundarySmoothTest, SmoothDimensions);

// No inverted cell after any iteration count, for both methods; the box's volume (the sum of
// all cells) is kept, and the worst element is never worse than the input's.
TYPED_TEST(BoundarySmoothTest, NoInvertedCellAndNoWorseElementAfterAnyIterationCount)
{
  constexpr int D = TypeParam::value;
  const SmoothMesh<D> input = CutBall<D>(Extent<D>(), 0.35);
  const stm::MeshInvariantReport before = Check<D>(input);
  ASSERT_TRUE(before.IsValid()) << before.Summary();
  const auto qualityBefore = Quality<D>(input);
  for (const auto method : { stm::SmoothingMethod::Taubin, stm::SmoothingMethod::Laplacian })
  {
    for (const int iterations : { 1, 2, 5, 20, 40 })
    {
      SmoothMesh<D> mesh = input;
      stm::BoundarySmoothOptions options;
      options.Method = method;
      options.NumberOfIterations = iterations;
      const stm::BoundarySmoothStats stats = Smooth<D>(mesh, options);
      const stm::MeshInvariantReport report = Check<D>(mesh);
      EXPECT_TRUE(report.IsValid()) << iterations << " iterations: " << report.Summary();
      EXPECT_GT(report.MinimumVolume, 0.0);
      EXPECT_NEAR(report.TotalVolume, before.TotalVolume, 1e-9 * before.TotalVolume);
      const auto quality = Quality<D>(mesh);
      EXPECT_LE(quality.first, qualityBefore.first) << iterations << " iterations";
      EXPECT_GE(quality.second, qualityBefore.second) << iterations << " iterations";
      EXPECT_EQ(stats.WorstConditionBefore, qualityBefore.first);
      EXPECT_EQ(stats.WorstConditionAfter, quality.first);
      EXPECT_EQ(stats.MinDihedralAfter, quality.second);
      EXPECT_GT(stats.MovedPoints, 0);
      EXPECT_EQ(stats.SurfacePoints + stats.FixedPoints + stats.InteriorLayerPoints <=
          mesh.NumberOfPoints(),
        true);
    }
  }
}

// The ball after 20 iterations: Taubin keeps the inside volume within 0.5%, Laplacian shrinks
// it by clearly more.
TYPED_TEST(BoundarySmoothTest, TaubinKeepsTheVolumeAndLaplacianShrinksIt)
{
  constexpr int D = TypeParam::value;
  const SmoothMesh<D> input = CutBall<D>(Extent<D>(), 0.35);
  const double inside = Check<D>(input).VolumePerMaterial.at(1);
  SmoothMesh<D> taubin = input, laplacian = input;
  stm::BoundarySmoothOptions options;
  const stm::BoundarySmoothStats taubinStats = Smooth<D>(taubin, options);
  options.Method = stm::SmoothingMethod::Laplacian;
  const stm::BoundarySmoothStats laplacianStats = Smooth<D>(laplacian, options);
  const double taubinInside = Check<D>(taubin).VolumePerMaterial.at(1);
  const double laplacianInside = Check<D>(laplacian).VolumePerMaterial.at(1);
  EXPECT_NEAR(taubinStats.VolumeAfter.at(1), taubinInside, 1e-9 * inside);
  EXPECT_NEAR(taubinStats.VolumeBefore.at(1), inside, 1e-9 * inside);
  const double taubinChange = (taubinInside - inside) / inside;
  const double laplacianChange = (laplacianInside - inside) / inside;
  std::cout << D << "D ball, 20 iterations: inside " << inside << ", Taubin " << taubinInside
            << " (" << 100 * taubinChange << " %, " << taubinStats.MovedPoints << " moved, "
            << taubinStats.RejectedMoves << " rejected), Laplacian " << laplacianInside << " ("
            << 100 * laplacianChange << " %, " << laplacianStats.MovedPoints << " moved, "
            << laplacianStats.RejectedMoves << " rejected)\n";
  EXPECT_LT(std::abs(taubinChange), 0.005);
  EXPECT_LT(laplacianChange, -0.01);
  EXPECT_LT(laplacianChange, -4.0 * std::abs(taubinChange));
  EXPECT_EQ(std::abs(stm::BoundarySmoother<D>::TaubinMu(0.5, 0.1) + 1.0 / 1.9) < 1e-15, true);
}

// The outer-boundary points of background cells (the box) do not move, bit for bit, and are
// the fixed points (without small parts, whose kept interior points are fixed too); every
// surface point lies at the ball's radius within a cell size.
TYPED_TEST(BoundarySmoothTest, BackgroundBoxStaysBitIdentical)
{
  constexpr int D = TypeParam::value;
  const SmoothMesh<D> input = CutBall<D>(Extent<D>(), 0.35);
  SmoothMesh<D> mesh = input;
  std::vector<std::uint8_t> roles;
  stm::BoundarySmoothOptions options;
  options.SmallPartPoints = 0;
  const stm::BoundarySmoothStats stats = Smooth<D>(mesh, options, &roles);
  std::int64_t onBox = 0;
  for (std::int64_t p = 0; p < mesh.NumberOfPoints(); ++p)
  {
    bool boundary = false;
    for (int axis = 0; axis < D; ++axis)
    {
      const double x = input.Points[p * D + axis];
      boundary = boundary || x == 0.0 || x == static_cast<double>(input.Extent);
    }
    if (boundary)
    {
      ++onBox;
      EXPECT_EQ(roles[p], stm::BoundarySmoother<D>::Fixed);
      EXPECT_EQ(std::memcmp(&mesh.Points[p * D], &input.Points[p * D], sizeof(double) * D), 0);
    }
    if (roles[p] == stm::BoundarySmoother<D>::Surface)
    {
      double r2 = 0.0;
      for (int axis = 0; axis < D; ++axis)
      {
        r2 += std::pow(mesh.Points[p * D + axis] - input.Centre[axis], 2);
      }
      EXPECT_NEAR(std::sqrt(r2), input.Radius, 0.5);
    }
  }
  EXPECT_EQ(stats.FixedPoints, onBox);
  EXPECT_EQ(onBox,
    static_cast<std::int64_t>(std::pow(input.Extent + 1, D) - std::pow(input.Extent - 1, D)));
}

// MaxDisplacement bounds every point's distance from its original position.
TYPED_TEST(BoundarySmoothTest, MaxDisplacementIsRespected)
{
  constexpr int D = TypeParam::value;
  const SmoothMesh<D> input = CutBall<D>(Extent<D>(), 0.35);
  SmoothMesh<D> mesh = input;
  stm::BoundarySmoothOptions options;
  options.Method = stm::SmoothingMethod::Laplacian;
  options.MaxDisplacement = 0.05;
  Smooth<D>(mesh, options);
  double largest = 0.0;
  for (std::int64_t p = 0; p < mesh.NumberOfPoints(); ++p)
  {
    double d2 = 0.0;
    for (int axis = 0; axis < D; ++axis)
    {
      d2 += std::pow(mesh.Points[p * D + axis] - input.Points[p * D + axis], 2);
    }
    largest = std::max(largest, std::sqrt(d2));
  }
  EXPECT_LE(largest, 0.05 * (1 + 1e-12));
  EXPECT_GT(largest, 0.04); // the bound is what limits Laplacian here
}

// Held points (a piece's ghost points) stay bit for bit, and the others are smoothed as usual
// next to them: points on both sides of the plane x = centre move without them.
TYPED_TEST(BoundarySmoothTest, HeldPointsStayWhereTheyAre)
{
  constexpr int D = TypeParam::value;
  const SmoothMesh<D> input = CutBall<D>(Extent<D>(), 0.35);
  std::vector<std::uint8_t> held(static_cast<std::size_t>(input.NumberOfPoints()), 0);
  for (std::int64_t p = 0; p < input.NumberOfPoints(); ++p)
  {
    held[p] = input.Points[p * D] < input.Centre[0] ? 1 : 0;
  }
  SmoothMesh<D> free = input;
  stm::BoundarySmoothOptions options;
  Smooth<D>(free, options);
  SmoothMesh<D> mesh = input;
  options.HeldPoints = held.data();
  std::vector<std::uint8_t> roles;
  const stm::BoundarySmoothStats stats = Smooth<D>(mesh, options, &roles);
  std::int64_t movedHeld = 0, movedOther = 0, movedWithoutHolding = 0;
  for (std::int64_t p = 0; p < input.NumberOfPoints(); ++p)
  {
    const bool moved = !std::equal(
      mesh.Points.begin() + p * D, mesh.Points.begin() + (p + 1) * D, input.Points.begin() + p * D);
    const bool movedFree = !std::equal(
      free.Points.begin() + p * D, free.Points.begin() + (p + 1) * D, input.Points.begin() + p * D);
    movedHeld += held[p] && moved;
    movedOther += !held[p] && moved;
    movedWithoutHolding += held[p] && movedFree;
    if (held[p])
    {
      EXPECT_EQ(roles[p], stm::BoundarySmoother<D>::Fixed);
    }
  }
  EXPECT_EQ(movedHeld, 0);
  EXPECT_GT(movedOther, 10);
  EXPECT_GT(movedWithoutHolding, 10); // the held half would have moved
  EXPECT_GE(stats.FixedPoints,
    static_cast<std::int64_t>(std::count(held.begin(), held.end(), std::uint8_t{ 1 })));
  const stm::MeshInvariantReport report = Check<D>(mesh);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
}

// A piece's ghost cells (GhostCells) leave the quality bounds, the reported extremes and the
// volumes to the other cells: all of them marked leave no extremes and no volumes at all, half
// of them no worse extremes and a part of the volume.
TYPED_TEST(BoundarySmoothTest, GhostCellsDoNotSetTheBounds)
{
  constexpr int D = TypeParam::value;
  const SmoothMesh<D> input = CutBall<D>(Extent<D>(), 0.35);
  stm::BoundarySmoothOptions options;
  SmoothMesh<D> whole = input;
  const stm::BoundarySmoothStats wholeStats = Smooth<D>(whole, options);
  ASSERT_GT(wholeStats.WorstConditionBefore, 1.0);

  std::vector<std::uint8_t> allGhosts(static_cast<std::size_t>(input.NumberOfCells()), 1);
  SmoothMesh<D> ghosts = input;
  options.GhostCells = allGhosts.data();
  const stm::BoundarySmoothStats ghostStats = Smooth<D>(ghosts, options);
  EXPECT_EQ(ghostStats.WorstConditionBefore, 0.0);
  EXPECT_EQ(ghostStats.MinDihedralBefore, 180.0);
  EXPECT_EQ(ghostStats.WorstConditionAfter, 0.0);
  EXPECT_TRUE(ghostStats.VolumeBefore.empty());
  EXPECT_TRUE(ghostStats.VolumeAfter.empty());

  std::vector<std::uint8_t> halfGhosts(static_cast<std::size_t>(input.NumberOfCells()), 0);
  for (std::int64_t c = 0; c < input.NumberOfCells(); ++c)
  {
    halfGhosts[c] = input.Points[input.Cells[c * (D + 1)] * D] < input.Centre[0] ? 1 : 0;
  }
  SmoothMesh<D> half = input;
  options.GhostCells = halfGhosts.data();
  const stm::BoundarySmoothStats halfStats = Smooth<D>(half, options);
  EXPECT_GT(halfStats.WorstConditionBefore, 1.0);
  EXPECT_LE(halfStats.WorstConditionBefore, wholeStats.WorstConditionBefore);
  EXPECT_GE(halfStats.MinDihedralBefore, wholeStats.MinDihedralBefore);
  auto total = [](const std::map<std::int64_t, double>& volumes)
  {
    double sum = 0.0;
    for (const auto& entry : volumes)
    {
      sum += entry.second;
    }
    return sum;
  };
  EXPECT_GT(total(halfStats.VolumeBefore), 0.0);
  EXPECT_LT(total(halfStats.VolumeBefore), 0.9 * total(wholeStats.VolumeBefore));
  const stm::MeshInvariantReport report = Check<D>(half);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
}

// A projector onto the sphere (Newton steps, Cut/LevelSetProjection.h) puts every moved surface
// point on it; most surface points move (the others stay where a move would cost quality).
TYPED_TEST(BoundarySmoothTest, ProjectorPutsSurfacePointsOntoTheSphere)
{
  constexpr int D = TypeParam::value;
  const SmoothMesh<D> input = CutBall<D>(Extent<D>(), 0.35);
  SmoothMesh<D> mesh = input;
  const double* centre = input.Centre;
  const double radius = input.Radius;
  auto sphere = [&](const double* x, double* gradient)
  {
    double r2 = 0.0;
    for (int axis = 0; axis < D; ++axis)
    {
      gradient[axis] = 2.0 * (x[axis] - centre[axis]);
      r2 += (x[axis] - centre[axis]) * (x[axis] - centre[axis]);
    }
    return r2 - radius * radius;
  };
  stm::LevelSetProjectionOptions projection;
  projection.Tolerance = 1e-10;
  auto projector = [&](std::int64_t, double* x)
  {
    double point[D];
    std::copy(x, x + D, point);
    if (!stm::ProjectToLevelSet<D>(point, sphere, projection))
    {
      return false;
    }
    std::copy(point, point + D, x);
    return true;
  };
  stm::BoundarySmoother<D> smoother;
  stm::SequentialExecutor executor;
  ASSERT_TRUE(
    smoother
      .Smooth(mesh.Points.data(), mesh.NumberOfPoints(), mesh.Cells.data(), mesh.NumberOfCells(),
        mesh.Materials.data(), stm::BoundarySmoothOptions(), projector, executor)
      .IsOk());
  const std::vector<std::uint8_t>& roles = smoother.GetPointRoles();
  std::int64_t surface = 0, onSphere = 0;
  double before = 0.0, after = 0.0;
  for (std::int64_t p = 0; p < mesh.NumberOfPoints(); ++p)
  {
    if (roles[p] != stm::BoundarySmoother<D>::Surface)
    {
      continue;
    }
    ++surface;
    double r2 = 0.0, r2Before = 0.0;
    for (int axis = 0; axis < D; ++axis)
    {
      r2 += std::pow(mesh.Points[p * D + axis] - centre[axis], 2);
      r2Before += std::pow(input.Points[p * D + axis] - centre[axis], 2);
    }
    before = std::max(before, std::abs(std::sqrt(r2Before) - radius));
    after = std::max(after, std::abs(std::sqrt(r2) - radius));
    const bool moved = !std::equal(
      mesh.Points.begin() + p * D, mesh.Points.begin() + (p + 1) * D, input.Points.begin() + p * D);
    if (moved)
    {
      EXPECT_NEAR(std::sqrt(r2), radius, 1e-9);
      ++onSphere;
    }
  }
  std::cout << D << "D ball with projection: " << onSphere << " of " << surface
            << " surface points on the sphere; largest distance " << before << " -> " << after
            << "\n";
  EXPECT_GT(onSphere, surface * 8 / 10);
  EXPECT_EQ(Check<D>(mesh).IsValid(), true);
}

// The same bytes for 1 thread and a pool of 4, for both methods and with interior layers.
TYPED_TEST(BoundarySmoothTest, ThreadCountDoesNotChangeTheResult)
{
  constexpr int D = TypeParam::value;
  const SmoothMesh<D> input = CutBall<D>(Extent<D>(), 0.35);
  for (const auto method : { stm::SmoothingMethod::Taubin, stm::SmoothingMethod::Laplacian })
  {
    stm::BoundarySmoothOptions options;
    options.Method = method;
    options.NumberOfInteriorLayers = 3;
    SmoothMesh<D> sequential = input, pooled = input;
    stm::SequentialExecutor one;
    stm::ThreadPoolExecutor four(4);
    const stm::BoundarySmoothStats a = Smooth<D>(sequential, options, one);
    const stm::BoundarySmoothStats b = Smooth<D>(pooled, options, four);
    EXPECT_EQ(std::memcmp(sequential.Points.data(), pooled.Points.data(),
                sequential.Points.size() * sizeof(double)),
      0);
    EXPECT_EQ(a.MovedPoints, b.MovedPoints);
    EXPECT_EQ(a.RejectedMoves, b.RejectedMoves);
    EXPECT_EQ(a.VolumeAfter, b.VolumeAfter);
  }
}

/// Per cell, the root colour (stm::RootColouring) of the cube of `rootEdge` voxels that holds
/// its centroid: the cells of CutBall lie in voxels, so such cubes serve as root cells.
template <int D>
std::vector<std::uint8_t> CubeColours(const SmoothMesh<D>& mesh, double rootEdge)
{
  std::vector<std::uint8_t> colours;
  for (std::int64_t c = 0; c < mesh.NumberOfCells(); ++c)
  {
    stm::LatticeIndex<D> root;
    for (int axis = 0; axis < D; ++axis)
    {
      double centroid = 0.0;
      for (int v = 0; v <= D; ++v)
      {
        centroid += mesh.Points[mesh.Cells[c * (D + 1) + v] * D + axis] / (D + 1);
      }
      root[axis] = static_cast<std::int64_t>(std::floor(centroid / rootEdge));
    }
    colours.push_back(stm::RootColouring<D>::Colour(root));
  }
  return colours;
}

// With root colours the blocks are the points of one colour joined by shared cells, each in one
// root cell, 3^D colours; the result still does not depend on the number of threads, for root
// cells of one voxel (many small blocks) and of four (few large ones), and the mesh stays valid
// with the same volumes as with blocks of consecutive ids, to the volume restoration's tolerance.
TYPED_TEST(BoundarySmoothTest, RootCellBlocksDoNotDependOnTheThreads)
{
  constexpr int D = TypeParam::value;
  const SmoothMesh<D> input = CutBall<D>(Extent<D>(), 0.35);
  SmoothMesh<D> byIds = input;
  const stm::BoundarySmoothStats idStats = Smooth<D>(byIds, stm::BoundarySmoothOptions());
  EXPECT_FALSE(idStats.RootCellBlocks);
  for (const double rootEdge : { 1.0, 4.0 })
  {
    const std::vector<std::uint8_t> colours = CubeColours<D>(input, rootEdge);
    stm::BoundarySmoothOptions options;
    options.NumberOfInteriorLayers = 3;
    options.CellRootColours = colours.data();
    SmoothMesh<D> sequential = input, pooled = input;
    stm::SequentialExecutor one;
    stm::ThreadPoolExecutor four(4);
    const stm::BoundarySmoothStats a = Smooth<D>(sequential, options, one);
    const stm::BoundarySmoothStats b = Smooth<D>(pooled, options, four);
    EXPECT_TRUE(a.RootCellBlocks);
    EXPECT_EQ(a.NumberOfColours, stm::RootColouring<D>::NumberOfColours);
    EXPECT_EQ(std::memcmp(sequential.Points.data(), pooled.Points.data(),
                sequential.Points.size() * sizeof(double)),
      0)
      << "root edge " << rootEdge;
    EXPECT_EQ(a.MovedPoints, b.MovedPoints);
    EXPECT_GT(a.MovedPoints, idStats.MovedPoints / 2);
    EXPECT_EQ(a.RejectedMoves, b.RejectedMoves);
    EXPECT_EQ(a.VolumeAfter, b.VolumeAfter);
    EXPECT_TRUE(Check<D>(sequential).IsValid());
    EXPECT_NE(sequential.Points, byIds.Points); // another order of the moves
  }
}

// The interior layers are relaxed after every InteriorRelaxationInterval-th iteration and after
// the last: 20 iterations make 20, 5 (4, 8, ..., 20) and 7 (3, 6, ..., 18, 20) passes at
// intervals 1, 4 and 3, and one pass (after the last) at an interval beyond the iteration
// count, which for a single iteration is the interval-1 result bit for bit. Fewer passes leave
// other points; without interior layers there is no pass.
TYPED_TEST(BoundarySmoothTest, InteriorLayersAreRelaxedEveryIntervalAndAfterTheLastIteration)
{
  constexpr int D = TypeParam::value;
  const SmoothMesh<D> input = CutBall<D>(Extent<D>(), 0.35);
  auto run = [&](int iterations, int interval, int layers, SmoothMesh<D>& mesh)
  {
    stm::BoundarySmoothOptions options;
    options.NumberOfIterations = iterations;
    options.InteriorRelaxationInterval = interval;
    options.NumberOfInteriorLayers = layers;
    mesh = input;
    return Smooth<D>(mesh, options).InteriorRelaxations;
  };
  SmoothMesh<D> a, b;
  EXPECT_EQ(run(20, 1, 2, a), 20);
  EXPECT_EQ(run(20, 4, 2, b), 5);
  EXPECT_NE(a.Points, b.Points);
  EXPECT_EQ(run(20, 3, 2, b), 7);
  EXPECT_EQ(run(20, 25, 2, b), 1);
  EXPECT_EQ(run(20, 4, 0, b), 0);
  EXPECT_EQ(run(1, 1, 2, a), 1);
  EXPECT_EQ(run(1, 9, 2, b), 1);
  EXPECT_EQ(a.Points, b.Points);
  EXPECT_EQ(Check<D>(b).IsValid(), true);
}

// A perfect staircase cannot move: every move of a surface point would make some incident
// simplex worse than the input's worst (1.15 in 2D, 1.22 in 3D), which bounds every move.
TYPED_TEST(BoundarySmoothTest, PerfectStaircaseStays)
{
  constexpr int D = TypeParam::value;
  const SmoothMesh<D> input = StaircaseBall<D>(Extent<D>(), 0.3, false);
  SmoothMesh<D> mesh = input;
  const stm::BoundarySmoothStats stats = Smooth<D>(mesh, stm::BoundarySmoothOptions());
  EXPECT_EQ(stats.MovedPoints, 0);
  EXPECT_GT(stats.RejectedMoves, 0);
  EXPECT_EQ(mesh.Points, input.Points);
}

/// Root mean square deviation of the interface points' distance from the ball's centre from
/// its mean: zero on a sphere, the bumps of a staircase otherwise.
template <int D>
double RadialRoughness(const SmoothMesh<D>& mesh, const std::vector<std::uint8_t>& roles)
{
  std::vector<double> radii;
  for (std::int64_t p = 0; p < mesh.NumberOfPoints(); ++p)
  {
    if (roles[p] == stm::BoundarySmoother<D>::Surface)
    {
      double r2 = 0.0;
      for (int axis = 0; axis < D; ++axis)
      {
        r2 += std::pow(mesh.Points[p * D + axis] - mesh.Centre[axis], 2);
      }
      radii.push_back(std::sqrt(r2));
    }
  }
  const double mean = std::accumulate(radii.begin(), radii.end(), 0.0) / radii.size();
  double sum = 0.0;
  for (const double r : radii)
  {
    sum += (r - mean) * (r - mean);
  }
  return std::sqrt(sum / radii.size());
}

// The staircase ball cut by the labels function (the default pipeline before snapping) gets
// smoother: the radial roughness of its interface points drops by more than 30%, the body
// volume stays within 2% (removing the staircase's bumps shrinks it a little), and the mesh
// stays valid with no worse element.
TYPED_TEST(BoundarySmoothTest, StaircaseSurfaceBecomesSmoother)
{
  constexpr int D = TypeParam::value;
  SmoothMesh<D> mesh = StaircaseBall<D>(Extent<D>(), 0.3, true);
  const stm::MeshInvariantReport before = Check<D>(mesh);
  ASSERT_TRUE(before.IsValid()) << before.Summary();
  const SmoothMesh<D> input = mesh;
  std::vector<std::uint8_t> roles;
  const stm::BoundarySmoothStats stats = Smooth<D>(mesh, stm::BoundarySmoothOptions(), &roles);
  const stm::MeshInvariantReport after = Check<D>(mesh);
  EXPECT_TRUE(after.IsValid()) << after.Summary();
  const double roughnessBefore = RadialRoughness<D>(input, roles);
  const double roughnessAfter = RadialRoughness<D>(mesh, roles);
  std::cout << D << "D labels-function ball: radial roughness " << roughnessBefore << " -> "
            << roughnessAfter << ", interface " << InterfaceMeasure<D>(input) << " -> "
            << InterfaceMeasure<D>(mesh) << " (sphere " << SphereMeasure<D>(mesh.Radius)
            << "), body volume " << before.VolumePerMaterial.at(1) << " -> "
            << after.VolumePerMaterial.at(1) << ", worst condition " << stats.WorstConditionBefore
            << " -> " << stats.WorstConditionAfter << ", smallest dihedral "
            << stats.MinDihedralBefore << " -> " << stats.MinDihedralAfter << ", "
            << stats.MovedPoints << " moved, " << stats.RejectedMoves << " rejected\n";
  EXPECT_LT(roughnessAfter, 0.7 * roughnessBefore);
  EXPECT_LE(stats.WorstConditionAfter, stats.WorstConditionBefore);
  EXPECT_GE(stats.MinDihedralAfter, stats.MinDihedralBefore);
  EXPECT_NEAR(after.VolumePerMaterial.at(1), before.VolumePerMaterial.at(1),
    0.02 * before.VolumePerMaterial.at(1));
}

/// Materials meeting along lines and at points, inside a background border of one voxel: in
/// [1, extent - 1]^D, material 1 for x < s, 2 for x >= s and y < s, and for x, y >= s material 3
/// (3D: 3 for z < s and 4 for z >= s), s = extent / 2. The points are jittered (seeded) except
/// on the border, keeping every interface in its plane and every junction line on its line; the
/// junction points of 2D and the quadruple point (s, s, s) of 3D are not jittered.
/// The interface planes of the junctions mesh (JitteredJunctions) that point x lies on: x =
/// middle, y = middle where x >= middle, and in 3D z = middle where x, y >= middle. On all D of
/// them: the 2D triple point or the 3D quadruple point.
struct JunctionPlanes
{
  bool X, Y, Z;
  int Count() const { return (this->X ? 1 : 0) + (this->Y ? 1 : 0) + (this->Z ? 1 : 0); }
};

template <int D>
JunctionPlanes PlanesOf(const double* x, double middle)
{
  return { x[0] == middle, x[1] == middle && x[0] >= middle,
    D == 3 && x[D - 1] == middle && x[0] >= middle && x[1] >= middle };
}

/// Expects y to keep the coordinates that put point p on its planes, bit for bit.
template <int D>
void ExpectPlanesKept(const JunctionPlanes& on, const double* y, double middle, std::int64_t p)
{
  EXPECT_TRUE(!on.X || y[0] == middle) << "point " << p;
  EXPECT_TRUE(!on.Y || y[1] == middle) << "point " << p;
  EXPECT_TRUE(!on.Z || y[D - 1] == middle) << "point " << p;
}

template <int D>
SmoothMesh<D> JitteredJunctions(std::int64_t extent, unsigned seed, double amplitude = 0.1)
{
  const std::int64_t s = extent / 2;
  LabelImage<D> image(UniformExtents<D>(extent));
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      bool border = false;
      for (int axis = 0; axis < D; ++axis)
      {
        border = border || voxel[axis] == 0 || voxel[axis] == extent - 1;
      }
      stm::MaterialIndex material = voxel[0] < s ? 1 : voxel[1] < s ? 2 : 3;
      if (D == 3 && material == 3 && voxel[D - 1] >= s)
      {
        material = 4;
      }
      image.Set(voxel, border ? 0 : material);
    });
  const SimplicialMesh<D> uniform = UniformMesh<D>(extent, image, true);
  SmoothMesh<D> mesh;
  mesh.Extent = extent;
  mesh.Points = uniform.Coordinates();
  mesh.Cells = uniform.Connectivity;
  mesh.Materials = uniform.MaterialsAsInt64();
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> jitter(-amplitude, amplitude);
  const auto middle = static_cast<double>(s);
  for (std::int64_t p = 0; p < mesh.NumberOfPoints(); ++p)
  {
    double* x = mesh.Points.data() + p * D;
    double move[D];
    bool inside = true;
    for (int axis = 0; axis < D; ++axis)
    {
      move[axis] = jitter(random);
      inside = inside && x[axis] > 1.0 && x[axis] < static_cast<double>(extent - 1);
    }
    if (!inside)
    {
      continue;
    }
    const JunctionPlanes on = PlanesOf<D>(x, middle);
    move[0] = on.X ? 0.0 : move[0];
    move[1] = on.Y ? 0.0 : move[1];
    move[D - 1] = on.Z ? 0.0 : move[D - 1];
    if (on.X && (D == 2 ? x[1] == middle : x[1] == middle && x[D - 1] == middle))
    {
      continue; // the 2D junction point, the 3D quadruple point
    }
    for (int axis = 0; axis < D; ++axis)
    {
      x[axis] += move[axis];
    }
  }
  return mesh;
}

// Junctions: a point where three or more materials meet moves only along its junction line
// (3D), and where lines meet (the quadruple point) or in 2D (triple points) it stays; the
// interfaces stay in their planes.
TYPED_TEST(BoundarySmoothTest, JunctionLinesAndPointsAreRespected)
{
  constexpr int D = TypeParam::value;
  const std::int64_t extent = D == 2 ? 16 : 8;
  const double middle = static_cast<double>(extent / 2);
  const SmoothMesh<D> input = JitteredJunctions<D>(extent, 5);
  ASSERT_TRUE(Check<D>(input).IsValid()) << Check<D>(input).Summary();
  SmoothMesh<D> mesh = input;
  const stm::BoundarySmoothStats stats = Smooth<D>(mesh, stm::BoundarySmoothOptions());
  const stm::MeshInvariantReport report = Check<D>(mesh);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_GT(stats.MovedPoints, 0);
  std::int64_t junctionPoints = 0, movedAlongLines = 0;
  for (std::int64_t p = 0; p < mesh.NumberOfPoints(); ++p)
  {
    const double* before = input.Points.data() + p * D;
    const double* after = mesh.Points.data() + p * D;
    bool inside = true;
    for (int axis = 0; axis < D; ++axis)
    {
      inside = inside && before[axis] > 1.0 && before[axis] < static_cast<double>(extent - 1);
    }
    if (!inside)
    {
      continue;
    }
    // The coordinates that put a point on an interface plane stay bit for bit.
    const JunctionPlanes on = PlanesOf<D>(before, middle);
    ExpectPlanesKept<D>(on, after, middle, p);
    const int planes = on.Count();
    if (planes == D)
    {
      // The 2D triple point, the 3D quadruple point.
      ++junctionPoints;
      for (int axis = 0; axis < D; ++axis)
      {
        EXPECT_EQ(after[axis], before[axis]);
      }
    }
    else if (D == 3 && planes == 2)
    {
      bool moved = false;
      for (int axis = 0; axis < D; ++axis)
      {
        moved = moved || after[axis] != before[axis];
      }
      movedAlongLines += moved ? 1 : 0;
    }
  }
  EXPECT_EQ(junctionPoints, 1);
  std::cout << D << "D junctions: " << stats.JunctionLinePoints << " points on junction lines ("
            << movedAlongLines << " interior ones moved along them), " << stats.JunctionCornerPoints
            << " junction points fixed, " << stats.MovedPoints << " points moved\n";
  if (D == 3)
  {
    EXPECT_GT(movedAlongLines, 0);
    EXPECT_GT(stats.JunctionLinePoints, 0);
  }
  else
  {
    EXPECT_EQ(stats.JunctionLinePoints, 0);
  }
  // 2D: the triple point and the three points where an interface meets the background. 3D: the
  // quadruple point and the four ends of the junction lines on the background.
  EXPECT_EQ(stats.JunctionCornerPoints, D == 2 ? 4 : 5);
}

// The quality improvement alone (no iterations), on junctions jittered into bad cells: the
// worst cell gets better and nothing gets worse, a point moves only within its interface plane
// (along its junction line in 3D), the junction point (2D) and the quadruple point (3D) stay,
// and every material keeps its volume (the interfaces are flat, so exactly up to rounding).
// Without interior layers only surface points may move, and some on interfaces do. Without
// sweeps nothing moves; four threads give the same points.
TYPED_TEST(BoundarySmoothTest, ImprovementKeepsInterfacesJunctionsAndVolumes)
{
  constexpr int D = TypeParam::value;
  const std::int64_t extent = D == 2 ? 16 : 8;
  const double middle = static_cast<double>(extent / 2);
  const SmoothMesh<D> input = JitteredJunctions<D>(extent, 11, 0.3);
  const stm::MeshInvariantReport before = Check<D>(input);
  ASSERT_TRUE(before.IsValid()) << before.Summary();
  const auto qualityBefore = Quality<D>(input);
  stm::BoundarySmoothOptions options;
  options.NumberOfIterations = 0;
  options.NumberOfImprovementSweeps = 0;
  SmoothMesh<D> unchanged = input;
  EXPECT_EQ(Smooth<D>(unchanged, options).MovedPoints, 0);
  EXPECT_EQ(unchanged.Points, input.Points);

  options.ImprovementMovesInterfaces = false;
  for (const int layers : { 2, 0 })
  {
    options.NumberOfImprovementSweeps = 10;
    options.NumberOfInteriorLayers = layers;
    SmoothMesh<D> mesh = input;
    const stm::BoundarySmoothStats stats = Smooth<D>(mesh, options);
    const stm::MeshInvariantReport report = Check<D>(mesh);
    EXPECT_TRUE(report.IsValid()) << report.Summary();
    EXPECT_GT(stats.ImprovedPoints, 0);
    EXPECT_EQ(stats.AcceptedMoves + stats.ReducedMoves + stats.RejectedMoves, 0);
    const auto quality = Quality<D>(mesh);
    // Both figures of the input are beyond the bounds; with interior layers the badness of the
    // worst cell drops.
    EXPECT_GT(qualityBefore.first, options.MaxConditionNumber);
    EXPECT_LT(qualityBefore.second, options.MinDihedralAngle);
    EXPECT_LE(quality.first, qualityBefore.first);
    EXPECT_GE(quality.second, qualityBefore.second);
    if (layers > 0)
    {
      EXPECT_LT(std::max(quality.first / options.MaxConditionNumber,
                  options.MinDihedralAngle / quality.second),
        std::max(qualityBefore.first / options.MaxConditionNumber,
          options.MinDihedralAngle / qualityBefore.second));
    }
    const std::map<std::int64_t, double>& volumesBefore = before.VolumePerMaterial;
    std::map<std::int64_t, double> volumesAfter = report.VolumePerMaterial;
    ASSERT_EQ(volumesBefore.size(), volumesAfter.size());
    for (const auto& entry : volumesBefore)
    {
      EXPECT_NEAR(volumesAfter[entry.first], entry.second, 1e-12 * before.TotalVolume)
        << "material " << entry.first;
    }
    std::int64_t movedOnInterfaces = 0;
    for (std::int64_t p = 0; p < mesh.NumberOfPoints(); ++p)
    {
      const double* x = input.Points.data() + p * D;
      const double* y = mesh.Points.data() + p * D;
      const JunctionPlanes on = PlanesOf<D>(x, middle);
      ExpectPlanesKept<D>(on, y, middle, p);
      const int planes = on.Count();
      bool moved = false;
      for (int axis = 0; axis < D; ++axis)
      {
        moved = moved || y[axis] != x[axis];
      }
      EXPECT_TRUE(planes < D || !moved) << "junction point " << p << " moved";
      movedOnInterfaces += planes > 0 && moved ? 1 : 0;
    }
    if (layers == 0)
    {
      EXPECT_GT(movedOnInterfaces, 0); // only surface points may move
    }
    // The same on four threads (the points of a sweep are coloured).
    SmoothMesh<D> pooled = input;
    stm::ThreadPoolExecutor four(4);
    EXPECT_EQ(Smooth<D>(pooled, options, four).ImprovedPoints, stats.ImprovedPoints);
    EXPECT_EQ(pooled.Points, mesh.Points);
    std::cout << D << "D improvement, " << layers << " interior layers: " << stats.ImprovedPoints
              << " moves (" << movedOnInterfaces << " points on interfaces), worst condition "
              << qualityBefore.first << " -> " << quality.first << ", smallest angle "
              << qualityBefore.second << " -> " << quality.second << "\n";
  }
}

// With ImprovementMovesInterfaces (the default), the sweeps that keep the volumes are followed
// by sweeps in which interface points move off their interface. An interface point of the
// junctions mesh pushed 0.8 of an edge off its plane makes needles on the side it entered, which
// no move within its tangent plane (nor of its neighbours on the plane, in theirs) can widen:
// without interior layers the worst cell stays as it is without the option and gets within the
// bounds with it, by a move of that point back toward the plane that changes the volumes by
// little; the junction points and lines stay, and four threads give the same points.
TYPED_TEST(BoundarySmoothTest, ImprovementMovesInterfacePointsWhereCellsStayBeyondTheBounds)
{
  constexpr int D = TypeParam::value;
  const std::int64_t extent = D == 2 ? 16 : 8;
  const double middle = static_cast<double>(extent / 2);
  SmoothMesh<D> input = JitteredJunctions<D>(extent, 11, 0.0);
  std::int64_t pushed = -1;
  for (std::int64_t p = 0; p < input.NumberOfPoints(); ++p)
  {
    const double* x = input.Points.data() + p * D;
    bool found = x[0] == middle;
    for (int axis = 1; axis < D; ++axis)
    {
      found = found && x[axis] == 2.0;
    }
    pushed = found ? p : pushed;
  }
  ASSERT_GE(pushed, 0);
  input.Points[pushed * D] += D == 2 ? 0.8 : 0.9;
  const stm::MeshInvariantReport before = Check<D>(input);
  ASSERT_TRUE(before.IsValid()) << before.Summary();
  stm::BoundarySmoothOptions options;
  options.NumberOfIterations = 0;
  options.NumberOfInteriorLayers = 0;
  EXPECT_TRUE(options.ImprovementMovesInterfaces);
  auto badness = [&](const std::pair<double, double>& quality)
  {
    return std::max(
      quality.first / options.MaxConditionNumber, options.MinDihedralAngle / quality.second);
  };
  const double inputBadness = badness(Quality<D>(input));
  EXPECT_GT(inputBadness, 1.0);
  SmoothMesh<D> kept = input;
  options.ImprovementMovesInterfaces = false;
  Smooth<D>(kept, options);
  const double keptBadness = badness(Quality<D>(kept));
  EXPECT_GT(keptBadness, 1.0);
  options.ImprovementMovesInterfaces = true;
  SmoothMesh<D> mesh = input;
  const stm::BoundarySmoothStats stats = Smooth<D>(mesh, options);
  const stm::MeshInvariantReport report = Check<D>(mesh);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_GT(stats.ImprovedPoints, 0);
  const double freedBadness = badness(Quality<D>(mesh));
  EXPECT_LE(freedBadness, 1.0);
  EXPECT_LT(mesh.Points[pushed * D], input.Points[pushed * D]);
  // The moved points are interface points next to the pushed one, between materials 0, 1 and
  // 2: the total volume stays (the outer boundary is fixed), and the materials away from them
  // keep theirs.
  std::map<std::int64_t, double> volumesAfter = report.VolumePerMaterial;
  const double tolerance = 1e-12 * before.TotalVolume;
  double total = 0.0, change = 0.0;
  for (const auto& entry : before.VolumePerMaterial)
  {
    total += volumesAfter[entry.first];
    change += std::abs(volumesAfter[entry.first] - entry.second);
    if (entry.first > 2)
    {
      EXPECT_NEAR(volumesAfter[entry.first], entry.second, tolerance) << "material " << entry.first;
    }
  }
  EXPECT_NEAR(total, before.TotalVolume, tolerance);
  EXPECT_GT(change, tolerance);
  for (std::int64_t p = 0; p < mesh.NumberOfPoints(); ++p)
  {
    const double* x = input.Points.data() + p * D;
    const double* y = mesh.Points.data() + p * D;
    const JunctionPlanes on = PlanesOf<D>(x, middle);
    if (on.Count() >= 2)
    {
      // A junction point: on its line (3D: its planes' coordinates kept) or fixed.
      ExpectPlanesKept<D>(on, y, middle, p);
      EXPECT_TRUE(on.Count() < D || std::equal(x, x + D, y)) << "junction point " << p << " moved";
    }
  }
  SmoothMesh<D> pooled = input;
  stm::ThreadPoolExecutor four(4);
  EXPECT_EQ(Smooth<D>(pooled, options, four).ImprovedPoints, stats.ImprovedPoints);
  EXPECT_EQ(pooled.Points, mesh.Points);
  std::cout << D << "D improvement off the interfaces: badness " << inputBadness << " -> "
            << keptBadness << " keeping the interfaces, " << freedBadness
            << " moving them; the pushed point back by "
            << input.Points[pushed * D] - mesh.Points[pushed * D] << ", volumes changed by "
            << change << " in all\n";
}

// Volume restoration. A Laplacian smoothing of the cut ball shrinks it by more than 1%; with the
// input's volumes as targets, the ball gets its volume back to 1e-6. On the jittered junctions,
// targets 1% off each material's volume are reached to 1e-6, and the junction points (2D)
// and the quadruple point (3D) stay.
TYPED_TEST(BoundarySmoothTest, VolumeRestorationReachesTheTargets)
{
  constexpr int D = TypeParam::value;
  {
    const SmoothMesh<D> input = CutBall<D>(Extent<D>(), 0.35);
    const double inside = Check<D>(input).VolumePerMaterial.at(1);
    stm::BoundarySmoothOptions options;
    options.Method = stm::SmoothingMethod::Laplacian;
    SmoothMesh<D> shrunk = input, restored = input;
    const stm::BoundarySmoothStats plain = Smooth<D>(shrunk, options);
    EXPECT_TRUE(plain.TargetVolumes.empty());
    EXPECT_LT(Check<D>(shrunk).VolumePerMaterial.at(1), 0.99 * inside);
    options.VolumeTargetMaterials = input.Materials.data();
    options.VolumeTolerance = 1e-7;
    options.NumberOfVolumeRounds = 50;
    const stm::BoundarySmoothStats stats = Smooth<D>(restored, options);
    const stm::MeshInvariantReport report = Check<D>(restored);
    EXPECT_TRUE(report.IsValid()) << report.Summary();
    EXPECT_NEAR(stats.TargetVolumes.at(1), inside, 1e-9 * inside);
    EXPECT_GT(stats.LargestVolumeErrorBefore, 0.01);
    EXPECT_LT(stats.LargestVolumeErrorAfter, 1e-6);
    EXPECT_NEAR(report.VolumePerMaterial.at(1), inside, 1e-6 * inside);
    std::cout << D << "D Laplacian ball: volume " << inside << " -> "
              << Check<D>(shrunk).VolumePerMaterial.at(1) << ", restored "
              << report.VolumePerMaterial.at(1) << "\n";
  }
  const std::int64_t extent = D == 2 ? 16 : 8;
  const double middle = static_cast<double>(extent / 2);
  const SmoothMesh<D> input = JitteredJunctions<D>(extent, 5);
  const stm::MeshInvariantReport before = Check<D>(input);
  stm::BoundarySmoothOptions options;
  options.NumberOfIterations = 0;
  options.NumberOfImprovementSweeps = 0;
  options.VolumeTolerance = 1e-7;
  double factor = 1.01;
  for (const auto& entry : before.VolumePerMaterial)
  {
    if (entry.first != 0)
    {
      options.TargetVolumes[entry.first] = factor * entry.second;
      factor = factor > 1.0 ? 0.99 : 1.01;
    }
  }
  SmoothMesh<D> mesh = input;
  const stm::BoundarySmoothStats stats = Smooth<D>(mesh, options);
  const stm::MeshInvariantReport report = Check<D>(mesh);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_NEAR(stats.LargestVolumeErrorBefore, 0.01 / 0.99, 1e-9);
  EXPECT_LT(stats.LargestVolumeErrorAfter, 1e-6);
  for (const auto& target : options.TargetVolumes)
  {
    EXPECT_NEAR(report.VolumePerMaterial.at(target.first), target.second, 1e-6 * target.second)
      << "material " << target.first;
  }
  std::int64_t junctionPoints = 0;
  for (std::int64_t p = 0; p < mesh.NumberOfPoints(); ++p)
  {
    const double* x = input.Points.data() + p * D;
    bool inside = true;
    for (int axis = 0; axis < D; ++axis)
    {
      inside = inside && x[axis] > 1.0 && x[axis] < static_cast<double>(extent - 1);
    }
    if (inside && PlanesOf<D>(x, middle).Count() == D)
    {
      ++junctionPoints;
      for (int axis = 0; axis < D; ++axis)
      {
        EXPECT_EQ(mesh.Points[p * D + axis], x[axis]);
      }
    }
  }
  EXPECT_EQ(junctionPoints, 1);
}

TEST(BoundarySmooth, RejectsBadOptionsAndIds)
{
  SmoothMesh<2> mesh = CutBall<2>(8, 0.3);
  auto run = [&](const stm::BoundarySmoothOptions& options)
  {
    stm::BoundarySmoother<2> smoother;
    stm::SequentialExecutor executor;
    return smoother.Smooth(mesh.Points.data(), mesh.NumberOfPoints(), mesh.Cells.data(),
      mesh.NumberOfCells(), mesh.Materials.data(), options, executor);
  };
  const std::vector<double> original = mesh.Points;
  stm::BoundarySmoothOptions options;
  options.RelaxationFactor = 0.0;
  EXPECT_EQ(run(options).GetCode(), stm::Status::Code::InvalidArgument);
  options = stm::BoundarySmoothOptions();
  options.PassBand = 1.0;
  EXPECT_EQ(run(options).GetCode(), stm::Status::Code::InvalidArgument);
  options = stm::BoundarySmoothOptions();
  options.NumberOfIterations = -1;
  EXPECT_EQ(run(options).GetCode(), stm::Status::Code::InvalidArgument);
  options = stm::BoundarySmoothOptions();
  options.MaxConditionNumber = 0.5;
  EXPECT_EQ(run(options).GetCode(), stm::Status::Code::InvalidArgument);
  options = stm::BoundarySmoothOptions();
  options.MinDihedralAngle = 180.0;
  EXPECT_EQ(run(options).GetCode(), stm::Status::Code::InvalidArgument);
  options = stm::BoundarySmoothOptions();
  options.InteriorRelaxationInterval = 0;
  EXPECT_EQ(run(options).GetCode(), stm::Status::Code::InvalidArgument);
  options = stm::BoundarySmoothOptions();
  options.SmallPartPoints = -1;
  EXPECT_EQ(run(options).GetCode(), stm::Status::Code::InvalidArgument);
  options = stm::BoundarySmoothOptions();
  options.NumberOfImprovementSweeps = -1;
  EXPECT_EQ(run(options).GetCode(), stm::Status::Code::InvalidArgument);
  options = stm::BoundarySmoothOptions();
  options.NumberOfVolumeRounds = -1;
  EXPECT_EQ(run(options).GetCode(), stm::Status::Code::InvalidArgument);
  options = stm::BoundarySmoothOptions();
  options.VolumeTolerance = -1.0;
  EXPECT_EQ(run(options).GetCode(), stm::Status::Code::InvalidArgument);
  options = stm::BoundarySmoothOptions();
  std::vector<std::uint8_t> colours(static_cast<std::size_t>(mesh.NumberOfCells()), 8);
  options.CellRootColours = colours.data();
  EXPECT_TRUE(run(options).IsOk()); // 8 is the last of 3^2 colours
  mesh.Points = original;
  colours[7] = 9;
  EXPECT_EQ(run(options).GetCode(), stm::Status::Code::InvalidArgument);
  EXPECT_EQ(mesh.Points, original);
  mesh.Cells[5] = mesh.NumberOfPoints();
  EXPECT_EQ(run(stm::BoundarySmoothOptions()).GetCode(), stm::Status::Code::InvalidArgument);
  mesh.Cells[5] = 0;
  mesh.Points[3] = std::nan("");
  EXPECT_EQ(run(stm::BoundarySmoothOptions()).GetCode(), stm::Status::Code::InvalidArgument);
}

// Without materials every cell is one body: the whole outer boundary is the surface, nothing
// is fixed; 20 Taubin iterations round the square's corners but keep a valid mesh.
TEST(BoundarySmooth, WithoutMaterialsTheOuterBoundaryIsTheSurface)
{
  SmoothMesh<2> mesh = CutBall<2>(8, 0.3);
  stm::BoundarySmoother<2> smoother;
  stm::SequentialExecutor executor;
  ASSERT_TRUE(
    smoother
      .Smooth(mesh.Points.data(), mesh.NumberOfPoints(), mesh.Cells.data(), mesh.NumberOfCells(),
        static_cast<const std::int64_t*>(nullptr), stm::BoundarySmoothOptions(), executor)
      .IsOk());
  EXPECT_EQ(smoother.GetStats().FixedPoints, 0);
  EXPECT_EQ(smoother.GetStats().SurfacePoints, 32);
  EXPECT_EQ(smoother.GetStats().VolumeBefore.count(1), 1u);
  EXPECT_TRUE(Check<2>(mesh).IsValid());
}

// 1D: surface points (material changes) have no surface edges and stay; interior layer points
// move toward their neighbours' centroid (the two interior points of material 1 would be a small
// part, kept, with the default SmallPartPoints). 4D: the generic code keeps a cut 4-ball valid and
// its worst element no worse.
TEST(BoundarySmooth, OneAndFourDimensions)
{
  SmoothMesh<1> line;
  const double x[] = { 0.0, 1.0, 2.0, 2.2, 4.0, 5.0, 6.0 };
  line.Points.assign(std::begin(x), std::end(x));
  for (std::int64_t c = 0; c < 6; ++c)
  {
    line.Cells.push_back(c);
    line.Cells.push_back(c + 1);
    line.Materials.push_back(c < 3 ? 1 : 2);
  }
  std::vector<std::uint8_t> roles;
  stm::BoundarySmoothOptions lineOptions;
  lineOptions.SmallPartPoints = 0;
  const stm::BoundarySmoothStats stats = Smooth<1>(line, lineOptions, &roles);
  EXPECT_EQ(roles[3], stm::BoundarySmoother<1>::Surface);
  EXPECT_EQ(line.Points[3], 2.2);
  EXPECT_EQ(line.Points[0], 0.0); // the outer ends are surface points of a body material
  EXPECT_EQ(stats.SurfacePoints, 3);
  EXPECT_LT(line.Points[2], 2.0); // an interior layer point moved toward 1 and 2.2
  EXPECT_GT(line.Points[2], 1.4);
  EXPECT_TRUE(Check<1>(line).IsValid());

  SmoothMesh<4> ball = CutBall<4>(4, 0.35);
  const auto quality = Quality<4>(ball);
  const stm::BoundarySmoothStats stats4 = Smooth<4>(ball, stm::BoundarySmoothOptions());
  EXPECT_TRUE(Check<4>(ball).IsValid());
  EXPECT_LE(Quality<4>(ball).first, quality.first);
  EXPECT_GT(stats4.SurfacePoints, 0);
}

} // namespace
