// SPDX-License-Identifier: BSD-3-Clause
// SpacetreeTessellator with CheckSimplicialMesh: the meshes of random label images are valid
// simplicial complexes whose material volumes and boundary measure equal those of the voxel
// model exactly. Volumes and boundary measures are recomputed here in integers (half lattice
// units, Leibniz determinants), and compared with the checker's floating-point values too.

#include "CoreTestUtilities.h"

#include <set>

namespace
{
using namespace stmtest;

template <class DimensionTag>
class SpacetreeTessellationTest : public ::testing::Test
{
};
TYPED_TEST_SUITE(SpacetreeTessellationTest, AllDimensions);

template <int D>
LabelImage<D> MakeMeshImage(unsigned seed)
{
  const stm::LatticeIndex<D> dims =
    D == 4 ? FirstExtents<D>({ 8, 7, 6, 5 }) : FirstExtents<D>({ 37, 23, 13, 1 });
  return MakeRandomImage<D>(dims, seed, 2 + seed % 2, 5, 30); // 2 or 3 body materials
}

TYPED_TEST(SpacetreeTessellationTest, RandomImagesGiveValidMeshesWithTheVoxelVolumesAndBoundary)
{
  constexpr int D = TypeParam::value;
  for (unsigned seed : { 1u, 2u, 3u })
  {
    const LabelImage<D> image = MakeMeshImage<D>(seed);
    ASSERT_GT(image.CountBodyVoxels(), 0);
    for (int L : { 0, 1, 2, 3 })
    {
      for (bool facetsOnly : { false, true })
      {
        if (L == 0 && facetsOnly)
        {
          continue;
        }
        stm::SequentialExecutor executor;
        stm::Spacetree<D> tree;
        ASSERT_TRUE(BuildTree<D>(image, 16, L, facetsOnly, executor, tree).IsOk());
        for (stm::CellTemplate cellTemplate : TemplatesOf<D>())
        {
          SCOPED_TRACE("seed " + std::to_string(seed) + ", L " + std::to_string(L) +
            (facetsOnly ? " (facets)" : "") + ", " + TemplateName(cellTemplate));
          SimplicialMesh<D> mesh;
          const stm::Status status =
            TessellateTree<D>(tree, TessellationOptions(cellTemplate), executor, mesh);
          ASSERT_TRUE(status.IsOk()) << status.GetMessage();
          ExpectMeshMatchesVoxelModel<D>(mesh, tree, image);
        }
      }
    }
  }
}

TYPED_TEST(SpacetreeTessellationTest, UniformImageUsesTheTemplateInEveryCubeAndNoExtraPoint)
{
  constexpr int D = TypeParam::value;
  LabelImage<D> image(UniformExtents<D>(4));
  std::fill(image.GetValues().begin(), image.GetValues().end(), 1);
  for (std::int64_t leafSize : { 1, 2, 4 })
  {
    stm::SequentialExecutor executor;
    stm::Spacetree<D> tree;
    ASSERT_TRUE(BuildTree<D>(image, leafSize, 0, false, executor, tree).IsOk());
    const std::int64_t cubesPerAxis = 4 / leafSize;
    ASSERT_EQ(tree.GetNumberOfLeaves(), stm::IntPow(static_cast<int>(cubesPerAxis), D));
    for (stm::CellTemplate cellTemplate : TemplatesOf<D>())
    {
      SCOPED_TRACE("leaf size " + std::to_string(leafSize) + ", " + TemplateName(cellTemplate));
      SimplicialMesh<D> mesh;
      ASSERT_TRUE(
        TessellateTree<D>(tree, TessellationOptions(cellTemplate), executor, mesh).IsOk());
      const int perCube = cellTemplate == stm::CellTemplate::Kuhn
        ? stm::CubeInfo<D>::KuhnSimplicesPerCell
        : stm::CubeInfo<D>::CheckerboardSimplicesPerCell;
      EXPECT_EQ(mesh.GetNumberOfSimplices(), tree.GetNumberOfLeaves() * perCube);
      // The points are exactly the leaf corners: no centre was inserted.
      EXPECT_EQ(mesh.GetNumberOfPoints(), stm::IntPow(static_cast<int>(cubesPerAxis) + 1, D));
      std::int64_t offGrid = 0;
      for (const auto& point : mesh.HalfUnitPoints)
      {
        for (int axis = 0; axis < D; ++axis)
        {
          offGrid += point[axis] % (2 * leafSize) != 0;
        }
      }
      EXPECT_EQ(offGrid, 0) << "a point is not a leaf corner";
      ExpectMeshMatchesVoxelModel<D>(mesh, tree, image);
    }
  }
}

TEST(SpacetreeTessellation, KnownSimplexCountsPerTemplate)
{
  // Independent of the CubeInfo table: 2 triangles per square, 5 or 6 tetrahedra per cube.
  auto countForOneCube = [](auto dimensionTag, stm::CellTemplate cellTemplate)
  {
    constexpr int D = decltype(dimensionTag)::value;
    LabelImage<D> image(UniformExtents<D>(2));
    std::fill(image.GetValues().begin(), image.GetValues().end(), 1);
    stm::SequentialExecutor executor;
    stm::Spacetree<D> tree;
    EXPECT_TRUE(BuildTree<D>(image, 2, 0, false, executor, tree).IsOk());
    SimplicialMesh<D> mesh;
    EXPECT_TRUE(TessellateTree<D>(tree, TessellationOptions(cellTemplate), executor, mesh).IsOk());
    return mesh.GetNumberOfSimplices();
  };
  EXPECT_EQ(countForOneCube(Dim<1>(), stm::CellTemplate::Kuhn), 1);
  EXPECT_EQ(countForOneCube(Dim<1>(), stm::CellTemplate::Checkerboard), 1);
  EXPECT_EQ(countForOneCube(Dim<2>(), stm::CellTemplate::Kuhn), 2);
  EXPECT_EQ(countForOneCube(Dim<2>(), stm::CellTemplate::Checkerboard), 2);
  EXPECT_EQ(countForOneCube(Dim<3>(), stm::CellTemplate::Kuhn), 6);
  EXPECT_EQ(countForOneCube(Dim<3>(), stm::CellTemplate::Checkerboard), 5);
  EXPECT_EQ(countForOneCube(Dim<4>(), stm::CellTemplate::Kuhn), 24);
}

/// A 4^D image of material 1 with voxel 0 of material 2: the root splits into 2^D quadrants
/// (octants), and the one at the origin into unit voxels.
template <int D>
LabelImage<D> CornerVoxelImage()
{
  LabelImage<D> image(UniformExtents<D>(4));
  std::fill(image.GetValues().begin(), image.GetValues().end(), 1);
  image.Set(stm::LatticeIndex<D>{}, 2);
  return image;
}

template <int D>
std::int64_t CountSimplicesWithVertex(
  const SimplicialMesh<D>& mesh, const stm::LatticeIndex<D>& point)
{
  std::int64_t count = 0;
  for (std::int64_t simplex = 0; simplex < mesh.GetNumberOfSimplices(); ++simplex)
  {
    for (int corner = 0; corner <= D; ++corner)
    {
      count += mesh.Vertex(simplex, corner) == point;
    }
  }
  return count;
}

TEST(SpacetreeTessellation, CoarseSquaresNextToFineOnesGetTheirCentreInserted)
{
  // 4x4, fine quadrant [0,2]^2 (4 unit squares), coarse quadrants A = [2,4]x[0,2],
  // B = [0,2]x[2,4], C = [2,4]^2. Worked by hand:
  //  - unit squares: regular, 2 triangles each                                 ->  8
  //  - A: the midpoint (2,1) of its left edge is a leaf corner, so its centre (3,1) is
  //    inserted and joined to its edges: the left edge in 2 halves + 3 edges    ->  5
  //  - B: the same with the bottom edge and centre (1,3)                        ->  5
  //  - C: no leaf corner on its edges besides its own corners: regular          ->  2
  // Total 20 triangles. Points: the 3x3 corners of the unit squares, the 5 other quadrant
  // corners (4,0) (4,2) (0,4) (2,4) (4,4), and the 2 inserted centres: 16.
  constexpr int D = 2;
  const LabelImage<D> image = CornerVoxelImage<D>();
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  ASSERT_TRUE(BuildTree<D>(image, 4, 0, false, executor, tree).IsOk());
  ASSERT_EQ(tree.GetNumberOfLeaves(), 7);
  std::set<stm::LatticeIndex<D>> expectedPoints;
  for (std::int64_t y : { 0, 1, 2 })
  {
    for (std::int64_t x : { 0, 1, 2 })
    {
      expectedPoints.insert({ 2 * x, 2 * y });
    }
  }
  for (const stm::LatticeIndex<D>& corner :
    { stm::LatticeIndex<D>{ 4, 0 }, { 4, 2 }, { 0, 4 }, { 2, 4 }, { 4, 4 }, { 3, 1 }, { 1, 3 } })
  {
    expectedPoints.insert({ 2 * corner[0], 2 * corner[1] });
  }
  for (stm::CellTemplate cellTemplate : TemplatesOf<D>())
  {
    SCOPED_TRACE(TemplateName(cellTemplate));
    SimplicialMesh<D> mesh;
    ASSERT_TRUE(TessellateTree<D>(tree, TessellationOptions(cellTemplate), executor, mesh).IsOk());
    EXPECT_EQ(mesh.GetNumberOfSimplices(), 20);
    EXPECT_EQ(mesh.GetNumberOfPoints(), 16);
    EXPECT_EQ(
      std::set<stm::LatticeIndex<D>>(mesh.HalfUnitPoints.begin(), mesh.HalfUnitPoints.end()),
      expectedPoints);
    EXPECT_EQ(CountSimplicesWithVertex<D>(mesh, { 6, 2 }), 5) << "fan around the centre of A";
    EXPECT_EQ(CountSimplicesWithVertex<D>(mesh, { 2, 6 }), 5) << "fan around the centre of B";
    ExpectMeshMatchesVoxelModel<D>(mesh, tree, image);
  }
}

TEST(SpacetreeTessellation, CoarseCubesNextToFineOnesGetFaceAndCellCentres)
{
  // 4^3, fine octant [0,2]^3 (8 unit cubes) and 7 octants of edge 2. Worked by hand:
  //  - unit cubes: Kuhn 6, checkerboard 5 each                             -> 48 | 40
  //  - 3 octants sharing a face with the fine octant: centre inserted, cone over
  //    the shared face (4 unit squares, 8 triangles), 4 faces with one split edge
  //    (centre inserted, 5 triangles each) and the far face (2)           -> 3 x 30
  //  - 3 octants sharing an edge: cone over 2 faces with a split edge (5 each)
  //    and 4 regular faces (2 each)                                        -> 3 x 18
  //  - the octant sharing a vertex only: regular                           -> 6 | 5
  // Kuhn 48 + 90 + 54 + 6 = 198, checkerboard 40 + 90 + 54 + 5 = 189.
  // Points: {0,1,2}^3 (27) and {0,2,4}^3 minus {0,2}^3 (19) are leaf corners; 6 octant centres;
  // 12 centres of faces of edge 2 that contain an edge of the fine octant without being one of
  // its faces (6 on the domain boundary, 6 between octants): 64.
  constexpr int D = 3;
  const LabelImage<D> image = CornerVoxelImage<D>();
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  ASSERT_TRUE(BuildTree<D>(image, 4, 0, false, executor, tree).IsOk());
  ASSERT_EQ(tree.GetNumberOfLeaves(), 15);
  for (stm::CellTemplate cellTemplate : TemplatesOf<D>())
  {
    SCOPED_TRACE(TemplateName(cellTemplate));
    SimplicialMesh<D> mesh;
    ASSERT_TRUE(TessellateTree<D>(tree, TessellationOptions(cellTemplate), executor, mesh).IsOk());
    EXPECT_EQ(mesh.GetNumberOfSimplices(), cellTemplate == stm::CellTemplate::Kuhn ? 198 : 189);
    EXPECT_EQ(mesh.GetNumberOfPoints(), 64);
    // The centre of the octant [2,4]x[0,2]x[0,2] is the apex of its 30 tetrahedra.
    EXPECT_EQ(CountSimplicesWithVertex<D>(mesh, { 6, 2, 2 }), 30);
    // The centre of the octant [2,4]x[2,4]x[0,2] is the apex of its 18 tetrahedra.
    EXPECT_EQ(CountSimplicesWithVertex<D>(mesh, { 6, 6, 2 }), 18);
    ExpectMeshMatchesVoxelModel<D>(mesh, tree, image);
  }
}

TYPED_TEST(SpacetreeTessellationTest, IncludeBackgroundFillsTheWholeRootGrid)
{
  constexpr int D = TypeParam::value;
  for (unsigned seed : { 4u, 5u })
  {
    const LabelImage<D> image = MakeMeshImage<D>(seed);
    for (int L : { 0, 1 })
    {
      stm::SequentialExecutor executor;
      stm::Spacetree<D> tree;
      ASSERT_TRUE(BuildTree<D>(image, 8, L, false, executor, tree).IsOk());
      for (stm::CellTemplate cellTemplate : TemplatesOf<D>())
      {
        SCOPED_TRACE("seed " + std::to_string(seed) + ", L " + std::to_string(L) + ", " +
          TemplateName(cellTemplate));
        SimplicialMesh<D> mesh;
        ASSERT_TRUE(
          TessellateTree<D>(tree, TessellationOptions(cellTemplate, true), executor, mesh).IsOk());
        const stm::MeshInvariantReport report = CheckMesh<D>(mesh);
        EXPECT_TRUE(report.IsValid()) << report.Summary();

        const std::int64_t latticeVolume = LatticeVolume<D>(tree);
        const ExactMeasures exact = ComputeExactMeasures<D>(mesh);
        EXPECT_EQ(exact.NonPositiveSimplices, 0);
        EXPECT_EQ(exact.ScaledTotalVolume, latticeVolume * ScaledVoxelVolume<D>());
        EXPECT_TRUE(CheckerMeasureMatches(report.TotalVolume, static_cast<double>(latticeVolume)));
        // Background = image background + padding.
        EXPECT_EQ(exact.ScaledVolumePerMaterial.at(stm::BackgroundMaterial),
          (latticeVolume - image.CountBodyVoxels()) * ScaledVoxelVolume<D>());

        // The boundary is the surface of the root grid box.
        const stm::LatticeIndex<D> dims = tree.GetLatticeDimensions();
        std::int64_t boxFaces = 0;
        for (int axis = 0; axis < D; ++axis)
        {
          boxFaces += 2 * latticeVolume / dims[axis];
        }
        EXPECT_EQ(exact.SkewBoundaryFacets, 0);
        EXPECT_EQ(exact.ScaledBoundaryMeasure, boxFaces * ScaledVoxelFace<D>());
        EXPECT_TRUE(CheckerMeasureMatches(report.BoundaryMeasure, static_cast<double>(boxFaces)));
      }
    }
  }
}

TYPED_TEST(SpacetreeTessellationTest, MaterialsOfSimplicesAreThoseOfTheirLeavesInLeafOrder)
{
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = MakeMeshImage<D>(6);
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  ASSERT_TRUE(BuildTree<D>(image, 16, 1, false, executor, tree).IsOk());
  SimplicialMesh<D> mesh;
  ASSERT_TRUE(
    TessellateTree<D>(tree, TessellationOptions(stm::CellTemplate::Kuhn), executor, mesh).IsOk());
  // Simplices are emitted leaf by leaf: each one lies in the closed cube of the leaf it belongs
  // to, and walking the leaves in order consumes the simplices in order.
  std::int64_t simplex = 0, outsideItsLeaf = 0, wrongMaterial = 0;
  for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
  {
    if (tree.LeafMaterials[leaf] == stm::BackgroundMaterial)
    {
      continue;
    }
    const std::int64_t size = tree.GetCellSize(tree.LeafLevels[leaf])[0];
    const auto& anchor = tree.LeafAnchors[leaf];
    auto inLeaf = [&](std::int64_t s)
    {
      for (int corner = 0; corner <= D; ++corner)
      {
        for (int axis = 0; axis < D; ++axis)
        {
          const std::int64_t c = mesh.Vertex(s, corner)[axis];
          if (c < 2 * anchor[axis] || c > 2 * (anchor[axis] + size))
          {
            return false;
          }
        }
      }
      return true;
    };
    // A leaf has at least one simplex, and all its simplices come before the next leaf's. A
    // simplex of positive volume lies in the closed cube of one leaf only, so taking simplices
    // while they fit this leaf cannot steal those of the next one.
    const std::int64_t first = simplex;
    while (simplex < mesh.GetNumberOfSimplices() && inLeaf(simplex))
    {
      wrongMaterial += mesh.Materials[simplex] != tree.LeafMaterials[leaf];
      ++simplex;
    }
    outsideItsLeaf += simplex == first;
  }
  EXPECT_EQ(outsideItsLeaf, 0);
  EXPECT_EQ(wrongMaterial, 0);
  EXPECT_EQ(simplex, mesh.GetNumberOfSimplices()) << "simplices not accounted for by a leaf";
}

TYPED_TEST(SpacetreeTessellationTest, SpeckAndHoleInALargeRootGiveAValidMesh)
{
  constexpr int D = TypeParam::value;
  // Level jumps from the root level to the finest one: a speck of material 2 and a hole (one
  // background voxel) inside a single large root of material 1. The hole's faces are boundary.
  const std::int64_t extent = D <= 2 ? 64 : (D == 3 ? 32 : 8);
  LabelImage<D> image(UniformExtents<D>(extent));
  std::fill(image.GetValues().begin(), image.GetValues().end(), 1);
  image.Set(UniformExtents<D>(extent / 2 - 1), 2);
  stm::LatticeIndex<D> hole = UniformExtents<D>(extent / 4 + 1);
  hole[0] = extent - 3;
  image.Set(hole, stm::BackgroundMaterial);
  for (int L : { 0, 1, 2 })
  {
    stm::SequentialExecutor executor;
    stm::Spacetree<D> tree;
    ASSERT_TRUE(BuildTree<D>(image, extent, L, false, executor, tree).IsOk());
    ASSERT_EQ(tree.GetRootCellSize()[0], extent);
    for (stm::CellTemplate cellTemplate : TemplatesOf<D>())
    {
      SCOPED_TRACE("L " + std::to_string(L) + ", " + TemplateName(cellTemplate));
      SimplicialMesh<D> mesh;
      ASSERT_TRUE(
        TessellateTree<D>(tree, TessellationOptions(cellTemplate), executor, mesh).IsOk());
      ExpectMeshMatchesVoxelModel<D>(mesh, tree, image);
    }
  }
}

TYPED_TEST(SpacetreeTessellationTest, AbortedExecutorStopsEveryStage)
{
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = MakeMeshImage<D>(7);
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  ASSERT_TRUE(BuildTree<D>(image, 16, 1, false, executor, tree).IsOk());
  const auto options = TessellationOptions(stm::CellTemplate::Kuhn);

  stm::SpacetreeTessellator<D> tessellator;
  ASSERT_TRUE(tessellator.Prepare(tree, options, executor).IsOk());
  std::vector<std::int64_t> connectivity(
    static_cast<std::size_t>(tessellator.GetNumberOfCells() * (D + 1)));
  std::vector<stm::MaterialIndex> materials(
    static_cast<std::size_t>(tessellator.GetNumberOfCells()));
  executor.RequestAbort();
  EXPECT_EQ(tessellator.WriteSimplices(connectivity.data(), materials.data(), executor).GetCode(),
    stm::Status::Code::Aborted);
  std::int64_t visited = 0;
  auto count = [&visited](std::int64_t, const stm::LatticeIndex<D>&) { ++visited; };
  EXPECT_EQ(tessellator.VisitPoints(count, executor).GetCode(), stm::Status::Code::Aborted);
  EXPECT_EQ(visited, 0);

  stm::SpacetreeTessellator<D> second;
  EXPECT_EQ(second.Prepare(tree, options, executor).GetCode(), stm::Status::Code::Aborted);
}

TYPED_TEST(SpacetreeTessellationTest, RegularLeafTablesAgreeWithTheGeneralConstruction)
{
  constexpr int D = TypeParam::value;
  // Most leaves take a tabulated template instead of the recursive construction. A leaf is
  // regular when no leaf corner other than its own lies on its closed cube; checked here with a
  // dense vertex map, and the table must then give the simplices of the general construction.
  for (int L : { 0, 1 })
  {
    stm::SequentialExecutor executor;
    stm::Spacetree<D> tree;
    ASSERT_TRUE(BuildTree<D>(MakeMeshImage<D>(8), 16, L, false, executor, tree).IsOk());
    stm::LatticeIndex<D> vertexDims = tree.GetLatticeDimensions();
    for (auto& extent : vertexDims)
    {
      ++extent;
    }
    std::vector<char> isVertex(
      static_cast<std::size_t>(stm::NumberOfLatticeCells<D>(vertexDims)), 0);
    for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
    {
      const std::int64_t size = tree.GetCellSize(tree.LeafLevels[leaf])[0];
      for (int c = 0; c < (1 << D); ++c)
      {
        stm::LatticeIndex<D> corner = tree.LeafAnchors[leaf];
        for (int axis = 0; axis < D; ++axis)
        {
          corner[axis] += ((c >> axis) & 1) * size;
        }
        isVertex[stm::LinearIndex<D>(corner, vertexDims)] = 1;
      }
    }
    for (stm::CellTemplate cellTemplate : TemplatesOf<D>())
    {
      SCOPED_TRACE("L " + std::to_string(L) + ", " + TemplateName(cellTemplate));
      stm::SpacetreeTessellator<D> tessellator;
      ASSERT_TRUE(tessellator.Prepare(tree, TessellationOptions(cellTemplate), executor).IsOk());
      typename stm::SpacetreeTessellator<D>::Scratch scratch;
      std::int64_t regular = 0, irregular = 0, misclassified = 0, tableMismatches = 0;
      for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
      {
        const std::int64_t size = tree.GetCellSize(tree.LeafLevels[leaf])[0];
        const auto& anchor = tree.LeafAnchors[leaf];
        stm::LatticeIndex<D> upper;
        for (int axis = 0; axis < D; ++axis)
        {
          upper[axis] = anchor[axis] + size + 1;
        }
        int verticesOnCube = 0;
        ForEachIndexInBox<D>(anchor, upper,
          [&](const stm::LatticeIndex<D>& point)
          { verticesOnCube += isVertex[stm::LinearIndex<D>(point, vertexDims)]; });
        const bool expectRegular = verticesOnCube == (1 << D);
        misclassified += tessellator.IsRegularLeaf(leaf) != expectRegular;
        (expectRegular ? regular : irregular) += 1;
        if (!expectRegular)
        {
          continue;
        }
        scratch.LeafCells.Clear();
        tessellator.TessellateLeaf(leaf, scratch);
        stm::SpacetreeTessellator<D>::Orient(scratch.LeafCells);
        std::vector<stm::LatticeIndex<D>> fromTable;
        for (std::uint8_t code : tessellator.RegularCellCodes(leaf))
        {
          stm::LatticeIndex<D> corner;
          for (int axis = 0; axis < D; ++axis)
          {
            corner[axis] = 2 * (anchor[axis] + ((code >> axis) & 1) * size);
          }
          fromTable.push_back(corner);
        }
        tableMismatches += fromTable != scratch.LeafCells.Points;
      }
      EXPECT_EQ(misclassified, 0);
      EXPECT_EQ(tableMismatches, 0);
      EXPECT_GT(regular, 0);
      if (D > 1)
      {
        // In 1D no leaf corner can lie on another leaf's boundary besides its end points.
        EXPECT_GT(irregular, 0);
      }
    }
  }
}

TEST(SpacetreeTessellation, CheckerboardInFourDimensionsIsInvalid)
{
  LabelImage<4> image(UniformExtents<4>(4));
  std::fill(image.GetValues().begin(), image.GetValues().end(), 1);
  stm::SequentialExecutor executor;
  stm::Spacetree<4> tree;
  ASSERT_TRUE(BuildTree<4>(image, 4, 0, false, executor, tree).IsOk());
  stm::SpacetreeTessellator<4> tessellator;
  const stm::Status status =
    tessellator.Prepare(tree, TessellationOptions(stm::CellTemplate::Checkerboard), executor);
  EXPECT_FALSE(status.IsOk());
  EXPECT_EQ(status.GetCode(), stm::Status::Code::InvalidArgument);
  EXPECT_FALSE(status.GetMessage().empty());
}

TYPED_TEST(SpacetreeTessellationTest, SimplexDeterminantIsTheExactDeterminant)
{
  constexpr int D = TypeParam::value;
  std::mt19937 random(12345);
  std::int64_t wrong = 0, degenerate = 0;
  for (int trial = 0; trial < 2000; ++trial)
  {
    std::array<stm::LatticeIndex<D>, D + 1> points;
    for (auto& point : points)
    {
      for (int axis = 0; axis < D; ++axis)
      {
        // Small range: zero pivots and singular matrices occur often.
        point[axis] = static_cast<std::int64_t>(random() % 7) - 3;
      }
    }
    const std::int64_t expected = ScaledSignedVolume<D>(points);
    degenerate += expected == 0;
    wrong += stm::SimplexDeterminant<D>(points.data()) != expected;

    // Orient must make a non-degenerate simplex positive by reordering its points only.
    std::vector<stm::LatticeIndex<D>> buffer(points.begin(), points.end());
    stm::SpacetreeTessellator<D>::OrientSimplices(buffer);
    std::array<stm::LatticeIndex<D>, D + 1> oriented;
    std::copy(buffer.begin(), buffer.end(), oriented.begin());
    wrong += ScaledSignedVolume<D>(oriented) != (expected < 0 ? -expected : expected);
    wrong += !std::is_permutation(buffer.begin(), buffer.end(), points.begin());
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(degenerate, 0) << "the sample should contain singular matrices";
}

TEST(SpacetreeTessellation, SimplexDeterminantOfFourDimensionalCornerCases)
{
  // Zero leading pivots that need row swaps, checked against hand-computed values.
  const std::array<stm::LatticeIndex<4>, 5> swapped = { { { 0, 0, 0, 0 }, { 0, 1, 0, 0 },
    { 1, 0, 0, 0 }, { 0, 0, 0, 1 }, { 0, 0, 1, 0 } } };
  EXPECT_EQ(stm::SimplexDeterminant<4>(swapped.data()), 1); // two swaps
  const std::array<stm::LatticeIndex<4>, 5> scaled = { { { 1, 1, 1, 1 }, { 3, 1, 1, 1 },
    { 1, 4, 1, 1 }, { 1, 1, 1, 6 }, { 1, 1, 5, 1 } } };
  EXPECT_EQ(stm::SimplexDeterminant<4>(scaled.data()), -2 * 3 * 5 * 4);
  const std::array<stm::LatticeIndex<4>, 5> flat = { { { 0, 0, 0, 0 }, { 1, 2, 3, 0 },
    { 2, 1, 0, 0 }, { 5, 1, 1, 0 }, { 7, 3, 2, 0 } } };
  EXPECT_EQ(stm::SimplexDeterminant<4>(flat.data()), 0);
}

} // namespace
