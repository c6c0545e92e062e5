// SPDX-License-Identifier: BSD-3-Clause
// CheckSimplicialMesh is the oracle of the tessellation tests, so it must be able to fail: each
// hand-made broken mesh below breaks one invariant, and the report must count exactly that.

#include "CoreTestUtilities.h"

#include <numeric>

namespace
{

using stm::CheckSimplicialMesh;
using stm::MeshInvariantReport;

// Two triangles of the unit square, positively oriented:
//   3---2
//   | / |
//   0---1
const std::vector<double> SquarePoints = { 0, 0, 1, 0, 1, 1, 0, 1 };
const std::vector<std::int64_t> SquareCells = { 0, 1, 2, 0, 2, 3 };

TEST(MeshInvariants, ValidSquareIsValidWithExactMeasures)
{
  const std::vector<std::int64_t> materials = { 1, 2 };
  const MeshInvariantReport report = CheckSimplicialMesh<2>(SquarePoints, SquareCells, &materials);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_EQ(report.NumberOfCells, 2);
  EXPECT_EQ(report.NumberOfPoints, 4);
  EXPECT_EQ(report.BoundaryFacets, 4);
  EXPECT_EQ(report.OvershareFacets, 0);
  EXPECT_EQ(report.NonPositiveCells, 0);
  EXPECT_EQ(report.OpenRidges, 0);
  EXPECT_EQ(report.HangingNodes, 0);
  EXPECT_EQ(report.UnreferencedPoints, 0);
  EXPECT_EQ(report.TotalVolume, 1.0);
  EXPECT_EQ(report.MinimumVolume, 0.5);
  EXPECT_EQ(report.BoundaryMeasure, 4.0);
  EXPECT_EQ(report.VolumePerMaterial.at(1), 0.5);
  EXPECT_EQ(report.VolumePerMaterial.at(2), 0.5);
}

TEST(MeshInvariants, DuplicatedCellOversharesAFacet)
{
  // Repeating triangle (0,2,3) puts its diagonal 0-2 in three cells.
  std::vector<std::int64_t> cells = SquareCells;
  cells.insert(cells.end(), { 0, 2, 3 });
  const MeshInvariantReport report = CheckSimplicialMesh<2>(SquarePoints, cells, nullptr);
  EXPECT_FALSE(report.IsValid());
  EXPECT_EQ(report.OvershareFacets, 1);
  EXPECT_EQ(report.NonPositiveCells, 0);
  EXPECT_EQ(report.TotalVolume, 1.5);
  // The boundary left is 0-1 and 1-2: its ends 0 and 2 are ridges used once.
  EXPECT_EQ(report.BoundaryFacets, 2);
  EXPECT_EQ(report.OpenRidges, 2);
}

TEST(MeshInvariants, InvertedTetrahedronIsNonPositive)
{
  // The unit corner tetrahedron (0,1,2,3) and its mirror image through the plane x = 0, which
  // shares the facet (0,2,3). Listed as (0,3,2,4) the mirror is positive; as (0,2,3,4) it is
  // inverted.
  const std::vector<double> points = { 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, -1, 0, 0 };
  const MeshInvariantReport good =
    CheckSimplicialMesh<3>(points, { 0, 1, 2, 3, 0, 3, 2, 4 }, nullptr);
  EXPECT_TRUE(good.IsValid()) << good.Summary();
  EXPECT_EQ(good.BoundaryFacets, 6);
  EXPECT_DOUBLE_EQ(good.TotalVolume, 1.0 / 3.0);

  const MeshInvariantReport bad =
    CheckSimplicialMesh<3>(points, { 0, 1, 2, 3, 0, 2, 3, 4 }, nullptr);
  EXPECT_FALSE(bad.IsValid());
  EXPECT_EQ(bad.NonPositiveCells, 1) << bad.Summary();
  EXPECT_DOUBLE_EQ(bad.MinimumVolume, -1.0 / 6.0);
  // Orientation does not change which facets are shared.
  EXPECT_EQ(bad.BoundaryFacets, 6);
  EXPECT_EQ(bad.OvershareFacets, 0);
}

TEST(MeshInvariants, FlatTriangleIsNonPositive)
{
  const std::vector<double> points = { 0, 0, 1, 0, 2, 0 };
  const MeshInvariantReport report = CheckSimplicialMesh<2>(points, { 0, 1, 2 }, nullptr);
  EXPECT_FALSE(report.IsValid());
  EXPECT_EQ(report.NonPositiveCells, 1);
}

TEST(MeshInvariants, HangingNodeIsDetected)
{
  // Points 0 = (0,0), 1 = (2,0), 2 = (1,0) the midpoint of 0-1, 3 = (1,1) above, 4 = (1,-1)
  // below. Above the edge 0-1, the triangles (0,2,3) and (2,1,3) meet at 2; below it, the
  // triangle (0,4,1) uses the whole edge 0-1, so 2 hangs on it.
  const std::vector<double> points = { 0, 0, 2, 0, 1, 0, 1, 1, 1, -1 };
  const std::vector<std::int64_t> cells = { 0, 2, 3, 2, 1, 3, 0, 4, 1 };
  const MeshInvariantReport report = CheckSimplicialMesh<2>(points, cells, nullptr);
  EXPECT_FALSE(report.IsValid());
  EXPECT_EQ(report.HangingNodes, 1) << report.Summary();
  EXPECT_EQ(report.NonPositiveCells, 0);
  // 0-2, 2-1 and 0-1 are each used once: they are (wrongly) boundary facets.
  EXPECT_EQ(report.BoundaryFacets, 7);
  EXPECT_EQ(report.OvershareFacets, 0);
}

TEST(MeshInvariants, HangingNodeOnATetrahedronFaceEdge)
{
  // Above the plane z = 0, two tetrahedra cover the triangle (0,1,2) split at the midpoint
  // 5 = (1,0,0) of its edge 0-1; below it, one tetrahedron uses the whole triangle: 5 hangs.
  const std::vector<double> points = { 0, 0, 0, 2, 0, 0, 0, 2, 0, 0, 0, 2, 0, 0, -2, 1, 0, 0 };
  // Above: (0,5,2,3) and (5,1,2,3); below: (0,2,1,4).
  const std::vector<std::int64_t> cells = { 0, 5, 2, 3, 5, 1, 2, 3, 0, 2, 1, 4 };
  const MeshInvariantReport report = CheckSimplicialMesh<3>(points, cells, nullptr);
  EXPECT_FALSE(report.IsValid());
  EXPECT_EQ(report.NonPositiveCells, 0) << report.Summary();
  EXPECT_EQ(report.HangingNodes, 1);
}

TEST(MeshInvariants, UnreferencedPointIsCounted)
{
  std::vector<double> points = SquarePoints;
  points.insert(points.end(), { 5, 5 });
  const MeshInvariantReport report = CheckSimplicialMesh<2>(points, SquareCells, nullptr);
  EXPECT_FALSE(report.IsValid());
  EXPECT_EQ(report.UnreferencedPoints, 1);
  EXPECT_EQ(report.NumberOfPoints, 5);
}

TEST(MeshInvariants, InvalidPointIdIsCounted)
{
  const MeshInvariantReport report =
    CheckSimplicialMesh<2>(SquarePoints, { 0, 1, 2, 0, 2, 7 }, nullptr);
  EXPECT_FALSE(report.IsValid());
  EXPECT_EQ(report.InvalidPointIds, 1);
  const MeshInvariantReport negative =
    CheckSimplicialMesh<2>(SquarePoints, { 0, 1, 2, -1, 2, 3 }, nullptr);
  EXPECT_FALSE(negative.IsValid());
  EXPECT_EQ(negative.InvalidPointIds, 1);
}

TEST(MeshInvariants, BookOfThreeTrianglesHasAnOversharedFacetAndOpenRidges)
{
  // Without overshared facets the boundary of a simplicial chain is always closed (the boundary
  // of a boundary is zero), so open ridges only appear together with a facet in three cells:
  // here the "book" of three triangles on the edge 0-1. Its ends 0 and 1 each lie on three
  // boundary edges (to 2, 3 and 4), an odd count.
  const std::vector<double> points = { 0, 0, 1, 0, 0, 1, 1, -1, 2, 1 };
  const std::vector<std::int64_t> cells = { 0, 1, 2, 1, 0, 3, 0, 1, 4 };
  const MeshInvariantReport report = CheckSimplicialMesh<2>(points, cells, nullptr);
  EXPECT_FALSE(report.IsValid());
  EXPECT_EQ(report.OvershareFacets, 1) << report.Summary();
  EXPECT_EQ(report.BoundaryFacets, 6);
  EXPECT_EQ(report.OpenRidges, 2);
}

template <class DimensionTag>
class MeshInvariantsTest : public ::testing::Test
{
};
TYPED_TEST_SUITE(MeshInvariantsTest, stmtest::AllDimensions);

/// The Kuhn triangulation of an n^D grid of unit cubes, built here without the tessellator: for
/// every cube and every order of the axes, the monotone path of corners; oriented by the sign of
/// the exact determinant.
template <int D>
void MakeKuhnGrid(std::int64_t n, std::vector<double>& points, std::vector<std::int64_t>& cells)
{
  const stm::LatticeIndex<D> pointDims = stmtest::UniformExtents<D>(n + 1);
  stmtest::ForEachIndex<D>(pointDims,
    [&](const stm::LatticeIndex<D>& point)
    { points.insert(points.end(), point.begin(), point.end()); });
  stmtest::ForEachIndex<D>(stmtest::UniformExtents<D>(n),
    [&](const stm::LatticeIndex<D>& cube)
    {
      std::array<int, D> axes;
      std::iota(axes.begin(), axes.end(), 0);
      do
      {
        std::array<stm::LatticeIndex<D>, D + 1> path;
        path[0] = cube;
        for (int step = 0; step < D; ++step)
        {
          path[step + 1] = path[step];
          ++path[step + 1][axes[step]];
        }
        if (stmtest::ScaledSignedVolume<D>(path) < 0)
        {
          std::swap(path[0], path[1]);
        }
        for (const auto& corner : path)
        {
          cells.push_back(stm::LinearIndex<D>(corner, pointDims));
        }
      } while (std::next_permutation(axes.begin(), axes.end()));
    });
}

TYPED_TEST(MeshInvariantsTest, KuhnGridMeasuresAreExact)
{
  // Integer coordinates: the volume (n^D) and the boundary measure (2D n^(D-1)) are integers,
  // and every simplex volume is 1/D!, so an exact checker must return them exactly. This is
  // what the header promises ("for exact comparisons with the voxel model").
  constexpr int D = TypeParam::value;
  const std::int64_t n = D == 4 ? 3 : 4;
  std::vector<double> points;
  std::vector<std::int64_t> cells;
  MakeKuhnGrid<D>(n, points, cells);
  const MeshInvariantReport report = CheckSimplicialMesh<D>(points, cells, nullptr);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  const std::int64_t volume = stm::IntPow(static_cast<int>(n), D);
  const std::int64_t boundary = 2 * D * stm::IntPow(static_cast<int>(n), D - 1);
  EXPECT_EQ(report.NumberOfCells, volume * stm::Factorial(D));
  EXPECT_EQ(report.BoundaryFacets, boundary * stm::Factorial(D - 1));
  EXPECT_TRUE(stmtest::ExactlyEqual(report.TotalVolume, static_cast<double>(volume)));
  EXPECT_TRUE(stmtest::ExactlyEqual(report.VolumePerMaterial.at(0), static_cast<double>(volume)));
  EXPECT_TRUE(stmtest::ExactlyEqual(report.BoundaryMeasure, static_cast<double>(boundary)));
}

TEST(MeshInvariants, EmptyMeshIsNotValid)
{
  const MeshInvariantReport report = CheckSimplicialMesh<3>({}, {}, nullptr);
  EXPECT_FALSE(report.IsValid());
  EXPECT_EQ(report.NumberOfCells, 0);
}

TEST(MeshInvariants, OneDimensionalBoundaryIsTheEndpointCount)
{
  // Segments [0,1] [1,3] and [5,6]: two components, four end points.
  const std::vector<double> points = { 0, 1, 3, 5, 6 };
  const MeshInvariantReport report = CheckSimplicialMesh<1>(points, { 0, 1, 1, 2, 3, 4 }, nullptr);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_EQ(report.BoundaryFacets, 4);
  EXPECT_EQ(report.BoundaryMeasure, 4.0);
  EXPECT_EQ(report.TotalVolume, 4.0);
  // Reversed segment: negative length.
  const MeshInvariantReport reversed =
    CheckSimplicialMesh<1>(points, { 1, 0, 1, 2, 3, 4 }, nullptr);
  EXPECT_EQ(reversed.NonPositiveCells, 1);
}

} // namespace
