// SPDX-License-Identifier: BSD-3-Clause
// Pieces of the root grid (RootPieces.h): the boxes partition the grid, and a piece meshed from
// its ghost box alone has exactly the whole image's cells in its owned box, so adjacent pieces
// match on their shared boundary and the pieces together are the whole mesh.

#include "CoreTestUtilities.h"
#include "Spacetree/RootPieces.h"

namespace
{
using namespace stmtest;

template <class DimensionTag>
class RootPiecesTest : public ::testing::Test
{
};
using RootPiecesDimensions = ::testing::Types<Dim<2>, Dim<3>, Dim<4>>;
TYPED_TEST_SUITE(RootPiecesTest, RootPiecesDimensions);

TYPED_TEST(RootPiecesTest, PiecesPartitionTheRootGrid)
{
  constexpr int D = TypeParam::value;
  for (const stm::LatticeIndex<D>& dims : { UniformExtents<D>(1), UniformExtents<D>(3),
         FirstExtents<D>({ 7, 2, 5, 3 }), FirstExtents<D>({ 2, 9, 4, 6 }) })
  {
    const std::int64_t cells = stm::NumberOfLatticeCells<D>(dims);
    for (int pieces = 1; pieces <= 12; ++pieces)
    {
      SCOPED_TRACE("grid " + ToString<D>(dims) + ", " + std::to_string(pieces) + " pieces");
      std::vector<int> owners(static_cast<std::size_t>(cells), 0);
      std::int64_t smallest = cells, largest = 0, nonEmpty = 0;
      for (int piece = 0; piece < pieces; ++piece)
      {
        const stm::RootBox<D> box = stm::PieceRootBox<D>(dims, pieces, piece);
        ForEachIndex<D>(dims,
          [&](const stm::LatticeIndex<D>& root)
          { owners[stm::LinearIndex<D>(root, dims)] += box.Contains(root) ? 1 : 0; });
        EXPECT_EQ(box.IsEmpty(), box.GetNumberOfCells() == 0);
        nonEmpty += box.IsEmpty() ? 0 : 1;
        smallest = std::min(smallest, box.GetNumberOfCells());
        largest = std::max(largest, box.GetNumberOfCells());
      }
      EXPECT_TRUE(std::all_of(owners.begin(), owners.end(), [](int n) { return n == 1; }))
        << "a root cell is not in exactly one piece";
      // As many pieces get cells as the grid has cells for.
      EXPECT_EQ(nonEmpty, std::min<std::int64_t>(pieces, cells));
      if (pieces <= cells)
      {
        EXPECT_GE(smallest, 1);
      }
      EXPECT_LE(largest, std::max<std::int64_t>(1, 2 * cells / pieces + 2));
    }
  }
  // Out of range: empty.
  EXPECT_TRUE(stm::PieceRootBox<D>(UniformExtents<D>(4), 2, 2).IsEmpty());
  EXPECT_TRUE(stm::PieceRootBox<D>(UniformExtents<D>(4), 0, 0).IsEmpty());
  EXPECT_TRUE(stm::PieceRootBox<D>(UniformExtents<D>(4), 2, -1).IsEmpty());
}

// One inner ghost layer for the default root cells (16 voxels) and larger ones; for smaller root
// cells as many as keep MinimumKeptGhostVoxels, by the smallest edge; always an outer one more.
TYPED_TEST(RootPiecesTest, GhostLayersKeepSixteenVoxels)
{
  constexpr int D = TypeParam::value;
  EXPECT_EQ(stm::MinimumKeptGhostVoxels, 16);
  EXPECT_EQ(stm::GhostRootLayersFor<D>(UniformExtents<D>(16)), 2);
  EXPECT_EQ(stm::GhostRootLayersFor<D>(UniformExtents<D>(64)), 2);
  EXPECT_EQ(stm::GhostRootLayersFor<D>(UniformExtents<D>(15)), 3);
  EXPECT_EQ(stm::GhostRootLayersFor<D>(UniformExtents<D>(8)), 3);
  EXPECT_EQ(stm::GhostRootLayersFor<D>(UniformExtents<D>(5)), 5);
  EXPECT_EQ(stm::GhostRootLayersFor<D>(UniformExtents<D>(4)), 5);
  EXPECT_EQ(stm::GhostRootLayersFor<D>(UniformExtents<D>(1)), 17);
  stm::LatticeIndex<D> anisotropic = UniformExtents<D>(32);
  anisotropic[D - 1] = 4;
  EXPECT_EQ(stm::GhostRootLayersFor<D>(anisotropic), 5);
}

TYPED_TEST(RootPiecesTest, BisectionHalvesTheLongestAxis)
{
  constexpr int D = TypeParam::value;
  const stm::LatticeIndex<D> dims = FirstExtents<D>({ 3, 10, 2, 2 });
  // Three pieces: axis 1 (the longest) is cut in half, at 5; the halves have as many cells, and
  // the lower one gets 2 of the 3 pieces (1.5 rounded up), so it is cut again in half, at 2.
  const stm::RootBox<D> first = stm::PieceRootBox<D>(dims, 3, 0);
  const stm::RootBox<D> second = stm::PieceRootBox<D>(dims, 3, 1);
  const stm::RootBox<D> third = stm::PieceRootBox<D>(dims, 3, 2);
  EXPECT_EQ(first.Lower[1], 0);
  EXPECT_EQ(first.Upper[1], 2);
  EXPECT_EQ(second.Lower[1], 2);
  EXPECT_EQ(second.Upper[1], 5);
  EXPECT_EQ(third.Lower[1], 5);
  EXPECT_EQ(third.Upper[1], 10);
  for (const stm::RootBox<D>* box : { &first, &second, &third })
  {
    EXPECT_EQ(box->Lower[0], 0);
    EXPECT_EQ(box->Upper[0], 3);
  }
}

TYPED_TEST(RootPiecesTest, CostsPartitionTheGridWithTheSameEmptyPieces)
{
  constexpr int D = TypeParam::value;
  for (const stm::LatticeIndex<D>& dims : { UniformExtents<D>(1), UniformExtents<D>(3),
         FirstExtents<D>({ 7, 2, 5, 3 }), FirstExtents<D>({ 2, 9, 4, 6 }) })
  {
    const std::int64_t cells = stm::NumberOfLatticeCells<D>(dims);
    // Uneven costs, zero in some cells.
    std::vector<std::int64_t> costs(static_cast<std::size_t>(cells));
    for (std::int64_t i = 0; i < cells; ++i)
    {
      costs[i] = (i * 7919) % 13 < 4 ? 0 : (i * 104729) % 97;
    }
    for (int pieces = 1; pieces <= 12; ++pieces)
    {
      SCOPED_TRACE("grid " + ToString<D>(dims) + ", " + std::to_string(pieces) + " pieces");
      std::vector<int> owners(static_cast<std::size_t>(cells), 0);
      for (int piece = 0; piece < pieces; ++piece)
      {
        const stm::RootBox<D> box = stm::PieceRootBox<D>(dims, pieces, piece, costs);
        ForEachIndex<D>(dims,
          [&](const stm::LatticeIndex<D>& root)
          { owners[stm::LinearIndex<D>(root, dims)] += box.Contains(root) ? 1 : 0; });
        EXPECT_EQ(box.IsEmpty(), stm::PieceRootBox<D>(dims, pieces, piece).IsEmpty());
      }
      EXPECT_TRUE(std::all_of(owners.begin(), owners.end(), [](int n) { return n == 1; }))
        << "a root cell is not in exactly one piece";
    }
  }
}

TYPED_TEST(RootPiecesTest, CostsMoveTheCut)
{
  constexpr int D = TypeParam::value;
  // A row of 10 root cells; the first two cost 10, the others 1 (28 in all). A cut at 1 leaves
  // the sides 10 and 18, at 2 20 and 8: the cut is at 1 (without costs: at 5).
  const stm::LatticeIndex<D> row = FirstExtents<D>({ 10, 1, 1, 1 });
  const std::vector<std::int64_t> rowCosts{ 10, 10, 1, 1, 1, 1, 1, 1, 1, 1 };
  EXPECT_EQ(stm::PieceRootBox<D>(row, 2, 0, rowCosts).Upper, FirstExtents<D>({ 1, 1, 1, 1 }));
  EXPECT_EQ(stm::PieceRootBox<D>(row, 2, 1, rowCosts).Lower, FirstExtents<D>({ 1, 0, 0, 0 }));
  EXPECT_EQ(stm::PieceRootBox<D>(row, 2, 0).Upper[0], 5);
  // 6 x 4 x 4 ... root cells costing 1, except 7 in the first layer across axis 0: per cross
  // section the layers along axis 0 cost 7, 1, 1, 1, 1, 1, whose best cut leaves 7 against 5;
  // across axis 1 (and the later ones alike) the costs halve at 2, so axis 1 is cut there.
  const stm::LatticeIndex<D> dims = FirstExtents<D>({ 6, 4, 4, 4 });
  std::vector<std::int64_t> costs(static_cast<std::size_t>(stm::NumberOfLatticeCells<D>(dims)));
  ForEachIndex<D>(dims,
    [&](const stm::LatticeIndex<D>& root)
    { costs[stm::LinearIndex<D>(root, dims)] = root[0] == 0 ? 7 : 1; });
  const stm::RootBox<D> lower = stm::PieceRootBox<D>(dims, 2, 0, costs);
  stm::LatticeIndex<D> upperCorner = dims;
  upperCorner[1] = 2;
  EXPECT_EQ(lower.Lower, UniformExtents<D>(0));
  EXPECT_EQ(lower.Upper, upperCorner);
  EXPECT_EQ(stm::PieceRootBox<D>(dims, 2, 0).Upper[0], 3);
  // Costs that are all zero, or of the wrong size: the middle of the longest axis.
  EXPECT_EQ(
    stm::PieceRootBox<D>(dims, 2, 0, std::vector<std::int64_t>(costs.size(), 0)).Upper[0], 3);
  EXPECT_EQ(stm::PieceRootBox<D>(dims, 2, 0, std::vector<std::int64_t>(3, 1)).Upper[0], 3);
}

// The root colours: 3^D of them, the index modulo 3 per axis with axis 0 the least significant
// (negative indices too); the 2^D root cells around any lattice point have distinct colours, and
// root cells of one colour differ by a multiple of 3 along every axis, so two distinct ones are
// at least 3 apart along some axis and their closures share no point.
TYPED_TEST(RootPiecesTest, RootColoursSeparateTheRootCellsAroundAPoint)
{
  constexpr int D = TypeParam::value;
  using Colouring = stm::RootColouring<D>;
  EXPECT_EQ(Colouring::NumberOfColours, static_cast<int>(std::pow(3, D)));
  stm::LatticeIndex<D> root{};
  root[0] = 4;
  root[D - 1] += 2;
  EXPECT_EQ(Colouring::Colour(root), D == 1 ? 0 : 1 + static_cast<int>(std::pow(3, D - 1)) * 2);
  root[0] = -1;
  EXPECT_EQ(Colouring::Colour(root) % 3, 2);
  std::vector<stm::LatticeIndex<D>> roots;
  ForEachIndex<D>(UniformExtents<D>(5),
    [&](const stm::LatticeIndex<D>& index)
    {
      stm::LatticeIndex<D> shifted = index;
      for (int axis = 0; axis < D; ++axis)
      {
        shifted[axis] -= 2;
      }
      roots.push_back(shifted);
    });
  std::vector<int> used(static_cast<std::size_t>(Colouring::NumberOfColours), 0);
  for (const auto& a : roots)
  {
    const int colour = Colouring::Colour(a);
    ASSERT_LT(colour, Colouring::NumberOfColours);
    used[colour] = 1;
    for (const auto& b : roots)
    {
      bool around = true, multiples = true;
      for (int axis = 0; axis < D; ++axis)
      {
        around = around && std::abs(a[axis] - b[axis]) <= 1;
        multiples = multiples && (a[axis] - b[axis]) % 3 == 0;
      }
      EXPECT_EQ(Colouring::Colour(a) == Colouring::Colour(b), multiples);
      if (around && a != b)
      {
        EXPECT_NE(Colouring::Colour(a), Colouring::Colour(b));
      }
    }
  }
  EXPECT_EQ(std::count(used.begin(), used.end(), 1), Colouring::NumberOfColours);
}

TEST(RootCellCosts, BoundaryAndBodyVoxels2D)
{
  // 8 x 6 voxels, material 1 in x 2..4, y 1..2; root cells of 4 x 4 voxels (2 x 2 of them).
  // Boundary voxels (the next voxel along x or y differs): (1,1) (1,2) (4,0) (4,1) (4,2) along
  // x or y, and (2,0) (3,0) (2,2) (3,2) along y. Root (0,0) holds 6 of them and 4 body voxels,
  // root (1,0) 3 and 2.
  std::vector<stm::MaterialIndex> values(8 * 6, 0);
  for (int y = 1; y <= 2; ++y)
  {
    for (int x = 2; x <= 4; ++x)
    {
      values[y * 8 + x] = 1;
    }
  }
  stm::MaterialImage<2> image;
  image.Dimensions = { 8, 6 };
  image.Values = values.data();
  stm::ThreadPoolExecutor executor(2);
  const std::vector<std::int64_t> costs =
    stm::RootCellCosts<2>(image, { 4, 4 }, { 2, 2 }, executor);
  const std::int64_t boundary = stm::BoundaryVoxelCost, body = stm::BodyVoxelCost;
  EXPECT_EQ(
    costs, (std::vector<std::int64_t>{ 6 * boundary + 4 * body, 3 * boundary + 2 * body, 0, 0 }));
  // Root cells that do not cover the image: no costs.
  EXPECT_EQ(
    stm::RootCellCosts<2>(image, { 2, 2 }, { 2, 2 }, executor), std::vector<std::int64_t>(4, 0));
}

TEST(RootCellCosts, OneVoxel3D)
{
  // One voxel of material 2 at (1,1,1) of 4 x 4 x 4; root cells of 2 voxels. It differs from
  // the next voxels, and (0,1,1), (1,0,1) and (1,1,0) differ from it: all in root (0,0,0).
  std::vector<stm::MaterialIndex> values(64, 0);
  values[1 + 4 * (1 + 4 * 1)] = 2;
  stm::MaterialImage<3> image;
  image.Dimensions = { 4, 4, 4 };
  image.Values = values.data();
  stm::SequentialExecutor executor;
  std::vector<std::int64_t> expected(8, 0);
  expected[0] = 4 * stm::BoundaryVoxelCost + stm::BodyVoxelCost;
  EXPECT_EQ(stm::RootCellCosts<3>(image, { 2, 2, 2 }, { 2, 2, 2 }, executor), expected);
}

TYPED_TEST(RootPiecesTest, SlabCostsAddUpToTheWholeImage)
{
  // Processes that each read a slab of root-cell layers along the last axis (and one row more)
  // find the whole image's costs in the sum of their slabs' costs, for any number of slabs,
  // also more than layers.
  constexpr int D = TypeParam::value;
  const stm::LatticeIndex<D> dims = FirstExtents<D>({ 13, 10, 11, 6 });
  const stm::LatticeIndex<D> rootVoxels = FirstExtents<D>({ 3, 4, 2, 2 });
  stm::LatticeIndex<D> rootDims;
  for (int axis = 0; axis < D; ++axis)
  {
    rootDims[axis] = (dims[axis] + rootVoxels[axis] - 1) / rootVoxels[axis];
  }
  const LabelImage<D> image = MakeRandomImage<D>(dims, 7, 3, 6, 30);
  stm::ThreadPoolExecutor executor(2);
  const std::vector<std::int64_t> whole =
    stm::RootCellCosts<D>(image.View(), rootVoxels, rootDims, executor);
  ASSERT_GT(std::count_if(whole.begin(), whole.end(), [](std::int64_t c) { return c > 0; }), 2);
  constexpr int last = D - 1;
  const std::int64_t layers = rootDims[last];
  const std::int64_t rowSize = stm::NumberOfLatticeCells<D>(dims) / dims[last];
  bool missedWithoutNextRow = false;
  for (std::int64_t slabs = 1; slabs <= layers + 1; ++slabs)
  {
    for (const bool withNextRow : { true, false })
    {
      SCOPED_TRACE(std::to_string(slabs) + " slabs" + (withNextRow ? "" : " without the next row"));
      std::vector<std::int64_t> sum(whole.size(), 0);
      for (std::int64_t slab = 0; slab < slabs; ++slab)
      {
        const std::int64_t first = slab * layers / slabs;
        const std::int64_t end = (slab + 1) * layers / slabs;
        const std::int64_t firstRow = std::min(dims[last], first * rootVoxels[last]);
        const std::int64_t endRow =
          std::min(dims[last], end * rootVoxels[last] + (withNextRow ? 1 : 0));
        stm::MaterialImage<D> view = image.View();
        view.Values += firstRow * rowSize;
        view.Dimensions[last] = endRow - firstRow;
        const std::vector<std::int64_t> costs =
          stm::RootCellCostsOfLayers<D>(view, first, end, rootVoxels, rootDims, executor);
        ASSERT_EQ(costs.size(), whole.size());
        for (std::size_t i = 0; i < sum.size(); ++i)
        {
          sum[i] += costs[i];
        }
      }
      if (withNextRow || slabs == 1)
      {
        EXPECT_EQ(sum, whole);
      }
      else
      {
        missedWithoutNextRow = missedWithoutNextRow || sum != whole;
      }
    }
  }
  // Without the next row the differences across a slab's last row go uncounted.
  EXPECT_TRUE(missedWithoutNextRow);
  // A slab that holds more than its layers and a row: no costs.
  stm::MaterialImage<D> tooLong = image.View();
  EXPECT_EQ(stm::RootCellCostsOfLayers<D>(tooLong, 0, 1, rootVoxels, rootDims, executor),
    std::vector<std::int64_t>(whole.size(), 0));
}

TYPED_TEST(RootPiecesTest, GhostBoxesGrowByTwoAndStartEven)
{
  constexpr int D = TypeParam::value;
  const stm::LatticeIndex<D> dims = FirstExtents<D>({ 9, 6, 5, 4 });
  for (int pieces = 1; pieces <= 8; ++pieces)
  {
    for (int piece = 0; piece < pieces; ++piece)
    {
      const stm::RootBox<D> owned = stm::PieceRootBox<D>(dims, pieces, piece);
      const stm::RootBox<D> ghost = stm::GhostRootBox<D>(owned, dims);
      if (owned.IsEmpty())
      {
        EXPECT_TRUE(ghost.IsEmpty());
        continue;
      }
      for (int axis = 0; axis < D; ++axis)
      {
        EXPECT_EQ(ghost.Lower[axis] % 2, 0);
        EXPECT_GE(ghost.Lower[axis], 0);
        EXPECT_LE(ghost.Upper[axis], dims[axis]);
        EXPECT_LE(ghost.Lower[axis], std::max<std::int64_t>(0, owned.Lower[axis] - 2));
        EXPECT_GE(ghost.Lower[axis], owned.Lower[axis] - 3);
        EXPECT_EQ(ghost.Upper[axis], std::min(dims[axis], owned.Upper[axis] + 2));
      }
    }
  }
  stm::RootBox<D> owned;
  owned.Lower = UniformExtents<D>(3);
  owned.Upper = UniformExtents<D>(4);
  const stm::RootBox<D> ghost = stm::GhostRootBox<D>(owned, UniformExtents<D>(8), 2);
  EXPECT_EQ(ghost.Lower, UniformExtents<D>(0));
  EXPECT_EQ(ghost.Upper, UniformExtents<D>(6));
}

// ---------------------------------------------------------------------------------------------
// Meshing piece by piece.

/// A cell as the whole mesh has it: its corners in half lattice units of the whole image,
/// sorted, and its material.
template <int D>
using CellKey = std::pair<std::vector<stm::LatticeIndex<D>>, stm::MaterialIndex>;

/// The cells of `mesh` whose leaf lies in root box `owned` (in the mesh's own root indices),
/// their corners moved by `offset` half units.
template <int D>
std::vector<CellKey<D>> OwnedCells(const TessellationMesh<D>& mesh, const stm::RootBox<D>& owned,
  const stm::LatticeIndex<D>& rootHalfUnits, const stm::LatticeIndex<D>& offset)
{
  std::vector<CellKey<D>> keys;
  for (std::int64_t cell = 0; cell < mesh.GetNumberOfCells(); ++cell)
  {
    const int size = mesh.GetCellSize(cell);
    // A cell lies inside its leaf, so its corners' mean is inside it too.
    stm::LatticeIndex<D> sum{};
    for (int i = 0; i < size; ++i)
    {
      for (int axis = 0; axis < D; ++axis)
      {
        sum[axis] += mesh.CellPoint(cell, i)[axis];
      }
    }
    stm::LatticeIndex<D> root;
    for (int axis = 0; axis < D; ++axis)
    {
      root[axis] = sum[axis] / (size * rootHalfUnits[axis]);
    }
    if (!owned.Contains(root))
    {
      continue;
    }
    CellKey<D> key;
    key.second = mesh.Materials[cell];
    for (int i = 0; i < size; ++i)
    {
      stm::LatticeIndex<D> point = mesh.CellPoint(cell, i);
      for (int axis = 0; axis < D; ++axis)
      {
        point[axis] += offset[axis];
      }
      key.first.push_back(point);
    }
    std::sort(key.first.begin(), key.first.end());
    keys.push_back(key);
  }
  std::sort(keys.begin(), keys.end());
  return keys;
}

struct PieceCase
{
  int Split;                // split count of the pattern, every axis and level
  std::int64_t MaxCellSize; // root edge in voxels
  int BalanceLevel;
  stm::CellTemplate Template;
  stm::TessellationOutput Output;
  bool IncludeBackground;
};

template <int D>
void ExpectPiecesReproduceTheWholeMesh(const LabelImage<D>& image, const PieceCase& c)
{
  stm::SequentialExecutor executor;
  stm::RefinementPlanOptions<D> planOptions;
  planOptions.MaxCellSize = c.MaxCellSize;
  planOptions.Pattern = UniformPattern<D>(c.Split);
  stm::SpacetreeTessellationOptions tessellation;
  tessellation.Template = c.Template;
  tessellation.Output = c.Output;
  tessellation.IncludeBackground = c.IncludeBackground;

  stm::Spacetree<D> whole;
  ASSERT_TRUE(
    BuildTreeWithPlan<D>(image, planOptions, c.BalanceLevel, false, executor, whole).IsOk());
  TessellationMesh<D> wholeMesh;
  ASSERT_TRUE(TessellateTree<D>(whole, tessellation, executor, wholeMesh).IsOk());
  const stm::LatticeIndex<D> rootDims = whole.RootGridDimensions;
  stm::LatticeIndex<D> rootVoxels, rootHalfUnits;
  for (int axis = 0; axis < D; ++axis)
  {
    ASSERT_EQ(whole.VoxelSubdivision[axis], 1);
    rootVoxels[axis] = whole.GetRootCellSize()[axis];
    rootHalfUnits[axis] = 2 * rootVoxels[axis];
  }
  stm::RootBox<D> everything;
  everything.Upper = rootDims;
  const std::vector<CellKey<D>> expected =
    OwnedCells<D>(wholeMesh, everything, rootHalfUnits, stm::LatticeIndex<D>{});
  ASSERT_EQ(static_cast<std::int64_t>(expected.size()), wholeMesh.GetNumberOfCells());
  ASSERT_GT(stm::NumberOfLatticeCells<D>(rootDims), 2);

  // The boxes halved by root cells and balanced by the image's costs (as the filter does when
  // it has the whole image).
  const std::vector<std::int64_t> costs =
    stm::RootCellCosts<D>(image.View(), rootVoxels, rootDims, executor);
  for (int run = 0; run < 6; ++run)
  {
    const int pieces = std::array<int, 3>{ 2, 3, 5 }[run % 3];
    const bool balanced = run >= 3;
    SCOPED_TRACE(balanced ? "balanced by costs" : "halved by root cells");
    std::vector<CellKey<D>> together;
    for (int piece = 0; piece < pieces; ++piece)
    {
      SCOPED_TRACE("piece " + std::to_string(piece) + " of " + std::to_string(pieces));
      const stm::RootBox<D> owned = balanced ? stm::PieceRootBox<D>(rootDims, pieces, piece, costs)
                                             : stm::PieceRootBox<D>(rootDims, pieces, piece);
      if (owned.IsEmpty())
      {
        continue;
      }
      const stm::RootBox<D> ghost = stm::GhostRootBox<D>(owned, rootDims);
      // The piece's image: the voxels of its ghost box, clipped to the image.
      stm::LatticeIndex<D> first, dims, halfOffset;
      for (int axis = 0; axis < D; ++axis)
      {
        first[axis] = ghost.Lower[axis] * rootVoxels[axis];
        dims[axis] =
          std::min(image.GetDimensions()[axis], ghost.Upper[axis] * rootVoxels[axis]) - first[axis];
        halfOffset[axis] = 2 * first[axis];
      }
      LabelImage<D> part(dims);
      ForEachIndex<D>(dims,
        [&](const stm::LatticeIndex<D>& voxel)
        {
          stm::LatticeIndex<D> source;
          for (int axis = 0; axis < D; ++axis)
          {
            source[axis] = first[axis] + voxel[axis];
          }
          part.Set(voxel, image.At(source));
        });
      // The whole image's root edge: the piece alone may be too small for the plan to reach it.
      stm::RefinementPlanOptions<D> pieceOptions = planOptions;
      pieceOptions.RootCellSize = rootVoxels;
      stm::Spacetree<D> tree;
      // The whole image's material table, as the filter passes it.
      stm::Status built = stm::SpacetreeBuilder<D>().Build(
        part.View(), MaterialLabels(image.LargestMaterial() + 1), pieceOptions, tree, executor);
      ASSERT_TRUE(built.IsOk()) << built.GetMessage();
      if (c.BalanceLevel > 0)
      {
        stm::SpacetreeBalanceOptions balanceOptions;
        balanceOptions.BalanceLevel = c.BalanceLevel;
        ASSERT_TRUE(stm::SpacetreeBalancer<D>().Balance(tree, balanceOptions, executor).IsOk());
      }
      stm::RootBox<D> local;
      for (int axis = 0; axis < D; ++axis)
      {
        local.Lower[axis] = owned.Lower[axis] - ghost.Lower[axis];
        local.Upper[axis] = owned.Upper[axis] - ghost.Lower[axis];
      }
      // As the filter does: the outer ghost layer's leaves give no cells.
      stm::SpacetreeTessellationOptions pieceTessellation = tessellation;
      pieceTessellation.HiddenLeaves.assign(static_cast<std::size_t>(tree.GetNumberOfLeaves()), 0);
      const stm::RootBox<D> kept = local.Grown(stm::GhostRootLayers - 1);
      std::int64_t hidden = 0;
      for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
      {
        const bool inner = stm::LeafInRootBox<D>(tree, leaf, kept);
        pieceTessellation.HiddenLeaves[leaf] = inner ? 0 : 1;
        hidden += inner ? 0 : 1;
      }
      TessellationMesh<D> mesh;
      ASSERT_TRUE(TessellateTree<D>(tree, pieceTessellation, executor, mesh).IsOk());
      TessellationMesh<D> unhidden;
      ASSERT_TRUE(TessellateTree<D>(tree, tessellation, executor, unhidden).IsOk());
      EXPECT_LE(mesh.GetNumberOfCells(), unhidden.GetNumberOfCells());
      stm::SpacetreeTessellationOptions wrongSize = pieceTessellation;
      wrongSize.HiddenLeaves.push_back(0);
      TessellationMesh<D> refused;
      EXPECT_FALSE(TessellateTree<D>(tree, wrongSize, executor, refused).IsOk());
      if (hidden > 0 && c.IncludeBackground)
      {
        EXPECT_LT(mesh.GetNumberOfCells(), unhidden.GetNumberOfCells());
      }
      const std::vector<CellKey<D>> cells = OwnedCells<D>(mesh, local, rootHalfUnits, halfOffset);
      const std::vector<CellKey<D>> wholeCells =
        OwnedCells<D>(wholeMesh, owned, rootHalfUnits, stm::LatticeIndex<D>{});
      EXPECT_EQ(cells.size(), wholeCells.size());
      EXPECT_TRUE(cells == wholeCells) << "the piece's own cells are not the whole mesh's";
      together.insert(together.end(), cells.begin(), cells.end());
    }
    std::sort(together.begin(), together.end());
    EXPECT_TRUE(together == expected) << pieces << " pieces together are not the whole mesh ("
                                      << together.size() << " of " << expected.size() << " cells)";
  }
}

std::string Describe(const PieceCase& c)
{
  return "split " + std::to_string(c.Split) + ", root " + std::to_string(c.MaxCellSize) + ", L " +
    std::to_string(c.BalanceLevel) +
    (c.Template == stm::CellTemplate::Kuhn ? ", Kuhn" : ", checkerboard") +
    (c.Output == stm::TessellationOutput::Hybrid ? ", hybrid" : ", simplices") +
    (c.IncludeBackground ? ", with background" : "");
}

class RootPiecesMeshTest : public ::testing::Test
{
};

const PieceCase PieceCases[] = {
  { 2, 8, 1, stm::CellTemplate::Checkerboard, stm::TessellationOutput::Simplices, false },
  { 2, 8, 1, stm::CellTemplate::Kuhn, stm::TessellationOutput::Simplices, true },
  { 2, 8, 2, stm::CellTemplate::Checkerboard, stm::TessellationOutput::Hybrid, false },
  { 2, 4, 0, stm::CellTemplate::Checkerboard, stm::TessellationOutput::Simplices, true },
  { 3, 9, 1, stm::CellTemplate::Checkerboard, stm::TessellationOutput::Simplices, true },
  { 3, 9, 1, stm::CellTemplate::Checkerboard, stm::TessellationOutput::Hybrid, false },
};

TEST_F(RootPiecesMeshTest, PiecesReproduceTheWholeMesh2D)
{
  const LabelImage<2> image = MakeRandomImage<2>(FirstExtents<2>({ 75, 58 }), 39, 3, 7, 25);
  for (const PieceCase& c : PieceCases)
  {
    SCOPED_TRACE(Describe(c));
    ExpectPiecesReproduceTheWholeMesh<2>(image, c);
  }
}

TEST_F(RootPiecesMeshTest, FineLeavesBeyondTheGhostLayer)
{
  // One row of four root cells of 8 voxels. Fine leaves in the last one, at its face with the
  // third, split that root leaf in the whole tree, which puts a hanging node on the face of the
  // second, a root leaf too. Meshed with root cells 0 and 1 as its own, a piece must see the
  // fourth root cell's leaves to get that node: a ghost layer of one root cell is not enough.
  LabelImage<2> image(FirstExtents<2>({ 32, 8 }));
  image.Set(FirstExtents<2>({ 0, 0 }), 1);
  for (int y = 0; y < 3; ++y)
  {
    image.Set(FirstExtents<2>({ 24, y }), 1);
  }
  for (const PieceCase& c : PieceCases)
  {
    if (c.MaxCellSize == 8)
    {
      SCOPED_TRACE(Describe(c));
      ExpectPiecesReproduceTheWholeMesh<2>(image, c);
    }
  }
}

TEST_F(RootPiecesMeshTest, PiecesReproduceTheWholeMesh3D)
{
  const LabelImage<3> image = MakeRandomImage<3>(FirstExtents<3>({ 38, 29, 25 }), 40, 3, 6, 15);
  for (const PieceCase& c : PieceCases)
  {
    SCOPED_TRACE(Describe(c));
    ExpectPiecesReproduceTheWholeMesh<3>(image, c);
  }
}

} // namespace
