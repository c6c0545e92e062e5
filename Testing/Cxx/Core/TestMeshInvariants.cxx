// SPDX-License-Identifier: BSD-3-Clause
// CheckSimplicialMesh and CheckCellMesh are the oracles of the tessellation tests, so they must be
// able to fail: each hand-made broken mesh below breaks one invariant, and the report must count
// exactly that. Valid meshes of cubes, pyramids and cones in every dimension must give exact
// measures.

#include "CoreTestUtilities.h"

#include <functional>
#include <numeric>

namespace
{

using stm::CheckCellMesh;
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
    {
      for (int axis = 0; axis < D; ++axis)
      {
        points.push_back(static_cast<double>(point[axis]));
      }
    });
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

// ---------------------------------------------------------------------------------------------
// Meshes of polytopes P_j: cubes, pyramids, cones (CheckCellMesh).

/// Point ids of the corners of the box [lower, lower + 2)^... in code order, for points listed
/// in the order of `coordinates` (added on demand).
class PointList
{
public:
  template <std::size_t N>
  std::int64_t Id(const std::array<double, N>& point)
  {
    const std::vector<double> key(point.begin(), point.end());
    for (std::size_t id = 0; id < this->Keys.size(); ++id)
    {
      if (this->Keys[id] == key)
      {
        return static_cast<std::int64_t>(id);
      }
    }
    this->Keys.push_back(key);
    this->Coordinates.insert(this->Coordinates.end(), point.begin(), point.end());
    return static_cast<std::int64_t>(this->Keys.size()) - 1;
  }
  std::vector<double> Coordinates;

private:
  std::vector<std::vector<double>> Keys;
};

/// A single cell of the given shape and ids, checked alone.
template <int D>
MeshInvariantReport CheckOne(const std::vector<double>& points,
  const std::vector<std::int64_t>& ids, std::uint8_t shape, std::int64_t material = 0)
{
  const std::vector<std::int64_t> materials = { material };
  return CheckCellMesh<D>(points, ids, { shape }, &materials);
}

TEST(MeshInvariants, SingleHexahedronIsValidWithExactMeasures)
{
  // The cube [0,2]^3, corners in code order (bit i: far side along axis i).
  PointList points;
  std::vector<std::int64_t> ids;
  for (int c = 0; c < 8; ++c)
  {
    ids.push_back(points.Id(
      std::array<double, 3>{ 2.0 * (c & 1), 2.0 * ((c >> 1) & 1), 2.0 * ((c >> 2) & 1) }));
  }
  const MeshInvariantReport report = CheckOne<3>(points.Coordinates, ids, 3, 5);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_EQ(report.NumberOfCells, 1);
  EXPECT_EQ(report.NumberOfPoints, 8);
  EXPECT_EQ(report.BoundaryFacets, 6);
  EXPECT_EQ(report.OpenRidges, 0);
  EXPECT_EQ(report.HangingNodes, 0);
  EXPECT_TRUE(stmtest::ExactlyEqual(report.TotalVolume, 8.0));
  EXPECT_TRUE(stmtest::ExactlyEqual(report.MinimumVolume, 8.0));
  EXPECT_TRUE(stmtest::ExactlyEqual(report.VolumePerMaterial.at(5), 8.0));
  EXPECT_TRUE(stmtest::ExactlyEqual(report.BoundaryMeasure, 24.0));

  // Mirrored along the first axis (left-handed corner order): every Kuhn tetrahedron inverted.
  std::vector<std::int64_t> mirrored = ids;
  for (int c = 0; c < 8; c += 2)
  {
    std::swap(mirrored[c], mirrored[c + 1]);
  }
  const MeshInvariantReport inverted = CheckOne<3>(points.Coordinates, mirrored, 3);
  EXPECT_FALSE(inverted.IsValid());
  EXPECT_EQ(inverted.NonPositiveCells, 1);
  EXPECT_TRUE(stmtest::ExactlyEqual(inverted.TotalVolume, -8.0));
  EXPECT_EQ(inverted.BoundaryFacets, 6);

  // A shape out of range and a connectivity of the wrong length are invalid cells.
  EXPECT_EQ(CheckOne<3>(points.Coordinates, ids, 4).InvalidCells, 2);
  std::vector<std::int64_t> shortIds(ids.begin(), ids.end() - 1);
  EXPECT_EQ(CheckOne<3>(points.Coordinates, shortIds, 3).InvalidCells, 1);
  EXPECT_FALSE(CheckOne<3>(points.Coordinates, shortIds, 3).IsValid());
}

/// The pyramid over the square [0,2]^2 x {0} with the given apex: apex first, then the base in
/// code order.
std::vector<std::int64_t> Pyramid(PointList& points, const std::array<double, 3>& apex)
{
  std::vector<std::int64_t> ids = { points.Id(apex) };
  for (int c = 0; c < 4; ++c)
  {
    ids.push_back(points.Id(std::array<double, 3>{ 2.0 * (c & 1), 2.0 * (c >> 1), 0.0 }));
  }
  return ids;
}

TEST(MeshInvariants, PyramidIsValidAndInvertedPyramidIsDetected)
{
  // Apex (0,0,2) above base corner 0: volume 4 * 2 / 3 = 8/3 (two Kuhn tetrahedra of volume
  // 4/3). Boundary: the base (4), the triangles in x = 0 and y = 0 (2 each) and the two
  // slanted ones over the far edges (2 sqrt 2 each).
  PointList points;
  const std::vector<std::int64_t> up = Pyramid(points, { 0, 0, 2 });
  const MeshInvariantReport report = CheckOne<3>(points.Coordinates, up, 2);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_EQ(report.BoundaryFacets, 5);
  EXPECT_EQ(report.OpenRidges, 0);
  EXPECT_TRUE(stmtest::ExactlyEqual(report.TotalVolume, 16.0 / 6.0));
  EXPECT_DOUBLE_EQ(report.BoundaryMeasure, 8.0 + 4.0 * std::sqrt(2.0));

  // The base normal of corners 0, 1, 3, 2 points to +z: an apex below is inverted.
  PointList below;
  const std::vector<std::int64_t> down = Pyramid(below, { 1, 1, -2 });
  const MeshInvariantReport inverted = CheckOne<3>(below.Coordinates, down, 2);
  EXPECT_FALSE(inverted.IsValid());
  EXPECT_EQ(inverted.NonPositiveCells, 1) << inverted.Summary();
  EXPECT_TRUE(stmtest::ExactlyEqual(inverted.MinimumVolume, -16.0 / 6.0));
  EXPECT_EQ(inverted.BoundaryFacets, 5);
  EXPECT_EQ(inverted.OpenRidges, 0);

  // The base listed around the square (0, 1, 3, 2 as code order) is a twisted cube: one of its
  // two Kuhn tetrahedra is inverted.
  std::vector<std::int64_t> twisted = up;
  std::swap(twisted[3], twisted[4]);
  const MeshInvariantReport bad = CheckOne<3>(points.Coordinates, twisted, 2);
  EXPECT_EQ(bad.NonPositiveCells, 1) << bad.Summary();
  EXPECT_TRUE(stmtest::ExactlyEqual(bad.TotalVolume, 0.0));
}

TEST(MeshInvariants, QuadAndTrianglesInTwoDimensions)
{
  // The square [0,2]^2 and the square [2,4]x[0,2] cut into two triangles along (2,0)-(4,2):
  // a conforming mesh of the 4 x 2 rectangle, perimeter 12.
  const std::vector<double> points = { 0, 0, 2, 0, 0, 2, 2, 2, 4, 0, 4, 2 };
  const std::vector<std::int64_t> connectivity = { 0, 1, 2, 3, 1, 4, 5, 1, 5, 3 };
  const std::vector<std::uint8_t> shapes = { 2, 1, 1 };
  const std::vector<std::int64_t> materials = { 1, 2, 2 };
  const MeshInvariantReport report = CheckCellMesh<2>(points, connectivity, shapes, &materials);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_EQ(report.BoundaryFacets, 6);
  EXPECT_EQ(report.OvershareFacets, 0);
  EXPECT_EQ(report.OpenRidges, 0);
  EXPECT_EQ(report.HangingNodes, 0);
  EXPECT_TRUE(stmtest::ExactlyEqual(report.TotalVolume, 8.0));
  EXPECT_TRUE(stmtest::ExactlyEqual(report.MinimumVolume, 2.0));
  EXPECT_TRUE(stmtest::ExactlyEqual(report.VolumePerMaterial.at(1), 4.0));
  EXPECT_TRUE(stmtest::ExactlyEqual(report.VolumePerMaterial.at(2), 4.0));
  EXPECT_TRUE(stmtest::ExactlyEqual(report.BoundaryMeasure, 12.0));

  // The square listed around (0, 1, 3, 2): twisted, one Kuhn triangle inverted.
  const MeshInvariantReport twisted =
    CheckCellMesh<2>(points, { 0, 1, 3, 2, 1, 4, 5, 1, 5, 3 }, shapes, &materials);
  EXPECT_EQ(twisted.NonPositiveCells, 1) << twisted.Summary();

  // The same as simplices: CheckSimplicialMesh agrees with CheckCellMesh on simplicial input.
  const std::vector<std::int64_t> simplices = { 0, 1, 3, 0, 3, 2, 1, 4, 5, 1, 5, 3 };
  const MeshInvariantReport general =
    CheckCellMesh<2>(points, simplices, std::vector<std::uint8_t>(4, 1), nullptr);
  const MeshInvariantReport simplicial = CheckSimplicialMesh<2>(points, simplices, nullptr);
  EXPECT_TRUE(simplicial.IsValid()) << simplicial.Summary();
  EXPECT_EQ(simplicial.Summary(), general.Summary());
  EXPECT_EQ(simplicial.BoundaryMeasure, general.BoundaryMeasure);
  EXPECT_EQ(simplicial.BoundaryFacets, 6);
  // CheckSimplicialMesh rejects other shapes: it has no shapes, only Dim + 1 ids per cell.
  EXPECT_EQ(CheckSimplicialMesh<2>(points, { 0, 1, 3, 0 }, nullptr).InvalidCells, 1);
}

TEST(MeshInvariants, CoarseQuadNextToTwoFineQuadsHasAHangingNode)
{
  // [0,4]^2 next to [4,6]x[0,2] and [4,6]x[2,4]: (4,2) hangs on the coarse square's edge.
  const std::vector<double> points = { 0, 0, 4, 0, 0, 4, 4, 4, 6, 0, 4, 2, 6, 2, 6, 4 };
  const std::vector<std::int64_t> connectivity = { 0, 1, 2, 3, 1, 4, 5, 6, 5, 6, 3, 7 };
  const MeshInvariantReport report = CheckCellMesh<2>(points, connectivity, { 2, 2, 2 }, nullptr);
  EXPECT_FALSE(report.IsValid());
  EXPECT_EQ(report.HangingNodes, 1) << report.Summary();
  EXPECT_EQ(report.NonPositiveCells, 0);
  // The coarse edge and the two fine ones all lie on the boundary.
  EXPECT_EQ(report.BoundaryFacets, 10);
  EXPECT_EQ(report.OpenRidges, 0);
  EXPECT_TRUE(stmtest::ExactlyEqual(report.TotalVolume, 24.0));
}

TEST(MeshInvariants, HexahedronSplitIntoSixPyramidsAroundItsCentre)
{
  // [0,2]^3 coned from its centre (1,1,1) over its 6 square faces: volume 8, boundary 24, the
  // triangles between pyramids shared by two cells, no hanging node (no edge passes through
  // the centre).
  PointList points;
  std::vector<std::int64_t> connectivity;
  const std::int64_t centre = points.Id(std::array<double, 3>{ 1, 1, 1 });
  for (int axis = 0; axis < 3; ++axis)
  {
    for (int side = 0; side < 2; ++side)
    {
      std::array<stm::LatticeIndex<3>, 5> corners;
      for (int c = 0; c < 4; ++c)
      {
        stm::LatticeIndex<3> corner{};
        corner[axis] = 2 * side;
        corner[(axis + 1) % 3] = 2 * (c & 1);
        corner[(axis + 2) % 3] = 2 * (c >> 1);
        corners[c] = corner;
      }
      // Orientation: the simplex of base corners 0, 1, 2 and the apex.
      const std::array<stm::LatticeIndex<3>, 4> simplex = { corners[0], corners[1], corners[2],
        { 1, 1, 1 } };
      if (stmtest::ScaledSignedVolume<3>(simplex) < 0)
      {
        std::swap(corners[0], corners[1]);
        std::swap(corners[2], corners[3]);
      }
      connectivity.push_back(centre);
      for (int c = 0; c < 4; ++c)
      {
        connectivity.push_back(points.Id(std::array<double, 3>{ static_cast<double>(corners[c][0]),
          static_cast<double>(corners[c][1]), static_cast<double>(corners[c][2]) }));
      }
    }
  }
  const MeshInvariantReport report =
    CheckCellMesh<3>(points.Coordinates, connectivity, std::vector<std::uint8_t>(6, 2), nullptr);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_EQ(report.NumberOfCells, 6);
  EXPECT_EQ(report.NumberOfPoints, 9);
  EXPECT_EQ(report.BoundaryFacets, 6);
  EXPECT_TRUE(stmtest::ExactlyEqual(report.TotalVolume, 8.0));
  EXPECT_TRUE(stmtest::ExactlyEqual(report.MinimumVolume, 8.0 / 6.0));
  EXPECT_TRUE(stmtest::ExactlyEqual(report.BoundaryMeasure, 24.0));

  // Reversing the corner order of one pyramid turns it inside out.
  std::vector<std::int64_t> flipped = connectivity;
  std::swap(flipped[1], flipped[2]);
  std::swap(flipped[3], flipped[4]);
  const MeshInvariantReport bad =
    CheckCellMesh<3>(points.Coordinates, flipped, std::vector<std::uint8_t>(6, 2), nullptr);
  EXPECT_EQ(bad.NonPositiveCells, 1) << bad.Summary();
  EXPECT_EQ(bad.BoundaryFacets, 6);
}

TEST(MeshInvariants, SquareFacingTwoTrianglesIsNotConforming)
{
  // The cube [0,2]^3, and over its face x = 2 the pyramid with apex (4,1,1), either as one
  // pyramid (conforming) or as two tetrahedra cut along the face diagonal (2,0,0)-(2,2,2): then
  // the square and the two triangles are different facets, all on the boundary, and the square
  // contains the triangles. Ridges stay paired: only the overlap reveals it.
  PointList points;
  std::vector<std::int64_t> cube;
  for (int c = 0; c < 8; ++c)
  {
    cube.push_back(points.Id(
      std::array<double, 3>{ 2.0 * (c & 1), 2.0 * ((c >> 1) & 1), 2.0 * ((c >> 2) & 1) }));
  }
  const std::int64_t apex = points.Id(std::array<double, 3>{ 4, 1, 1 });
  // The face x = 2 in code order over (y, z): cube corners 1, 3, 5, 7. The pyramid's base
  // normal (corners 0, 1, 3, 2 = (2,0,0) (2,2,0) (2,2,2) (2,0,2)) points to +x, towards the apex.
  std::vector<std::int64_t> connectivity = cube;
  connectivity.insert(connectivity.end(), { apex, cube[1], cube[3], cube[5], cube[7] });
  const MeshInvariantReport conforming =
    CheckCellMesh<3>(points.Coordinates, connectivity, { 3, 2 }, nullptr);
  EXPECT_TRUE(conforming.IsValid()) << conforming.Summary();
  EXPECT_EQ(conforming.BoundaryFacets, 9);
  EXPECT_EQ(conforming.NonConformingFacets, 0);
  EXPECT_TRUE(stmtest::ExactlyEqual(conforming.TotalVolume, 64.0 / 6.0));

  // Tetrahedra (2,0,0) (2,2,0) (2,2,2) apex and (2,0,0) (2,2,2) (2,0,2) apex, oriented.
  connectivity = cube;
  connectivity.insert(
    connectivity.end(), { cube[1], cube[3], cube[7], apex, cube[1], cube[7], cube[5], apex });
  const MeshInvariantReport split =
    CheckCellMesh<3>(points.Coordinates, connectivity, { 3, 1, 1 }, nullptr);
  EXPECT_FALSE(split.IsValid());
  EXPECT_EQ(split.NonPositiveCells, 0) << split.Summary();
  EXPECT_EQ(split.NonConformingFacets, 1);
  // The cube's 6 facets and the tetrahedra's 6 unshared facets (the triangle between them is
  // shared).
  EXPECT_EQ(split.BoundaryFacets, 12);
  EXPECT_EQ(split.OvershareFacets, 0);
  EXPECT_EQ(split.OpenRidges, 0);
  EXPECT_EQ(split.HangingNodes, 0);
  EXPECT_TRUE(stmtest::ExactlyEqual(split.TotalVolume, 64.0 / 6.0));
  // The square and the two triangles (2 each) are counted on top of the true boundary.
  EXPECT_DOUBLE_EQ(split.BoundaryMeasure, conforming.BoundaryMeasure + 8.0);
}

/// Cells of the cube [0,4]^D coned recursively from face centres `depth` times (the recursive
/// midpoint rule of the hybrid tessellation stopped early): the faces reached after `depth`
/// cones, or edges, are kept whole. depth 0 is the cube, depth 1 the 2D cones from the centre
/// over the facets, depth D - 1 simplices only. Oriented by the exact determinant of the
/// simplex of cube corners 0, 1, 2, 4, ... followed by the apexes.
template <int D>
void MakeConedCube(int depth, std::vector<double>& points, std::vector<std::int64_t>& connectivity,
  std::vector<std::uint8_t>& shapes)
{
  // Only the points used get ids: an unused lattice point at the midpoint of an edge would hang.
  std::map<stm::LatticeIndex<D>, std::int64_t> ids;
  auto idOf = [&](const stm::LatticeIndex<D>& point)
  {
    const auto inserted = ids.emplace(point, static_cast<std::int64_t>(ids.size()));
    if (inserted.second)
    {
      for (int axis = 0; axis < D; ++axis)
      {
        points.push_back(static_cast<double>(point[axis]));
      }
    }
    return inserted.first->second;
  };
  // A face: its anchor and free axes; apexes: the centres so far, outermost first.
  struct Face
  {
    stm::LatticeIndex<D> Anchor;
    unsigned Free;
  };
  std::vector<stm::LatticeIndex<D>> apexes;
  auto emit = [&](const Face& face, int k)
  {
    std::vector<stm::LatticeIndex<D>> corners;
    for (int c = 0; c < (1 << k); ++c)
    {
      stm::LatticeIndex<D> corner = face.Anchor;
      for (int axis = 0, index = 0; axis < D; ++axis)
      {
        if (face.Free & (1u << axis))
        {
          corner[axis] += 4 * ((c >> index++) & 1);
        }
      }
      corners.push_back(corner);
    }
    std::array<stm::LatticeIndex<D>, D + 1> simplex;
    simplex[0] = corners[0];
    for (int i = 0; i < k; ++i)
    {
      simplex[1 + i] = corners[1 << i];
    }
    std::copy(apexes.begin(), apexes.end(), simplex.begin() + 1 + k);
    if (stmtest::ScaledSignedVolume<D>(simplex) < 0)
    {
      for (int c = 0; c < (1 << k); c += 2)
      {
        std::swap(corners[c], corners[c + 1]);
      }
    }
    for (const auto& point : apexes)
    {
      connectivity.push_back(idOf(point));
    }
    for (const auto& point : corners)
    {
      connectivity.push_back(idOf(point));
    }
    shapes.push_back(static_cast<std::uint8_t>(k));
  };
  std::function<void(const Face&)> recurse = [&](const Face& face)
  {
    const int k = stm::PopCount(face.Free);
    if (k == 1 || static_cast<int>(apexes.size()) == depth)
    {
      emit(face, k);
      return;
    }
    stm::LatticeIndex<D> centre = face.Anchor;
    for (int axis = 0; axis < D; ++axis)
    {
      centre[axis] += (face.Free & (1u << axis)) ? 2 : 0;
    }
    apexes.push_back(centre);
    for (int axis = 0; axis < D; ++axis)
    {
      if (face.Free & (1u << axis))
      {
        for (int side = 0; side < 2; ++side)
        {
          Face facet{ face.Anchor, face.Free & ~(1u << axis) };
          facet.Anchor[axis] += 4 * side;
          recurse(facet);
        }
      }
    }
    apexes.pop_back();
  };
  recurse(Face{ stm::LatticeIndex<D>{}, (1u << D) - 1u });
}

/// Pieces of a k-cube coned `depth` times: 2k facets each coned depth - 1 times; edges whole.
constexpr std::int64_t ConedPieces(int k, int depth)
{
  return k == 1 || depth == 0 ? 1 : 2 * k * ConedPieces(k - 1, depth - 1);
}

TYPED_TEST(MeshInvariantsTest, ConedCubesOfEveryShapeAreValidWithExactMeasures)
{
  constexpr int D = TypeParam::value;
  for (int depth = 0; depth < D; ++depth)
  {
    SCOPED_TRACE("depth " + std::to_string(depth));
    std::vector<double> points;
    std::vector<std::int64_t> connectivity;
    std::vector<std::uint8_t> shapes;
    MakeConedCube<D>(depth, points, connectivity, shapes);
    const std::vector<std::int64_t> materials(shapes.size(), 3);
    const MeshInvariantReport report = CheckCellMesh<D>(points, connectivity, shapes, &materials);
    EXPECT_TRUE(report.IsValid()) << report.Summary();
    EXPECT_EQ(report.NonPositiveCells, 0);
    EXPECT_EQ(report.OvershareFacets, 0);
    EXPECT_EQ(report.NonConformingFacets, 0);
    EXPECT_EQ(report.OpenRidges, 0);
    EXPECT_EQ(report.HangingNodes, 0);
    EXPECT_EQ(report.InvalidCells, 0);
    EXPECT_EQ(report.NumberOfCells, ConedPieces(D, depth));
    EXPECT_EQ(report.BoundaryFacets, depth == 0 ? 2 * D : 2 * D * ConedPieces(D - 1, depth - 1));
    const double volume = static_cast<double>(stm::IntPow(4, D));
    EXPECT_TRUE(stmtest::ExactlyEqual(report.TotalVolume, volume));
    EXPECT_TRUE(stmtest::ExactlyEqual(report.VolumePerMaterial.at(3), volume));
    EXPECT_TRUE(stmtest::ExactlyEqual(
      report.BoundaryMeasure, static_cast<double>(2 * D * stm::IntPow(4, D - 1))));
    if (D > 1 && depth > 0)
    {
      // Inverting one cell is detected whatever its shape.
      const int shape = shapes[0];
      std::vector<std::int64_t> inverted = connectivity;
      const int first = D - shape;
      for (int c = 0; c < (1 << shape); c += 2)
      {
        std::swap(inverted[first + c], inverted[first + c + 1]);
      }
      EXPECT_EQ(CheckCellMesh<D>(points, inverted, shapes, nullptr).NonPositiveCells, 1);
    }
  }
}

TYPED_TEST(MeshInvariantsTest, GridOfCubesAndSimplicesIsConformingOnlyInTwoDimensions)
{
  // A 2^D grid of cubes of edge 1: those with x < 1 stay cubes, the others are cut into Kuhn
  // simplices. In 2D the interface is an edge, shared; from 3D on, each interface (D-1)-cube
  // faces (D-1)! simplex facets: all are boundary facets, and each square contains its
  // triangles.
  constexpr int D = TypeParam::value;
  const stm::LatticeIndex<D> pointDims = stmtest::UniformExtents<D>(3);
  std::vector<double> points;
  stmtest::ForEachIndex<D>(pointDims,
    [&](const stm::LatticeIndex<D>& point)
    {
      for (int axis = 0; axis < D; ++axis)
      {
        points.push_back(static_cast<double>(point[axis]));
      }
    });
  std::vector<std::int64_t> connectivity;
  std::vector<std::uint8_t> shapes;
  stmtest::ForEachIndex<D>(stmtest::UniformExtents<D>(2),
    [&](const stm::LatticeIndex<D>& cube)
    {
      auto corner = [&](int c)
      {
        stm::LatticeIndex<D> point = cube;
        for (int axis = 0; axis < D; ++axis)
        {
          point[axis] += (c >> axis) & 1;
        }
        return stm::LinearIndex<D>(point, pointDims);
      };
      if (cube[0] == 0)
      {
        for (int c = 0; c < (1 << D); ++c)
        {
          connectivity.push_back(corner(c));
        }
        shapes.push_back(static_cast<std::uint8_t>(D));
        return;
      }
      std::array<int, D> axes;
      std::iota(axes.begin(), axes.end(), 0);
      do
      {
        std::array<stm::LatticeIndex<D>, D + 1> path;
        std::array<std::int64_t, D + 1> ids;
        int c = 0;
        path[0] = cube;
        ids[0] = corner(0);
        for (int step = 0; step < D; ++step)
        {
          path[step + 1] = path[step];
          ++path[step + 1][axes[step]];
          c |= 1 << axes[step];
          ids[step + 1] = corner(c);
        }
        if (stmtest::ScaledSignedVolume<D>(path) < 0)
        {
          std::swap(ids[0], ids[1]);
        }
        connectivity.insert(connectivity.end(), ids.begin(), ids.end());
        shapes.push_back(1);
      } while (std::next_permutation(axes.begin(), axes.end()));
    });
  const MeshInvariantReport report = CheckCellMesh<D>(points, connectivity, shapes, nullptr);
  const std::int64_t half = stm::IntPow(2, D - 1); // cubes per half, interface squares
  EXPECT_EQ(report.NumberOfCells, half + half * stm::Factorial(D));
  EXPECT_EQ(report.NonPositiveCells, 0) << report.Summary();
  EXPECT_EQ(report.OvershareFacets, 0);
  EXPECT_EQ(report.OpenRidges, 0);
  EXPECT_EQ(report.HangingNodes, 0);
  EXPECT_TRUE(stmtest::ExactlyEqual(report.TotalVolume, static_cast<double>(2 * half)));
  // The outer boundary: on x = 0 cube facets, on x = 2 simplex facets, on the 2(D-1) other
  // sides half of each; plus, from 3D on, the interface seen from both sides.
  const std::int64_t simplexFacets = stm::Factorial(D - 1);
  std::int64_t facets = half + half * simplexFacets;
  if (D > 1)
  {
    facets += 2 * (D - 1) * (half / 2) * (1 + simplexFacets);
  }
  const std::int64_t outerMeasure = 2 * D * half;
  if (D <= 2)
  {
    EXPECT_TRUE(report.IsValid()) << report.Summary();
    EXPECT_EQ(report.NonConformingFacets, 0);
    EXPECT_EQ(report.BoundaryFacets, facets);
    EXPECT_TRUE(stmtest::ExactlyEqual(report.BoundaryMeasure, static_cast<double>(outerMeasure)));
  }
  else
  {
    EXPECT_FALSE(report.IsValid());
    EXPECT_EQ(report.NonConformingFacets, half);
    EXPECT_EQ(report.BoundaryFacets, facets + half + half * simplexFacets);
    EXPECT_TRUE(
      stmtest::ExactlyEqual(report.BoundaryMeasure, static_cast<double>(outerMeasure + 2 * half)));
  }
}

} // namespace
