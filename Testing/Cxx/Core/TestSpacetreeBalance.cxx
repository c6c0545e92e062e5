// SPDX-License-Identifier: BSD-3-Clause
// SpacetreeBalancer: after balancing, adjacent leaves differ by at most BalanceLevel levels; the
// balanced tree is a refinement of the original (never coarser, same materials) and the coarsest
// one: every split is forced by a leaf that is too fine. Adjacency and level differences are
// recomputed here from a dense cell -> leaf map, independently of LevelMap.

#include "CoreTestUtilities.h"

#include <cstdlib>
#include <functional>
#include <set>

namespace
{
using namespace stmtest;

template <class DimensionTag>
class SpacetreeBalanceTest : public ::testing::Test
{
};
TYPED_TEST_SUITE(SpacetreeBalanceTest, AllDimensions);

template <int D>
LabelImage<D> MakeBalanceImage(unsigned seed)
{
  const stm::LatticeIndex<D> dims =
    D == 4 ? FirstExtents<D>({ 8, 8, 7, 6 }) : FirstExtents<D>({ 61, 29, 19, 1 });
  return MakeRandomImage<D>(dims, seed, 3, 5, 8);
}

/// The neighbour offsets {-1,0,1}^D without 0, or only the 2D facet offsets; enumerated here
/// rather than taken from the code under test.
template <int D>
std::vector<stm::LatticeIndex<D>> Offsets(bool facetsOnly)
{
  std::vector<stm::LatticeIndex<D>> offsets;
  ForEachIndex<D>(UniformExtents<D>(3),
    [&](const stm::LatticeIndex<D>& code)
    {
      stm::LatticeIndex<D> offset;
      int nonZero = 0;
      for (int axis = 0; axis < D; ++axis)
      {
        offset[axis] = code[axis] - 1;
        nonZero += offset[axis] != 0;
      }
      if (nonZero > 0 && (!facetsOnly || nonZero == 1))
      {
        offsets.push_back(offset);
      }
    });
  return offsets;
}

/// Largest level difference between two leaves that contain adjacent lattice cells. Two leaves
/// share a facet (or any vertex) exactly when some pair of their cells does.
template <int D>
int ReferenceMaximumLevelDifference(const stm::Spacetree<D>& tree, bool facetsOnly)
{
  std::vector<std::int64_t> cellToLeaf;
  MapCellsToLeaves<D>(tree, cellToLeaf);
  const stm::LatticeIndex<D> dims = tree.GetLatticeDimensions();
  const auto offsets = Offsets<D>(facetsOnly);
  int worst = 0;
  ForEachIndex<D>(dims,
    [&](const stm::LatticeIndex<D>& cell)
    {
      const int level = tree.LeafLevels[cellToLeaf[stm::LinearIndex<D>(cell, dims)]];
      for (const auto& offset : offsets)
      {
        stm::LatticeIndex<D> neighbor;
        bool inside = true;
        for (int axis = 0; axis < D; ++axis)
        {
          neighbor[axis] = cell[axis] + offset[axis];
          inside = inside && neighbor[axis] >= 0 && neighbor[axis] < dims[axis];
        }
        if (inside)
        {
          const int other = tree.LeafLevels[cellToLeaf[stm::LinearIndex<D>(neighbor, dims)]];
          worst = std::max(worst, std::abs(other - level));
        }
      }
    });
  return worst;
}

/// The canonical order rebuilt from the set of leaves: roots in linear order, children of a
/// split cube in linear order, depth first.
template <int D>
void ExpectCanonicalOrder(const stm::Spacetree<D>& tree)
{
  std::set<std::pair<int, stm::LatticeIndex<D>>> leaves;
  for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
  {
    leaves.emplace(tree.LeafLevels[leaf], tree.LeafAnchors[leaf]);
  }
  std::vector<stm::LatticeIndex<D>> expectedAnchors;
  std::vector<std::uint8_t> expectedLevels;
  std::function<void(const stm::LatticeIndex<D>&, int)> visit =
    [&](const stm::LatticeIndex<D>& anchor, int level)
  {
    if (leaves.count({ level, anchor }) || level >= tree.MaxLevel)
    {
      expectedAnchors.push_back(anchor);
      expectedLevels.push_back(static_cast<std::uint8_t>(level));
      return;
    }
    const std::int64_t half = tree.GetCellSize(level + 1)[0];
    for (int child = 0; child < (1 << D); ++child)
    {
      stm::LatticeIndex<D> childAnchor = anchor;
      for (int axis = 0; axis < D; ++axis)
      {
        childAnchor[axis] += ((child >> axis) & 1) * half;
      }
      visit(childAnchor, level + 1);
    }
  };
  ForEachIndex<D>(tree.RootGridDimensions,
    [&](const stm::LatticeIndex<D>& root)
    {
      stm::LatticeIndex<D> anchor;
      for (int axis = 0; axis < D; ++axis)
      {
        anchor[axis] = root[axis] * tree.GetRootCellSize()[axis];
      }
      visit(anchor, 0);
    });
  EXPECT_EQ(tree.LeafAnchors, expectedAnchors);
  EXPECT_EQ(tree.LeafLevels, expectedLevels);
}

/// refined must be the original with some leaves split: each original leaf is still a leaf or is
/// covered exactly by strictly finer leaves of its material.
template <int D>
void ExpectRefinementOf(const stm::Spacetree<D>& original, const stm::Spacetree<D>& refined)
{
  ASSERT_EQ(refined.MaxLevel, original.MaxLevel);
  ASSERT_EQ(refined.RootGridDimensions, original.RootGridDimensions);
  EXPECT_EQ(refined.ImageDimensions, original.ImageDimensions);
  EXPECT_EQ(refined.MaterialLabels, original.MaterialLabels);

  std::vector<std::int64_t> refinedCells;
  EXPECT_EQ(MapCellsToLeaves<D>(refined, refinedCells), 0) << "refined leaves overlap";
  EXPECT_EQ(std::count(refinedCells.begin(), refinedCells.end(), -1), 0) << "uncovered cells";

  std::vector<std::int64_t> originalCells;
  MapCellsToLeaves<D>(original, originalCells);
  const stm::LatticeIndex<D> dims = original.GetLatticeDimensions();
  std::vector<std::int64_t> coveredVolume(original.LeafLevels.size(), 0);
  std::int64_t coarsened = 0, recoloured = 0, misaligned = 0;
  for (std::int64_t leaf = 0; leaf < refined.GetNumberOfLeaves(); ++leaf)
  {
    const auto& anchor = refined.LeafAnchors[leaf];
    for (int axis = 0; axis < D; ++axis)
    {
      misaligned += anchor[axis] % refined.GetCellSize(refined.LeafLevels[leaf])[axis] != 0;
    }
    const std::int64_t owner = originalCells[stm::LinearIndex<D>(anchor, dims)];
    // An aligned cube no coarser than the original leaf holding its anchor lies inside it.
    coarsened += refined.LeafLevels[leaf] < original.LeafLevels[owner];
    recoloured += refined.LeafMaterials[leaf] != original.LeafMaterials[owner];
    coveredVolume[owner] += LeafVolume<D>(refined, leaf);
  }
  EXPECT_EQ(misaligned, 0);
  EXPECT_EQ(coarsened, 0) << "balancing coarsened a leaf";
  EXPECT_EQ(recoloured, 0) << "balancing changed a material";
  std::int64_t badlyCovered = 0;
  for (std::int64_t leaf = 0; leaf < original.GetNumberOfLeaves(); ++leaf)
  {
    badlyCovered += coveredVolume[leaf] != LeafVolume<D>(original, leaf);
  }
  EXPECT_EQ(badlyCovered, 0) << "an original leaf is not covered exactly by its refinement";
}

/// Every leaf that balancing created has a parent that had to be split: some leaf adjacent to
/// the parent is more than BalanceLevel levels finer than the parent.
template <int D>
std::int64_t CountUnforcedSplits(
  const stm::Spacetree<D>& original, const stm::Spacetree<D>& balanced, int L, bool facetsOnly)
{
  std::set<std::pair<int, stm::LatticeIndex<D>>> originalLeaves;
  for (std::int64_t leaf = 0; leaf < original.GetNumberOfLeaves(); ++leaf)
  {
    originalLeaves.emplace(original.LeafLevels[leaf], original.LeafAnchors[leaf]);
  }
  std::vector<std::int64_t> cellToLeaf;
  MapCellsToLeaves<D>(balanced, cellToLeaf);
  const stm::LatticeIndex<D> dims = balanced.GetLatticeDimensions();
  std::set<std::pair<int, stm::LatticeIndex<D>>> checkedParents;
  std::int64_t unforced = 0;
  for (std::int64_t leaf = 0; leaf < balanced.GetNumberOfLeaves(); ++leaf)
  {
    const int level = balanced.LeafLevels[leaf];
    if (originalLeaves.count({ level, balanced.LeafAnchors[leaf] }))
    {
      continue;
    }
    const int parentLevel = level - 1;
    const std::int64_t parentSize = balanced.GetCellSize(parentLevel)[0];
    stm::LatticeIndex<D> parent, shellLower, shellUpper;
    for (int axis = 0; axis < D; ++axis)
    {
      parent[axis] =
        balanced.LeafAnchors[leaf][axis] - balanced.LeafAnchors[leaf][axis] % parentSize;
      shellLower[axis] = parent[axis] - 1;
      shellUpper[axis] = parent[axis] + parentSize + 1;
    }
    if (!checkedParents.insert({ parentLevel, parent }).second)
    {
      continue;
    }
    // Finest leaf touching the parent: cells of the one-cell shell around it (for facets only,
    // the shell cells outside exactly one facet).
    int finest = -1;
    ForEachIndexInBox<D>(shellLower, shellUpper,
      [&](const stm::LatticeIndex<D>& cell)
      {
        int outside = 0;
        for (int axis = 0; axis < D; ++axis)
        {
          if (cell[axis] < 0 || cell[axis] >= dims[axis])
          {
            return;
          }
          outside += cell[axis] < parent[axis] || cell[axis] >= parent[axis] + parentSize;
        }
        if (outside == 0 || (facetsOnly && outside != 1))
        {
          return;
        }
        finest =
          std::max<int>(finest, balanced.LeafLevels[cellToLeaf[stm::LinearIndex<D>(cell, dims)]]);
      });
    unforced += finest <= parentLevel + L;
  }
  return unforced;
}

template <int D>
void ExpectSameLeaves(const stm::Spacetree<D>& expected, const stm::Spacetree<D>& actual)
{
  EXPECT_EQ(actual.LeafLevels, expected.LeafLevels);
  EXPECT_EQ(actual.LeafAnchors, expected.LeafAnchors);
  EXPECT_EQ(actual.LeafMaterials, expected.LeafMaterials);
}

TYPED_TEST(SpacetreeBalanceTest, BalancedTreeIsTheCoarsestBalancedRefinement)
{
  constexpr int D = TypeParam::value;
  for (unsigned seed : { 1u, 2u, 3u })
  {
    const LabelImage<D> image = MakeBalanceImage<D>(seed);
    stm::SequentialExecutor executor;
    stm::Spacetree<D> original;
    ASSERT_TRUE(BuildTree<D>(image, 16, 0, false, executor, original).IsOk());
    const int unbalancedDifference = ReferenceMaximumLevelDifference<D>(original, false);
    for (int L : { 1, 2, 3 })
    {
      for (bool facetsOnly : { false, true })
      {
        SCOPED_TRACE("seed " + std::to_string(seed) + ", L " + std::to_string(L) +
          (facetsOnly ? ", facets only" : ", all neighbours"));
        stm::Spacetree<D> tree = original;
        stm::SpacetreeBalanceOptions options;
        options.BalanceLevel = L;
        options.FaceBalanceOnly = facetsOnly;
        const stm::Status status = stm::SpacetreeBalancer<D>().Balance(tree, options, executor);
        ASSERT_TRUE(status.IsOk()) << status.GetMessage();
        EXPECT_EQ(tree.BalanceLevel, L);
        EXPECT_EQ(tree.FaceBalanceOnly, facetsOnly);

        const int difference = ReferenceMaximumLevelDifference<D>(tree, facetsOnly);
        EXPECT_LE(difference, L);
        EXPECT_EQ(stm::MaximumLevelDifference<D>(tree, facetsOnly, executor), difference);
        if (unbalancedDifference > L)
        {
          EXPECT_GT(tree.GetNumberOfLeaves(), original.GetNumberOfLeaves());
        }
        ExpectRefinementOf<D>(original, tree);
        EXPECT_EQ(CountMaterialMismatches<D>(tree, image), 0);
        ExpectCanonicalOrder<D>(tree);
        EXPECT_EQ(CountUnforcedSplits<D>(original, tree, L, facetsOnly), 0)
          << "balancing split a leaf that no finer neighbour forced";
      }
    }
  }
}

TYPED_TEST(SpacetreeBalanceTest, RandomImagesActuallyNeedBalancing)
{
  constexpr int D = TypeParam::value;
  // Guards the test above against images so tame that balancing would have nothing to do.
  stm::SequentialExecutor executor;
  int worst = 0;
  for (unsigned seed : { 1u, 2u, 3u })
  {
    stm::Spacetree<D> tree;
    ASSERT_TRUE(BuildTree<D>(MakeBalanceImage<D>(seed), 16, 0, false, executor, tree).IsOk());
    worst = std::max(worst, ReferenceMaximumLevelDifference<D>(tree, true));
    EXPECT_EQ(stm::MaximumLevelDifference<D>(tree, true, executor),
      ReferenceMaximumLevelDifference<D>(tree, true));
    EXPECT_EQ(stm::MaximumLevelDifference<D>(tree, false, executor),
      ReferenceMaximumLevelDifference<D>(tree, false));
  }
  EXPECT_GE(worst, 2);
}

TYPED_TEST(SpacetreeBalanceTest, SpeckAtARootCornerIsGradedToExactlyL)
{
  constexpr int D = TypeParam::value;
  // Two roots along axis 0, all material 1 except the voxel of root 0 at its far corner: that
  // voxel is a leaf of the finest level whose facet touches the whole unsplit root 1.
  const std::int64_t rootSize = D == 4 ? 8 : 16;
  stm::LatticeIndex<D> dims = UniformExtents<D>(rootSize);
  dims[0] = 2 * rootSize;
  LabelImage<D> image(dims);
  std::fill(image.GetValues().begin(), image.GetValues().end(), 1);
  image.Set(UniformExtents<D>(rootSize - 1), 2);

  stm::SequentialExecutor executor;
  stm::Spacetree<D> original;
  ASSERT_TRUE(BuildTree<D>(image, rootSize, 0, false, executor, original).IsOk());
  const int maxLevel = original.MaxLevel;
  ASSERT_GE(maxLevel, 3);
  EXPECT_EQ(ReferenceMaximumLevelDifference<D>(original, true), maxLevel);
  EXPECT_EQ(stm::MaximumLevelDifference<D>(original, true, executor), maxLevel);
  for (int L : { 1, 2, 3 })
  {
    for (bool facetsOnly : { false, true })
    {
      SCOPED_TRACE("L " + std::to_string(L) + (facetsOnly ? ", facets only" : ", all"));
      stm::Spacetree<D> tree = original;
      stm::SpacetreeBalanceOptions options;
      options.BalanceLevel = L;
      options.FaceBalanceOnly = facetsOnly;
      ASSERT_TRUE(stm::SpacetreeBalancer<D>().Balance(tree, options, executor).IsOk());
      EXPECT_EQ(ReferenceMaximumLevelDifference<D>(tree, facetsOnly), std::min(L, maxLevel));
      EXPECT_EQ(stm::MaximumLevelDifference<D>(tree, facetsOnly, executor), std::min(L, maxLevel));
      ExpectRefinementOf<D>(original, tree);
      EXPECT_EQ(CountUnforcedSplits<D>(original, tree, L, facetsOnly), 0);
    }
  }
}

TEST(SpacetreeBalance, OneDimensionalSpeckGivesTheHandCountedLeaves)
{
  // 32 voxels, roots [0,16) and [16,32), a speck at voxel 15. Unbalanced leaves:
  //   [0,8) [8,12) [12,14) [14,15) [15,16) | [16,32)                      -> 6 leaves.
  // L = 1: [15,16) (level 4) forces [16,32) down to level 3:
  //   ... [15,16) | [16,18) [18,20) [20,24) [24,32)                       -> 9 leaves.
  LabelImage<1> image({ 32 });
  std::fill(image.GetValues().begin(), image.GetValues().end(), 1);
  image.Set({ 15 }, 2);
  stm::SequentialExecutor executor;
  stm::Spacetree<1> tree;
  ASSERT_TRUE(BuildTree<1>(image, 16, 0, false, executor, tree).IsOk());
  EXPECT_EQ(tree.GetNumberOfLeaves(), 6);
  ASSERT_TRUE(BuildTree<1>(image, 16, 1, false, executor, tree).IsOk());
  const std::vector<stm::LatticeIndex<1>> anchors = { { 0 }, { 8 }, { 12 }, { 14 }, { 15 }, { 16 },
    { 18 }, { 20 }, { 24 } };
  const std::vector<std::uint8_t> levels = { 1, 2, 3, 4, 4, 3, 3, 2, 1 };
  const std::vector<stm::MaterialIndex> materials = { 1, 1, 1, 1, 2, 1, 1, 1, 1 };
  EXPECT_EQ(tree.LeafAnchors, anchors);
  EXPECT_EQ(tree.LeafLevels, levels);
  EXPECT_EQ(tree.LeafMaterials, materials);
}

TYPED_TEST(SpacetreeBalanceTest, BalancingABalancedTreeChangesNothing)
{
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = MakeBalanceImage<D>(7);
  stm::SequentialExecutor executor;
  for (bool facetsOnly : { false, true })
  {
    SCOPED_TRACE(facetsOnly ? "facets only" : "all neighbours");
    stm::Spacetree<D> once;
    ASSERT_TRUE(BuildTree<D>(image, 16, 1, facetsOnly, executor, once).IsOk());
    stm::Spacetree<D> twice = once;
    stm::SpacetreeBalanceOptions options;
    options.BalanceLevel = 1;
    options.FaceBalanceOnly = facetsOnly;
    ASSERT_TRUE(stm::SpacetreeBalancer<D>().Balance(twice, options, executor).IsOk());
    ExpectSameLeaves<D>(once, twice);

    // A 1-balanced tree is also 2- and 3-balanced; only the recorded level changes.
    for (int L : { 2, 3 })
    {
      stm::Spacetree<D> looser = once;
      options.BalanceLevel = L;
      ASSERT_TRUE(stm::SpacetreeBalancer<D>().Balance(looser, options, executor).IsOk());
      ExpectSameLeaves<D>(once, looser);
      EXPECT_EQ(looser.BalanceLevel, L);
    }
  }
  // Vertex balance implies facet balance.
  stm::Spacetree<D> vertexBalanced;
  ASSERT_TRUE(BuildTree<D>(image, 16, 2, false, executor, vertexBalanced).IsOk());
  stm::Spacetree<D> thenFacet = vertexBalanced;
  stm::SpacetreeBalanceOptions facetOptions;
  facetOptions.BalanceLevel = 2;
  facetOptions.FaceBalanceOnly = true;
  ASSERT_TRUE(stm::SpacetreeBalancer<D>().Balance(thenFacet, facetOptions, executor).IsOk());
  ExpectSameLeaves<D>(vertexBalanced, thenFacet);
}

TYPED_TEST(SpacetreeBalanceTest, NonPositiveBalanceLevelIsInvalidAndLeavesTheTreeAlone)
{
  constexpr int D = TypeParam::value;
  stm::SequentialExecutor executor;
  stm::Spacetree<D> original;
  ASSERT_TRUE(BuildTree<D>(MakeBalanceImage<D>(8), 16, 0, false, executor, original).IsOk());
  for (int L : { 0, -1 })
  {
    SCOPED_TRACE("BalanceLevel " + std::to_string(L));
    stm::Spacetree<D> tree = original;
    stm::SpacetreeBalanceOptions options;
    options.BalanceLevel = L;
    const stm::Status status = stm::SpacetreeBalancer<D>().Balance(tree, options, executor);
    EXPECT_FALSE(status.IsOk());
    EXPECT_EQ(status.GetCode(), stm::Status::Code::InvalidArgument);
    ExpectSameLeaves<D>(original, tree);
    EXPECT_EQ(tree.BalanceLevel, -1);
  }
}

TYPED_TEST(SpacetreeBalanceTest, ParallelBalancingGivesTheSameTree)
{
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = MakeBalanceImage<D>(9);
  stm::SequentialExecutor sequential;
  stm::Spacetree<D> expected;
  ASSERT_TRUE(BuildTree<D>(image, 4, 1, false, sequential, expected).IsOk());
  for (int threads : { 2, 3 })
  {
    SCOPED_TRACE(std::to_string(threads) + " threads");
    stm::ThreadPoolExecutor pool(threads);
    stm::Spacetree<D> tree;
    ASSERT_TRUE(BuildTree<D>(image, 4, 1, false, pool, tree).IsOk());
    ExpectSameLeaves<D>(expected, tree);
  }
}

TYPED_TEST(SpacetreeBalanceTest, AbortedExecutorReturnsAbortedAndLeavesTheTreeAlone)
{
  constexpr int D = TypeParam::value;
  stm::SequentialExecutor executor;
  stm::Spacetree<D> original;
  ASSERT_TRUE(BuildTree<D>(MakeBalanceImage<D>(10), 16, 0, false, executor, original).IsOk());
  stm::Spacetree<D> tree = original;
  executor.RequestAbort();
  stm::SpacetreeBalanceOptions options;
  EXPECT_EQ(stm::SpacetreeBalancer<D>().Balance(tree, options, executor).GetCode(),
    stm::Status::Code::Aborted);
  ExpectSameLeaves<D>(original, tree);
  EXPECT_EQ(tree.BalanceLevel, -1);
}

} // namespace
