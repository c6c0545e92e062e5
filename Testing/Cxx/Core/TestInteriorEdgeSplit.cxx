// SPDX-License-Identifier: BSD-3-Clause
// Splitting edges inside one material (InteriorEdgeSplit) in 2D and 3D: the star of a long
// interior edge (two flat triangles; six needle tetrahedra around a hexagon) is split at its
// midpoint, which the symmetric search keeps, into a conforming mesh of less bad cells with the
// same volume per material; an edge between two materials, on the outer boundary or with a held
// end is never split, and bad options are refused.

#include "CoreTestUtilities.h"

#include "Check/MeshInvariants.h"
#include "Check/SimplexQuality.h"
#include "Common/Execution.h"
#include "Smooth/InteriorEdgeSplit.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace
{
template <int D>
struct StarMesh
{
  std::vector<double> Points;
  std::vector<std::int64_t> Cells;
  std::vector<std::int64_t> Materials;
};

/// Orders each cell's corners so that it has VTK's (positive) orientation.
template <int D>
void Orient(StarMesh<D>& mesh)
{
  for (std::size_t c = 0; c < mesh.Materials.size(); ++c)
  {
    const double* corners[D + 1];
    for (int v = 0; v <= D; ++v)
    {
      corners[v] = mesh.Points.data() + mesh.Cells[c * (D + 1) + v] * D;
    }
    if (stm::MeasureSimplex<D>(corners).Determinant < 0.0)
    {
      std::swap(mesh.Cells[c * (D + 1)], mesh.Cells[c * (D + 1) + 1]);
    }
  }
}

/// 2D: the edge from (-1, 0) to (1, 0) (points 0, 1) between the triangles to (0, 0.3) and
/// (0, -0.3): smallest angle 16.7 degrees, condition number 2.97. 3D: the edge from (0, 0, -1)
/// to (0, 0, 1) inside six tetrahedra around a hexagon of radius 0.35 in z = 0 (2.57).
template <int D>
StarMesh<D> Star()
{
  StarMesh<D> mesh;
  if constexpr (D == 2)
  {
    mesh.Points = { -1.0, 0.0, 1.0, 0.0, 0.0, 0.3, 0.0, -0.3 };
    mesh.Cells = { 0, 1, 2, 0, 1, 3 };
  }
  else
  {
    mesh.Points = { 0.0, 0.0, -1.0, 0.0, 0.0, 1.0 };
    for (int k = 0; k < 6; ++k)
    {
      const double angle = k * 3.14159265358979323846 / 3.0;
      mesh.Points.insert(
        mesh.Points.end(), { 0.35 * std::cos(angle), 0.35 * std::sin(angle), 0.0 });
      mesh.Cells.insert(mesh.Cells.end(), { 0, 1, 2 + k, 2 + (k + 1) % 6 });
    }
  }
  mesh.Materials.assign(mesh.Cells.size() / (D + 1), 1);
  Orient<D>(mesh);
  return mesh;
}

/// The mesh with the edits applied.
template <int D>
StarMesh<D> Apply(const StarMesh<D>& mesh, const stm::InteriorEdgeSplit<D>& split)
{
  StarMesh<D> out = mesh;
  for (const auto& point : split.GetNewPoints())
  {
    out.Points.insert(out.Points.end(), point.Position.begin(), point.Position.end());
  }
  for (const auto& changed : split.GetChangedCells())
  {
    std::copy(
      changed.second.begin(), changed.second.end(), out.Cells.begin() + changed.first * (D + 1));
  }
  for (std::size_t c = 0; c < split.GetAppendedCells().size(); ++c)
  {
    const auto& ids = split.GetAppendedCells()[c];
    out.Cells.insert(out.Cells.end(), ids.begin(), ids.end());
    out.Materials.push_back(mesh.Materials[split.GetAppendedParents()[c]]);
  }
  return out;
}

template <int D>
stm::Status RunSplit(const StarMesh<D>& mesh, const stm::InteriorEdgeSplitOptions& options,
  stm::InteriorEdgeSplit<D>& split)
{
  stm::SequentialExecutor executor;
  return split.Split(mesh.Points.data(), static_cast<std::int64_t>(mesh.Points.size() / D),
    mesh.Cells.data(), static_cast<std::int64_t>(mesh.Materials.size()), mesh.Materials.data(),
    options, executor);
}

template <class T>
class InteriorEdgeSplitTest : public ::testing::Test
{
};
using SplitDimensions =
  ::testing::Types<std::integral_constant<int, 2>, std::integral_constant<int, 3>>;
TYPED_TEST_SUITE(InteriorEdgeSplitTest, SplitDimensions);

// The star's edge is split once at its midpoint: every cell of the star becomes two (the first
// keeps its slot), the mesh stays conforming with the same volume and outer boundary, and the
// worst condition number falls below the bound of 2 (2D: 2.97 -> 2.10, 3D: 2.57 -> 1.86).
TYPED_TEST(InteriorEdgeSplitTest, LongInteriorEdgeIsSplitAtItsMidpoint)
{
  constexpr int D = TypeParam::value;
  const StarMesh<D> mesh = Star<D>();
  const std::int64_t cells = static_cast<std::int64_t>(mesh.Materials.size());
  stm::InteriorEdgeSplitOptions options;
  options.MaxConditionNumber = 2.0;
  const double before = stmtest::WorstSimplexCondition<D>(mesh.Points, mesh.Cells);
  EXPECT_GT(before, options.MaxConditionNumber);
  stm::InteriorEdgeSplit<D> split;
  ASSERT_TRUE(RunSplit<D>(mesh, options, split).IsOk());
  EXPECT_EQ(split.GetNumberOfCandidates(), cells);
  ASSERT_EQ(split.GetNewPoints().size(), 1u);
  EXPECT_EQ(split.GetNewPoints()[0].A + split.GetNewPoints()[0].B, 1); // the edge (0, 1)
  for (int c = 0; c < D; ++c)
  {
    EXPECT_EQ(split.GetNewPoints()[0].Position[c], 0.0);
  }
  EXPECT_EQ(static_cast<std::int64_t>(split.GetChangedCells().size()), cells);
  EXPECT_EQ(static_cast<std::int64_t>(split.GetAppendedCells().size()), cells);
  const StarMesh<D> out = Apply<D>(mesh, split);
  const stm::MeshInvariantReport report =
    stm::CheckSimplicialMesh<D>(out.Points, out.Cells, &out.Materials);
  EXPECT_TRUE(report.IsValid());
  EXPECT_EQ(report.NumberOfCells, 2 * cells);
  const stm::MeshInvariantReport input =
    stm::CheckSimplicialMesh<D>(mesh.Points, mesh.Cells, &mesh.Materials);
  EXPECT_NEAR(report.VolumePerMaterial.at(1), input.VolumePerMaterial.at(1), 1e-14);
  EXPECT_EQ(report.BoundaryFacets, input.BoundaryFacets);
  const double after = stmtest::WorstSimplexCondition<D>(out.Points, out.Cells);
  EXPECT_LT(after, before);
  EXPECT_NEAR(before, D == 2 ? 2.97335 : 2.57477, 1e-5);
  EXPECT_NEAR(after, D == 2 ? 2.09771 : 1.86476, 1e-5);
  EXPECT_LT(split.GetWorstBadnessAfter(), split.GetWorstBadnessBefore());
}

// An edge between two materials, or on the outer boundary (one cell of the 3D star removed; in
// 2D one triangle), is never split; cells within the bounds are no candidates.
TYPED_TEST(InteriorEdgeSplitTest, EdgesOnInterfacesOrTheBoundaryStay)
{
  constexpr int D = TypeParam::value;
  stm::InteriorEdgeSplitOptions options;
  options.MaxConditionNumber = 2.0;
  StarMesh<D> mixed = Star<D>();
  mixed.Materials[0] = 2;
  stm::InteriorEdgeSplit<D> split;
  ASSERT_TRUE(RunSplit<D>(mixed, options, split).IsOk());
  EXPECT_GT(split.GetNumberOfCandidates(), 0);
  EXPECT_TRUE(split.GetNewPoints().empty());
  EXPECT_TRUE(split.GetChangedCells().empty());
  EXPECT_TRUE(split.GetAppendedCells().empty());

  StarMesh<D> open = Star<D>();
  open.Cells.resize(open.Cells.size() - (D + 1));
  open.Materials.pop_back();
  ASSERT_TRUE(RunSplit<D>(open, options, split).IsOk());
  EXPECT_GT(split.GetNumberOfCandidates(), 0);
  EXPECT_TRUE(split.GetNewPoints().empty());

  options.MaxConditionNumber = 10.0;
  options.MinDihedralAngle = 1.0;
  ASSERT_TRUE(RunSplit<D>(Star<D>(), options, split).IsOk());
  EXPECT_EQ(split.GetNumberOfCandidates(), 0);
  EXPECT_TRUE(split.GetNewPoints().empty());
}

// In a piece of a larger mesh the points of its ghost cells are held: an edge with a held end
// is never split, and holding a point off the edge leaves the split as it was.
TYPED_TEST(InteriorEdgeSplitTest, EdgesWithAHeldEndStay)
{
  constexpr int D = TypeParam::value;
  const StarMesh<D> mesh = Star<D>();
  stm::InteriorEdgeSplitOptions options;
  options.MaxConditionNumber = 2.0;
  std::vector<std::uint8_t> held(mesh.Points.size() / D, 0);
  options.HeldPoints = held.data();
  for (const int end : { 0, 1 })
  {
    std::fill(held.begin(), held.end(), 0);
    held[end] = 1;
    stm::InteriorEdgeSplit<D> split;
    ASSERT_TRUE(RunSplit<D>(mesh, options, split).IsOk());
    EXPECT_GT(split.GetNumberOfCandidates(), 0);
    EXPECT_TRUE(split.GetNewPoints().empty()) << "end " << end;
    EXPECT_TRUE(split.GetChangedCells().empty());
    EXPECT_TRUE(split.GetAppendedCells().empty());
  }
  std::fill(held.begin(), held.end(), 0);
  held[2] = 1; // a corner of the star off the edge
  stm::InteriorEdgeSplit<D> split;
  ASSERT_TRUE(RunSplit<D>(mesh, options, split).IsOk());
  ASSERT_EQ(split.GetNewPoints().size(), 1u);
  EXPECT_EQ(split.GetNewPoints()[0].A + split.GetNewPoints()[0].B, 1); // the edge (0, 1)
  EXPECT_EQ(split.GetAppendedCells().size(), mesh.Materials.size());
}

TEST(InteriorEdgeSplit, RejectsBadOptionsAndIds)
{
  StarMesh<3> mesh = Star<3>();
  stm::InteriorEdgeSplit<3> split;
  stm::InteriorEdgeSplitOptions options;
  options.MaxConditionNumber = 0.5;
  EXPECT_EQ(RunSplit<3>(mesh, options, split).GetCode(), stm::Status::Code::InvalidArgument);
  options = stm::InteriorEdgeSplitOptions();
  options.MinDihedralAngle = 180.0;
  EXPECT_EQ(RunSplit<3>(mesh, options, split).GetCode(), stm::Status::Code::InvalidArgument);
  mesh.Cells[3] = 8;
  EXPECT_EQ(RunSplit<3>(mesh, stm::InteriorEdgeSplitOptions(), split).GetCode(),
    stm::Status::Code::InvalidArgument);
}
} // namespace
