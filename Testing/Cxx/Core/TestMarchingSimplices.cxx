// SPDX-License-Identifier: BSD-3-Clause
// Marching simplices and the voxel separating function: the case tables, every sign pattern of
// a simplex in 1D to 4D, cut meshes of adaptive spacetrees (conformity, volumes, cell order and
// thread independence), closed oriented iso-surfaces, and the literal staircase that cuts nothing.

#include "CoreTestUtilities.h"

#include "Check/MeshInvariants.h"
#include "Common/Determinant.h"
#include "Cut/MarchingSimplices.h"
#include "Cut/SeparatingFunction.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <vector>

namespace
{
using namespace stmtest;
using stm::CutSide;
using stm::VertexClass;

template <int D>
CutSide OutsideIfAllZero(std::int64_t)
{
  return CutSide::Outside;
}

template <class T>
class MarchingSimplicesTest : public ::testing::Test
{
};
TYPED_TEST_SUITE(MarchingSimplicesTest, AllDimensions);

// The case tables agree with the pieces actually generated, and with the paper's 3D counts.
TYPED_TEST(MarchingSimplicesTest, CaseTablesMatchThePieces)
{
  constexpr int D = TypeParam::value;
  using Info = stm::SimplexCutInfo<D>;
  for (int caseIndex = 0; caseIndex < Info::Cases; ++caseIndex)
  {
    for (int permutation = 0; permutation < 2; ++permutation)
    {
      int counts[2] = { 0, 0 };
      // Two global orders: the pulling triangulation must not change the counts.
      auto globalId = [permutation](const stm::PieceVertex& v)
      {
        const int a = permutation ? D - v.A : v.A;
        const int b = permutation ? D - v.B : v.B;
        return static_cast<std::int64_t>(v.IsCut() ? 10 + std::min(a, b) * 10 + std::max(a, b) : a);
      };
      stm::ForEachPiece<D>(caseIndex, CutSide::Inside, globalId,
        [&](const stm::PieceVertex*, CutSide side) { ++counts[static_cast<int>(side)]; });
      if (caseIndex == Info::AllZeroCase())
      {
        EXPECT_EQ(counts[0], 1);
        EXPECT_EQ(Info::InsideSimplices[caseIndex] + Info::OutsideSimplices[caseIndex], 0);
        continue;
      }
      EXPECT_EQ(counts[0], Info::InsideSimplices[caseIndex]) << "case " << caseIndex;
      EXPECT_EQ(counts[1], Info::OutsideSimplices[caseIndex]) << "case " << caseIndex;
      EXPECT_LE(std::max(counts[0], counts[1]), Info::MaxPieceSimplices);
    }
  }
  EXPECT_EQ(Info::Cases, stm::detail::Power3(D + 1));
  if (D == 3)
  {
    // The paper's cases as (n+, n0, n-) with vertex 0..3: classes digits 0 (-), 1 (0), 2 (+).
    auto caseOf = [](std::array<int, 4> classes)
    { return classes[0] + 3 * classes[1] + 9 * classes[2] + 27 * classes[3]; };
    EXPECT_EQ(Info::OutsideSimplices[caseOf({ 2, 2, 2, 0 })], 3); // (3,0,1): prism
    EXPECT_EQ(Info::InsideSimplices[caseOf({ 2, 2, 2, 0 })], 1);  //          and tet
    EXPECT_EQ(Info::OutsideSimplices[caseOf({ 2, 2, 0, 0 })], 3); // (2,0,2): two prisms
    EXPECT_EQ(Info::InsideSimplices[caseOf({ 2, 2, 0, 0 })], 3);
    EXPECT_EQ(Info::OutsideSimplices[caseOf({ 2, 2, 1, 0 })], 2); // (2,1,1): pyramid
    EXPECT_EQ(Info::InsideSimplices[caseOf({ 2, 2, 1, 0 })], 1);  //          and tet
    EXPECT_EQ(Info::OutsideSimplices[caseOf({ 2, 1, 1, 0 })], 1); // (1,2,1): two tets
    EXPECT_EQ(Info::InsideSimplices[caseOf({ 2, 1, 1, 0 })], 1);
    EXPECT_EQ(Info::CutEdgeCounts[caseOf({ 2, 2, 0, 0 })], 4);
    EXPECT_EQ(Info::CutEdgeCounts[caseOf({ 1, 1, 1, 1 })], 0);
  }
  if (D == 2)
  {
    auto caseOf = [](std::array<int, 3> classes)
    { return classes[0] + 3 * classes[1] + 9 * classes[2]; };
    EXPECT_EQ(Info::OutsideSimplices[caseOf({ 2, 2, 0 })], 2); // (2,0,1): quad
    EXPECT_EQ(Info::InsideSimplices[caseOf({ 2, 2, 0 })], 1);  //          and triangle
    EXPECT_EQ(Info::OutsideSimplices[caseOf({ 2, 1, 0 })], 1); // (1,1,1): two triangles
    EXPECT_EQ(Info::InsideSimplices[caseOf({ 2, 1, 0 })], 1);
  }
}

// Every sign pattern of a simplex, random positions and values (zero vertices within the
// tolerance): the pieces tile the parent with positive volumes, lie on their side, and the
// interface facets lie on the zero set, oriented towards the outside.
TYPED_TEST(MarchingSimplicesTest, EverySignPatternTilesTheSimplex)
{
  constexpr int D = TypeParam::value;
  using Info = stm::SimplexCutInfo<D>;
  std::mt19937 random(7 + D);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  stm::MarchingSimplicesOptions options;
  options.IsoValue = 0.25;
  options.ZeroTolerance = 1e-6;
  stm::SequentialExecutor executor;
  for (int caseIndex = 0; caseIndex < Info::Cases; ++caseIndex)
  {
    for (int trial = 0; trial < 20; ++trial)
    {
      std::vector<double> coordinates;
      std::vector<std::int64_t> ids(D + 1);
      std::iota(ids.begin(), ids.end(), 0);
      double parentVolume = 0.0;
      do
      {
        coordinates.clear();
        for (int i = 0; i < (D + 1) * D; ++i)
        {
          coordinates.push_back(unit(random));
        }
        parentVolume = ScaledVolume<D>(coordinates, ids.data());
      } while (std::abs(parentVolume) < 0.05);
      if (parentVolume < 0)
      {
        std::swap(ids[0], ids[1]);
        parentVolume = -parentVolume;
      }
      std::vector<double> values(D + 1);
      for (int v = 0; v <= D; ++v)
      {
        const VertexClass vertexClass = Info::ClassOf(caseIndex, v);
        const double magnitude = 0.01 + std::abs(unit(random));
        values[v] = options.IsoValue +
          (vertexClass == VertexClass::Negative      ? -magnitude
              : vertexClass == VertexClass::Positive ? magnitude
                                                     : 0.5e-6 * unit(random));
      }
      // The cell's own vertex order is ids; its case is read from the values in that order.
      const CutResult<D> cut =
        Cut<D>(coordinates, values, ids, options, executor, OutsideIfAllZero<D>);
      ASSERT_TRUE(cut.Result.IsOk()) << cut.Result.GetMessage();
      double sum = 0.0;
      for (std::int64_t cell = 0; cell < cut.GetNumberOfCells(); ++cell)
      {
        const std::int64_t* piece = cut.Connectivity.data() + cell * (D + 1);
        const double volume = ScaledVolume<D>(cut.Coordinates, piece);
        EXPECT_GT(volume, 0.0) << "case " << caseIndex << " trial " << trial;
        sum += volume;
        for (int v = 0; v <= D; ++v)
        {
          const double f = cut.Values[piece[v]] - options.IsoValue;
          if (cut.Sides[cell] == static_cast<std::uint8_t>(CutSide::Inside))
          {
            EXPECT_LE(f, options.ZeroTolerance) << "case " << caseIndex;
          }
          else
          {
            EXPECT_GE(f, -options.ZeroTolerance) << "case " << caseIndex;
          }
        }
      }
      EXPECT_NEAR(sum, parentVolume, 1e-12 * parentVolume) << "case " << caseIndex;
      // A single simplex has no interface facet between two pieces only when it is not split.
      const bool split = Info::CutEdgeCounts[caseIndex] > 0;
      EXPECT_EQ(cut.SplitCells, split ? 1 : 0);
      EXPECT_EQ(cut.Surface.empty(), !split) << "case " << caseIndex;
      for (std::size_t first = 0; first < cut.Surface.size(); first += D)
      {
        for (int v = 0; v < D; ++v)
        {
          EXPECT_NEAR(cut.Values[cut.Surface[first + v]], options.IsoValue, options.ZeroTolerance);
        }
        if (D >= 2)
        {
          // Outward: the facet and a positive vertex make a positive simplex.
          for (int v = 0; v <= D; ++v)
          {
            if (Info::ClassOf(caseIndex, static_cast<int>(ids[v])) == VertexClass::Positive)
            {
              std::vector<std::int64_t> simplex(
                cut.Surface.begin() + first, cut.Surface.begin() + first + D);
              simplex.push_back(ids[v]);
              // An outward facet followed by an outside point has the sign (-1)^(d+1).
              const double volume = ScaledVolume<D>(cut.Coordinates, simplex.data());
              EXPECT_GT(D % 2 == 1 ? volume : -volume, 0.0) << "case " << caseIndex;
            }
          }
        }
      }
    }
  }
}

/// Coordinates of a tessellation in lattice units.
template <int D>
std::vector<double> LatticeCoordinates(const SimplicialMesh<D>& mesh)
{
  return mesh.Coordinates();
}

template <int D>
SimplicialMesh<D> AdaptiveMesh(unsigned seed, std::int64_t extent)
{
  const LabelImage<D> image = MakeRandomImage<D>(UniformExtents<D>(extent), seed, 2, 3, 20);
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  EXPECT_TRUE(BuildTree<D>(image, 4, 1, false, executor, tree).IsOk());
  stm::SpacetreeTessellationOptions options;
  options.IncludeBackground = true;
  SimplicialMesh<D> mesh;
  stm::SpacetreeTessellator<D> tessellator;
  EXPECT_TRUE(TessellateTree<D>(tree, options, executor, mesh, tessellator).IsOk());
  return mesh;
}

/// A smooth function with a closed zero set inside the box [0, extent]^D: a ball.
template <int D>
std::vector<double> BallFunction(
  const std::vector<double>& coordinates, double centre, double radius)
{
  std::vector<double> values(coordinates.size() / D);
  for (std::size_t p = 0; p < values.size(); ++p)
  {
    double r2 = 0.0;
    for (int axis = 0; axis < D; ++axis)
    {
      const double x = coordinates[p * D + axis] - centre - 0.1 * axis;
      r2 += x * x;
    }
    values[p] = r2 - radius * radius;
  }
  return values;
}

template <class T>
class PieceOrientationTest : public ::testing::Test
{
};
using TableDimensions = ::testing::Types<Dim<1>, Dim<2>, Dim<3>>;
TYPED_TEST_SUITE(PieceOrientationTest, TableDimensions);

// The orientation table holds the sign of the barycentric determinant of every tuple of piece
// vertices (vertices and edge midpoints, in either order of an edge's ends), and the codes
// number the vertices and then the edges without a gap.
TYPED_TEST(PieceOrientationTest, SignsAreTheBarycentricDeterminants)
{
  constexpr int D = TypeParam::value;
  using Table = stm::PieceOrientation<D>;
  std::vector<stm::PieceVertex> vertices;
  std::set<int> codes;
  for (int a = 0; a <= D; ++a)
  {
    for (int b = 0; b <= D; ++b)
    {
      vertices.push_back({ static_cast<std::int8_t>(a), static_cast<std::int8_t>(b) });
      EXPECT_EQ(Table::CodeTable[a][b], Table::CodeTable[b][a]);
      codes.insert(Table::CodeTable[a][b]);
    }
  }
  EXPECT_EQ(static_cast<int>(codes.size()), Table::Codes);
  EXPECT_EQ(*codes.begin(), 0);
  EXPECT_EQ(*codes.rbegin(), Table::Codes - 1);
  const int n = static_cast<int>(vertices.size());
  int tuples = 1;
  for (int v = 0; v <= D; ++v)
  {
    tuples *= n;
  }
  int positive = 0, negative = 0, wrong = 0;
  for (int t = 0; t < tuples; ++t)
  {
    stm::PieceVertex simplex[D + 1];
    for (int v = D, rest = t; v >= 0; --v, rest /= n)
    {
      simplex[v] = vertices[rest % n];
    }
    const double determinant = stm::BarycentricDeterminant<D>(simplex);
    const int expected = determinant > 0.0 ? 1 : determinant < 0.0 ? -1 : 0;
    const int sign = Table::Signs[Table::IndexOf(simplex)];
    wrong += sign != expected;
    positive += expected > 0;
    negative += expected < 0;
  }
  EXPECT_EQ(wrong, 0);
  // Both orientations occur as often: swapping two rows flips the sign.
  EXPECT_EQ(positive, negative);
  EXPECT_GT(positive, 0);
  // The identity (the parent's own vertices) is positive, two vertices swapped negative.
  stm::PieceVertex parent[D + 1];
  for (int v = 0; v <= D; ++v)
  {
    parent[v] = { static_cast<std::int8_t>(v), static_cast<std::int8_t>(v) };
  }
  EXPECT_EQ(Table::Signs[Table::IndexOf(parent)], 1);
  std::swap(parent[0], parent[1]);
  EXPECT_EQ(Table::Signs[Table::IndexOf(parent)], -1);
}

template <class T>
class PieceTableTest : public ::testing::Test
{
};
TYPED_TEST_SUITE(PieceTableTest, TableDimensions);

// The piece table holds exactly ForEachPiece's pieces (vertices, order and sides) for every
// case and every order of the corners' numbers, with the cut vertices numbered after all
// points in the sorted order of their edges as MarchingSimplices numbers them; the order
// index numbers the (D + 1)! orders without a gap.
TYPED_TEST(PieceTableTest, EntriesAreThePullingPiecesOfEveryOrder)
{
  constexpr int D = TypeParam::value;
  using Table = stm::PieceTable<D>;
  using Info = stm::SimplexCutInfo<D>;
  const Table& table = Table::Get();
  std::mt19937_64 random(31 + D);
  std::uniform_int_distribution<std::int64_t> id(0, 999999);
  constexpr std::int64_t cutBase = 1000000;
  std::set<int> orders;
  int compared = 0;
  for (int trial = 0; trial < 3; ++trial)
  {
    std::vector<std::int64_t> ids;
    while (static_cast<int>(ids.size()) < D + 1)
    {
      const std::int64_t candidate = id(random);
      if (std::find(ids.begin(), ids.end(), candidate) == ids.end())
      {
        ids.push_back(candidate);
      }
    }
    std::sort(ids.begin(), ids.end());
    do
    {
      // The cell's edges sorted by (min, max) of their ends' numbers: the cut vertices' order.
      std::vector<std::pair<std::int64_t, std::int64_t>> edges;
      for (int a = 0; a <= D; ++a)
      {
        for (int b = a + 1; b <= D; ++b)
        {
          edges.push_back(std::minmax(ids[a], ids[b]));
        }
      }
      std::sort(edges.begin(), edges.end());
      auto globalId = [&](const stm::PieceVertex& v)
      {
        if (!v.IsCut())
        {
          return ids[v.A];
        }
        const std::pair<std::int64_t, std::int64_t> edge = std::minmax(ids[v.A], ids[v.B]);
        return cutBase + (std::lower_bound(edges.begin(), edges.end(), edge) - edges.begin());
      };
      const int order = Table::OrderOf(ids.data());
      ASSERT_GE(order, 0);
      ASSERT_LT(order, Table::Orders);
      orders.insert(order);
      for (int caseIndex = 0; caseIndex < Info::Cases; ++caseIndex)
      {
        std::vector<stm::PieceVertex> expected;
        std::vector<CutSide> sides;
        stm::ForEachPiece<D>(caseIndex, CutSide::Inside, globalId,
          [&](const stm::PieceVertex* simplex, CutSide side)
          {
            expected.insert(expected.end(), simplex, simplex + D + 1);
            sides.push_back(side);
          });
        const typename Table::Entry& entry = table.Of(caseIndex, order);
        ASSERT_EQ(static_cast<std::size_t>(entry.Count), sides.size()) << "case " << caseIndex;
        EXPECT_EQ(static_cast<int>(entry.Count),
          caseIndex == Info::AllZeroCase()
            ? 1
            : std::max(1, Info::InsideSimplices[caseIndex] + Info::OutsideSimplices[caseIndex]));
        for (int piece = 0; piece < entry.Count; ++piece)
        {
          EXPECT_EQ(entry.Sides[piece], sides[piece]);
          for (int v = 0; v <= D; ++v)
          {
            EXPECT_EQ(entry.Pieces[piece][v].A, expected[piece * (D + 1) + v].A);
            EXPECT_EQ(entry.Pieces[piece][v].B, expected[piece * (D + 1) + v].B);
          }
        }
        ++compared;
      }
    } while (std::next_permutation(ids.begin(), ids.end()));
  }
  EXPECT_EQ(static_cast<int>(orders.size()), Table::Orders);
  EXPECT_EQ(*orders.begin(), 0);
  EXPECT_EQ(*orders.rbegin(), Table::Orders - 1);
  EXPECT_EQ(compared, 3 * Table::Orders * Info::Cases);
}

template <class T>
class MarchingSimplicesMeshTest : public ::testing::Test
{
};
using MeshDimensions = ::testing::Types<Dim<2>, Dim<3>>;
TYPED_TEST_SUITE(MarchingSimplicesMeshTest, MeshDimensions);

// Quantised random values (many exact zeros, every case) on adaptive meshes: the cut mesh is
// conforming with positive volumes and the input's volume; the cut is the same for every cell
// order and every number of threads.
TYPED_TEST(MarchingSimplicesMeshTest, CutMeshesAreConformingAndOrderIndependent)
{
  constexpr int D = TypeParam::value;
  for (unsigned seed = 1; seed <= 3; ++seed)
  {
    const SimplicialMesh<D> mesh = AdaptiveMesh<D>(seed, D == 2 ? 24 : 10);
    const std::vector<double> coordinates = LatticeCoordinates<D>(mesh);
    std::mt19937 random(seed);
    std::vector<double> values(static_cast<std::size_t>(mesh.GetNumberOfPoints()));
    for (double& value : values)
    {
      value = static_cast<double>(static_cast<int>(random() % 5) - 2) / 2.0;
    }
    stm::MarchingSimplicesOptions options;
    stm::SequentialExecutor sequential;
    auto sideOfMaterial = [&mesh](std::int64_t cell) {
      return mesh.Materials[cell] == stm::BackgroundMaterial ? CutSide::Outside : CutSide::Inside;
    };
    const CutResult<D> cut =
      Cut<D>(coordinates, values, mesh.Connectivity, options, sequential, sideOfMaterial);
    ASSERT_TRUE(cut.Result.IsOk());
    EXPECT_GT(cut.SplitCells, 0);
    const stm::MeshInvariantReport before = CheckMesh<D>(mesh);
    const stm::MeshInvariantReport report =
      stm::CheckSimplicialMesh<D>(cut.Coordinates, cut.Connectivity, nullptr);
    EXPECT_TRUE(report.IsValid()) << report.Summary();
    EXPECT_NEAR(report.TotalVolume, before.TotalVolume, 1e-9 * before.TotalVolume);
    EXPECT_EQ(report.BoundaryFacets >= before.BoundaryFacets, true);

    // Thread independence: identical arrays.
    stm::ThreadPoolExecutor threads(4);
    const CutResult<D> threaded =
      Cut<D>(coordinates, values, mesh.Connectivity, options, threads, sideOfMaterial);
    EXPECT_EQ(threaded.Connectivity, cut.Connectivity);
    EXPECT_EQ(threaded.Sides, cut.Sides);
    EXPECT_EQ(threaded.Coordinates, cut.Coordinates);
    EXPECT_EQ(threaded.Surface, cut.Surface);

    // Cell order independence: the same cells (vertex sets and sides), the same points.
    std::vector<std::int64_t> order(static_cast<std::size_t>(mesh.GetNumberOfSimplices()));
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), random);
    std::vector<std::int64_t> shuffled;
    for (std::int64_t cell : order)
    {
      // Rotate the vertex order too (an even permutation keeps the orientation in any D
      // when applied twice; use a cyclic shift by two positions).
      std::array<std::int64_t, D + 1> ids;
      for (int v = 0; v <= D; ++v)
      {
        ids[v] = mesh.Connectivity[cell * (D + 1) + v];
      }
      std::swap(ids[0], ids[1]);
      std::swap(ids[1], ids[2]);
      shuffled.insert(shuffled.end(), ids.begin(), ids.end());
    }
    auto shuffledSide = [&](std::int64_t cell) { return sideOfMaterial(order[cell]); };
    const CutResult<D> permuted =
      Cut<D>(coordinates, values, shuffled, options, sequential, shuffledSide);
    EXPECT_EQ(permuted.Coordinates, cut.Coordinates);
    auto cellSet = [](const CutResult<D>& result)
    {
      std::multiset<std::vector<std::int64_t>> cells;
      for (std::int64_t cell = 0; cell < result.GetNumberOfCells(); ++cell)
      {
        std::vector<std::int64_t> key(result.Connectivity.begin() + cell * (D + 1),
          result.Connectivity.begin() + (cell + 1) * (D + 1));
        std::sort(key.begin(), key.end());
        key.push_back(result.Sides[cell]);
        cells.insert(key);
      }
      return cells;
    };
    EXPECT_EQ(cellSet(permuted), cellSet(cut));
    const stm::MeshInvariantReport permutedReport =
      stm::CheckSimplicialMesh<D>(permuted.Coordinates, permuted.Connectivity, nullptr);
    EXPECT_TRUE(permutedReport.IsValid()) << permutedReport.Summary();
  }
}

// A closed level set gives a closed, oriented surface (each ridge in exactly two facets, once
// each way; a sphere's Euler characteristic in 3D), enclosing exactly the inside volume.
TYPED_TEST(MarchingSimplicesMeshTest, ClosedLevelSetGivesClosedOrientedSurface)
{
  constexpr int D = TypeParam::value;
  const std::int64_t extent = D == 2 ? 24 : 12;
  const SimplicialMesh<D> mesh = AdaptiveMesh<D>(5, extent);
  const std::vector<double> coordinates = LatticeCoordinates<D>(mesh);
  const std::vector<double> values = BallFunction<D>(
    coordinates, 0.5 * static_cast<double>(extent), 0.3 * static_cast<double>(extent));
  stm::SequentialExecutor executor;
  const CutResult<D> cut = Cut<D>(coordinates, values, mesh.Connectivity,
    stm::MarchingSimplicesOptions(), executor, OutsideIfAllZero<D>);
  ASSERT_TRUE(cut.Result.IsOk());
  ASSERT_FALSE(cut.Surface.empty());
  double insideVolume = 0.0;
  for (std::int64_t cell = 0; cell < cut.GetNumberOfCells(); ++cell)
  {
    if (cut.Sides[cell] == static_cast<std::uint8_t>(CutSide::Inside))
    {
      insideVolume += ScaledVolume<D>(cut.Coordinates, cut.Connectivity.data() + cell * (D + 1));
    }
  }
  // Enclosed volume by the divergence theorem: cones from the origin over the facets.
  std::vector<double> withOrigin = cut.Coordinates;
  withOrigin.insert(withOrigin.end(), D, 0.0);
  const std::int64_t origin = static_cast<std::int64_t>(withOrigin.size()) / D - 1;
  double enclosed = 0.0;
  std::map<std::vector<std::int64_t>, int> ridges; // directed ridge -> count
  std::set<std::int64_t> vertices;
  const std::size_t facets = cut.Surface.size() / D;
  for (std::size_t f = 0; f < facets; ++f)
  {
    std::array<std::int64_t, D + 1> cone;
    for (int v = 0; v < D; ++v)
    {
      cone[v] = cut.Surface[f * D + v];
      vertices.insert(cone[v]);
    }
    cone[D] = origin;
    enclosed += (D % 2 == 0 ? 1.0 : -1.0) * ScaledVolume<D>(withOrigin, cone.data());
    if (D == 2)
    {
      ++ridges[{ cone[0] }];
      --ridges[{ cone[1] }];
    }
    else
    {
      for (int e = 0; e < 3; ++e)
      {
        ++ridges[{ cone[e], cone[(e + 1) % 3] }];
      }
    }
  }
  EXPECT_NEAR(enclosed, insideVolume, 1e-9 * insideVolume);
  if (D == 2)
  {
    for (const auto& ridge : ridges)
    {
      EXPECT_EQ(ridge.second, 0); // every vertex starts one segment and ends one
    }
    EXPECT_EQ(vertices.size(), facets);
  }
  else
  {
    std::int64_t edges = 0;
    for (const auto& ridge : ridges)
    {
      EXPECT_EQ(ridge.second, 1);
      const std::vector<std::int64_t> reverse{ ridge.first[1], ridge.first[0] };
      EXPECT_EQ(ridges.count(reverse), 1u);
      ++edges;
    }
    edges /= 2;
    const std::int64_t euler =
      static_cast<std::int64_t>(vertices.size()) - edges + static_cast<std::int64_t>(facets);
    EXPECT_EQ(euler, 2);
  }
}

template <int D>
stm::Spacetree<D> TreeOfImage(const LabelImage<D>& image, std::int64_t maxCellSize)
{
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  EXPECT_TRUE(BuildTree<D>(image, maxCellSize, 1, false, executor, tree).IsOk());
  return tree;
}

// The literal function (-1 strictly inside the body's voxels, +1 strictly outside, 0 on their
// interface) cuts no cell (paper 3.1): the output is the input, all-zero cells by material.
TYPED_TEST(MarchingSimplicesMeshTest, LiteralStaircaseCutsNothing)
{
  constexpr int D = TypeParam::value;
  LabelImage<D> image = MakeRandomImage<D>(UniformExtents<D>(D == 2 ? 20 : 9), 11, 1, 3, 40);
  // Keep the body off the image border, so that its whole boundary is an interface.
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      for (int axis = 0; axis < D; ++axis)
      {
        if (voxel[axis] == 0 || voxel[axis] == image.GetDimensions()[axis] - 1)
        {
          image.Set(voxel, stm::BackgroundMaterial);
        }
      }
    });
  const stm::Spacetree<D> tree = TreeOfImage<D>(image, 4);
  stm::SequentialExecutor executor;
  stm::SpacetreeTessellationOptions options;
  options.IncludeBackground = true;
  SimplicialMesh<D> mesh;
  stm::SpacetreeTessellator<D> tessellator;
  ASSERT_TRUE(TessellateTree<D>(tree, options, executor, mesh, tessellator).IsOk());
  std::vector<double> values(static_cast<std::size_t>(mesh.GetNumberOfPoints()));
  for (std::int64_t p = 0; p < mesh.GetNumberOfPoints(); ++p)
  {
    // Voxels touching the point: those whose closed box contains it.
    const stm::LatticeIndex<D>& half = mesh.HalfUnitPoints[p];
    stm::LatticeIndex<D> lower, upper;
    for (int axis = 0; axis < D; ++axis)
    {
      lower[axis] = half[axis] % 2 ? half[axis] / 2 : half[axis] / 2 - 1;
      upper[axis] = half[axis] / 2 + 1;
    }
    bool body = false, background = false;
    ForEachIndexInBox<D>(lower, upper,
      [&](const stm::LatticeIndex<D>& voxel)
      { (image.At(voxel) == stm::BackgroundMaterial ? background : body) = true; });
    values[p] = body && background ? 0.0 : body ? -1.0 : 1.0;
  }
  auto sideOfMaterial = [&mesh](std::int64_t cell)
  { return mesh.Materials[cell] == stm::BackgroundMaterial ? CutSide::Outside : CutSide::Inside; };
  const CutResult<D> cut = Cut<D>(mesh.Coordinates(), values, mesh.Connectivity,
    stm::MarchingSimplicesOptions(), executor, sideOfMaterial);
  ASSERT_TRUE(cut.Result.IsOk());
  EXPECT_EQ(cut.SplitCells, 0);
  EXPECT_EQ(cut.Connectivity, mesh.Connectivity);
  for (std::int64_t cell = 0; cell < cut.GetNumberOfCells(); ++cell)
  {
    EXPECT_EQ(cut.Sides[cell], static_cast<std::uint8_t>(sideOfMaterial(cell)));
  }
  // The interface is the voxel boundary of the body: its measure, from the facets.
  double measure = 0.0;
  for (std::size_t first = 0; first < cut.Surface.size(); first += D)
  {
    if (D == 2)
    {
      const double* a = &cut.Coordinates[cut.Surface[first] * D];
      const double* b = &cut.Coordinates[cut.Surface[first + 1] * D];
      measure += std::hypot(b[0] - a[0], b[1] - a[1]);
    }
    else
    {
      const double* a = &cut.Coordinates[cut.Surface[first] * D];
      const double* b = &cut.Coordinates[cut.Surface[first + 1] * D];
      const double* c = &cut.Coordinates[cut.Surface[first + 2] * D];
      const double u[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] };
      const double v[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
      measure += 0.5 *
        std::sqrt(std::pow(u[1] * v[2] - u[2] * v[1], 2) + std::pow(u[2] * v[0] - u[0] * v[2], 2) +
          std::pow(u[0] * v[1] - u[1] * v[0], 2));
    }
  }
  const std::int64_t faces = CountVoxelBoundaryFaces<D>(image);
  EXPECT_NEAR(measure, static_cast<double>(faces), 1e-9 * static_cast<double>(faces));
}

// The indicator reproduces the image's body voxels; the dual-grid interpolation is the voxel
// value at voxel centres and the exact average of the 2^d voxels (outside: +1) at corners.
TYPED_TEST(MarchingSimplicesMeshTest, DualGridInterpolationOfTheBodyIndicator)
{
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = MakeRandomImage<D>(FirstExtents<D>({ 9, 7, 5 }), 3, 2, 3, 60);
  const stm::Spacetree<D> tree = TreeOfImage<D>(image, 4);
  std::vector<std::int8_t> indicator;
  stm::SequentialExecutor executor;
  ASSERT_TRUE(stm::BodyIndicator<D>(tree, indicator, executor).IsOk());
  const stm::VoxelField<D, std::int8_t> field{ image.GetDimensions(), indicator.data(), 1.0 };
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      const double expected = image.At(voxel) == stm::BackgroundMaterial ? 1.0 : -1.0;
      ASSERT_EQ(field.At(voxel), expected);
      double centre[D];
      for (int axis = 0; axis < D; ++axis)
      {
        centre[axis] = static_cast<double>(voxel[axis]) + 0.5;
      }
      EXPECT_EQ(field.Sample(centre), expected);
    });
  stm::LatticeIndex<D> cornerUpper = image.GetDimensions();
  for (auto& extent : cornerUpper)
  {
    ++extent;
  }
  std::set<double> seen;
  ForEachIndex<D>(cornerUpper,
    [&](const stm::LatticeIndex<D>& corner)
    {
      double sum = 0.0;
      stm::LatticeIndex<D> lower = corner, upper = corner;
      for (int axis = 0; axis < D; ++axis)
      {
        --lower[axis];
        ++upper[axis];
      }
      ForEachIndexInBox<D>(lower, upper,
        [&](const stm::LatticeIndex<D>& voxel)
        { sum += image.At(voxel) == stm::BackgroundMaterial ? 1.0 : -1.0; });
      double position[D];
      for (int axis = 0; axis < D; ++axis)
      {
        position[axis] = static_cast<double>(corner[axis]);
      }
      const double sample = field.Sample(position);
      EXPECT_EQ(sample, sum / (1 << D));
      seen.insert(sample);
    });
  // Values of eq. (2): multiples of 1 / 2^(d-1), and zeros occur.
  for (double value : seen)
  {
    EXPECT_EQ(value * (1 << (D - 1)), std::round(value * (1 << (D - 1))));
  }
  EXPECT_EQ(seen.count(0.0), 1u);
}

TEST(MarchingSimplices, RejectsNonFiniteValuesAndBadIds)
{
  stm::SequentialExecutor executor;
  const std::vector<double> coordinates{ 0, 0, 1, 0, 0, 1 };
  const std::vector<std::int64_t> triangle{ 0, 1, 2 };
  stm::MarchingSimplicesOptions options;
  EXPECT_FALSE(Cut<2>(
    coordinates, { 0.0, std::nan(""), 1.0 }, triangle, options, executor, OutsideIfAllZero<2>)
                 .Result.IsOk());
  EXPECT_FALSE(
    Cut<2>(coordinates, { -1.0, 1.0, 1.0 }, { 0, 1, 3 }, options, executor, OutsideIfAllZero<2>)
      .Result.IsOk());
  options.ZeroTolerance = -1.0;
  EXPECT_FALSE(
    Cut<2>(coordinates, { -1.0, 1.0, 1.0 }, triangle, options, executor, OutsideIfAllZero<2>)
      .Result.IsOk());
  options.ZeroTolerance = 0.0;
  options.Keep = stm::KeptSides::Inside;
  const CutResult<2> inside =
    Cut<2>(coordinates, { -1.0, 1.0, 1.0 }, triangle, options, executor, OutsideIfAllZero<2>);
  ASSERT_TRUE(inside.Result.IsOk());
  EXPECT_EQ(inside.GetNumberOfCells(), 1);
  options.Keep = stm::KeptSides::Outside;
  EXPECT_EQ(
    Cut<2>(coordinates, { -1.0, 1.0, 1.0 }, triangle, options, executor, OutsideIfAllZero<2>)
      .GetNumberOfCells(),
    2);
}
} // namespace
