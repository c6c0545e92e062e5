// SPDX-License-Identifier: BSD-3-Clause
// Finite element shapes: with a 1-balanced tree, every simplex of the mesh is similar to one of
// a small, fixed set of simplices, whatever the image. The set must not grow with the image.

#include "CoreTestUtilities.h"
#include "Tessellate/ElementShapeEnumeration.h"

#include <functional>
#include <set>

namespace
{
using namespace stmtest;

template <class DimensionTag>
class SimplexShapesTest : public ::testing::Test
{
};
using ShapeDimensions = ::testing::Types<Dim<2>, Dim<3>>;
TYPED_TEST_SUITE(SimplexShapesTest, ShapeDimensions);

/// A similarity invariant of a simplex (stm::SimilarityKey of its vertices).
using ShapeKey = std::vector<std::int64_t>;

template <int D>
ShapeKey ShapeOf(const std::array<stm::LatticeIndex<D>, D + 1>& vertices)
{
  return stm::SimilarityKey<D>(vertices.data(), D + 1);
}

template <int D>
std::set<ShapeKey> CollectShapes(const SimplicialMesh<D>& mesh)
{
  std::set<ShapeKey> shapes;
  for (std::int64_t simplex = 0; simplex < mesh.GetNumberOfSimplices(); ++simplex)
  {
    std::array<stm::LatticeIndex<D>, D + 1> vertices;
    for (int corner = 0; corner <= D; ++corner)
    {
      vertices[corner] = mesh.Vertex(simplex, corner);
    }
    shapes.insert(ShapeOf<D>(vertices));
  }
  return shapes;
}

/// Every shape a mesh of a 1-balanced (all neighbours) tree can have. In a leaf of edge s, every
/// vertex of every simplex is a corner of the leaf (multiple of s), the centre of the leaf or of
/// one of its faces (multiples of s/2), or a corner of a child face of a split face (multiples of
/// s/2). Deeper points would need a split or irregular child face, i.e. a leaf of edge s/4
/// touching this one, which 1-balance forbids. So every simplex is, up to scale, a simplex with
/// vertices in {0,1,2}^D: the shapes of all of those bound the shapes of every such mesh.
template <int D>
std::set<ShapeKey> ShapesOnTheHalfGrid()
{
  std::vector<stm::LatticeIndex<D>> grid;
  ForEachIndex<D>(UniformExtents<D>(3), [&](const stm::LatticeIndex<D>& p) { grid.push_back(p); });
  std::set<ShapeKey> shapes;
  std::vector<int> chosen(D + 1);
  std::function<void(int, int)> choose = [&](int depth, int start)
  {
    if (depth == D + 1)
    {
      std::array<stm::LatticeIndex<D>, D + 1> vertices;
      for (int v = 0; v <= D; ++v)
      {
        vertices[v] = grid[chosen[v]];
      }
      if (ScaledSignedVolume<D>(vertices) != 0)
      {
        shapes.insert(ShapeOf<D>(vertices));
      }
      return;
    }
    for (int i = start; i < static_cast<int>(grid.size()); ++i)
    {
      chosen[depth] = i;
      choose(depth + 1, i + 1);
    }
  };
  choose(0, 0);
  return shapes;
}

template <int D>
std::set<ShapeKey> ShapesOfRandomImage(
  std::int64_t extent, unsigned seed, stm::CellTemplate cellTemplate)
{
  // The same density of specks, and of boxes per voxel, at every size.
  const int boxes = static_cast<int>(stm::IntPow(static_cast<int>(extent / 8), D));
  const LabelImage<D> image = MakeRandomImage<D>(UniformExtents<D>(extent), seed, 2, boxes, 15);
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  EXPECT_TRUE(BuildTree<D>(image, 16, 1, false, executor, tree).IsOk());
  stm::SpacetreeTessellationOptions options;
  options.Template = cellTemplate;
  SimplicialMesh<D> mesh;
  EXPECT_TRUE(TessellateTree<D>(tree, options, executor, mesh).IsOk());
  return CollectShapes<D>(mesh);
}

/// The shapes observed on 1-balanced meshes of random images (the same for 16^D and 32^D images,
/// and for more seeds and larger images when this was written), by sorted squared edge lengths:
///  2D, both templates: the right isosceles triangle (1,1,2): half a square, and the cones from
///    a square's centre over a whole or half edge are all similar to it.
///  3D Kuhn: (1,1,1,2,2,3) the Kuhn tetrahedron, also the cone over a half edge or a child
///    square; (3,3,3,4,4,8) the cone from the centre over half a face; (1,2,2,3,3,4) the cone
///    over a face-centre fan triangle; (1,1,1,2,2,2) and (1,1,2,2,2,3), cones over child squares.
///  3D checkerboard: (1,1,1,1,1,1) the central regular tetrahedron, (1,1,1,2,2,2) a corner
///    tetrahedron, and the cones (1,1,1,2,2,3), (1,2,2,3,3,4), (3,3,3,4,4,8).
std::set<ShapeKey> ExpectedShapes(int dimension, stm::CellTemplate cellTemplate)
{
  if (dimension == 2)
  {
    return { { 1, 1, 2 } };
  }
  if (cellTemplate == stm::CellTemplate::Kuhn)
  {
    return { { 1, 1, 1, 2, 2, 2 }, { 1, 1, 1, 2, 2, 3 }, { 1, 1, 2, 2, 2, 3 }, { 1, 2, 2, 3, 3, 4 },
      { 3, 3, 3, 4, 4, 8 } };
  }
  return { { 1, 1, 1, 1, 1, 1 }, { 1, 1, 1, 2, 2, 2 }, { 1, 1, 1, 2, 2, 3 }, { 1, 2, 2, 3, 3, 4 },
    { 3, 3, 3, 4, 4, 8 } };
}

TYPED_TEST(SimplexShapesTest, OneBalancedMeshesUseAFixedSmallSetOfShapes)
{
  constexpr int D = TypeParam::value;
  const std::set<ShapeKey> possible = ShapesOnTheHalfGrid<D>();
  // 6 triangle shapes on {0,1,2}^2 and 179 tetrahedron shapes on {0,1,2}^3.
  EXPECT_EQ(possible.size(), D == 2 ? 6u : 179u);
  for (stm::CellTemplate cellTemplate :
    { stm::CellTemplate::Kuhn, stm::CellTemplate::Checkerboard })
  {
    SCOPED_TRACE(cellTemplate == stm::CellTemplate::Kuhn ? "Kuhn" : "Checkerboard");
    std::set<ShapeKey> small, large;
    for (unsigned seed : { 1u, 2u, 3u })
    {
      const auto smallShapes = ShapesOfRandomImage<D>(16, seed, cellTemplate);
      small.insert(smallShapes.begin(), smallShapes.end());
      const auto largeShapes = ShapesOfRandomImage<D>(32, seed, cellTemplate);
      large.insert(largeShapes.begin(), largeShapes.end());
    }
    EXPECT_EQ(large, small) << "the set of shapes grows with the image";
    EXPECT_LE(large.size(), possible.size());
    EXPECT_TRUE(std::includes(possible.begin(), possible.end(), large.begin(), large.end()))
      << "a simplex is not similar to any simplex of the half grid";
    EXPECT_EQ(large, ExpectedShapes(D, cellTemplate));
    EXPECT_EQ(large.size(), D == 2 ? 1u : 5u);
  }
}

} // namespace
