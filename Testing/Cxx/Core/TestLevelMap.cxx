// SPDX-License-Identifier: BSD-3-Clause
// LevelMap is the dense cell -> (level, material) view that balancing edits; turning it back into
// leaves must give the canonical leaf list, so that balancing a tree cannot reorder it.

#include "CoreTestUtilities.h"

#include "Spacetree/LevelMap.h"

namespace
{
using namespace stmtest;

template <class DimensionTag>
class LevelMapTest : public ::testing::Test
{
};
TYPED_TEST_SUITE(LevelMapTest, AllDimensions);

template <int D>
stm::Spacetree<D> MakeLevelMapTree(unsigned seed)
{
  const stm::LatticeIndex<D> dims =
    D == 4 ? FirstExtents<D>({ 9, 8, 7, 6 }) : FirstExtents<D>({ 41, 27, 19, 1 });
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  // MaxCellSize 8: several roots, so the per-root collection is exercised too.
  EXPECT_TRUE(
    BuildTree<D>(MakeRandomImage<D>(dims, seed, 3, 4, 20), 8, 0, false, executor, tree).IsOk());
  return tree;
}

TYPED_TEST(LevelMapTest, EveryCellReportsTheLevelMaterialAndAnchorOfItsLeaf)
{
  constexpr int D = TypeParam::value;
  const stm::Spacetree<D> tree = MakeLevelMapTree<D>(1);
  stm::SequentialExecutor executor;
  stm::LevelMap<D> map;
  ASSERT_TRUE(map.Build(tree, executor).IsOk());
  EXPECT_EQ(map.GetDimensions(), tree.GetLatticeDimensions());
  for (int level = 0; level <= tree.MaxLevel; ++level)
  {
    EXPECT_EQ(map.CellSize(level), tree.GetCellSize(level));
  }

  std::vector<std::int64_t> cellToLeaf;
  ASSERT_EQ(MapCellsToLeaves<D>(tree, cellToLeaf), 0);
  const stm::LatticeIndex<D> dims = tree.GetLatticeDimensions();
  std::int64_t wrongLevels = 0, wrongMaterials = 0, wrongAnchors = 0, notContained = 0;
  ForEachIndex<D>(dims,
    [&](const stm::LatticeIndex<D>& cell)
    {
      const std::int64_t leaf = cellToLeaf[stm::LinearIndex<D>(cell, dims)];
      notContained += !map.Contains(cell);
      wrongLevels += map.LevelAt(cell) != tree.LeafLevels[leaf];
      wrongMaterials += map.MaterialAt(cell) != tree.LeafMaterials[leaf];
      wrongAnchors += map.AnchorOf(cell, tree.LeafLevels[leaf]) != tree.LeafAnchors[leaf];
    });
  EXPECT_EQ(notContained, 0);
  EXPECT_EQ(wrongLevels, 0);
  EXPECT_EQ(wrongMaterials, 0);
  EXPECT_EQ(wrongAnchors, 0);

  for (int axis = 0; axis < D; ++axis)
  {
    stm::LatticeIndex<D> below{}, beyond{};
    below[axis] = -1;
    beyond[axis] = dims[axis];
    EXPECT_FALSE(map.Contains(below));
    EXPECT_FALSE(map.Contains(beyond));
  }
}

TYPED_TEST(LevelMapTest, CollectLeavesReproducesTheCanonicalLeafList)
{
  constexpr int D = TypeParam::value;
  for (unsigned seed : { 2u, 3u })
  {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const stm::Spacetree<D> tree = MakeLevelMapTree<D>(seed);
    stm::SequentialExecutor executor;
    stm::LevelMap<D> map;
    ASSERT_TRUE(map.Build(tree, executor).IsOk());
    stm::Spacetree<D> collected = tree;
    collected.ClearLeaves();
    collected.AddLeaf(0, stm::LatticeIndex<D>{}, 7); // must be discarded, not appended to
    ASSERT_TRUE(map.CollectLeaves(collected, executor).IsOk());
    EXPECT_EQ(collected.LeafLevels, tree.LeafLevels);
    EXPECT_EQ(collected.LeafAnchors, tree.LeafAnchors);
    EXPECT_EQ(collected.LeafMaterials, tree.LeafMaterials);
  }
}

TYPED_TEST(LevelMapTest, SplitReplacesOneLeafByItsChildrenInPlace)
{
  constexpr int D = TypeParam::value;
  const stm::Spacetree<D> tree = MakeLevelMapTree<D>(4);
  // The coarsest leaf, so that its children are not at the finest level already.
  const std::int64_t split =
    std::min_element(tree.LeafLevels.begin(), tree.LeafLevels.end()) - tree.LeafLevels.begin();
  const int level = tree.LeafLevels[split];
  ASSERT_LT(level, tree.MaxLevel);

  stm::SequentialExecutor executor;
  stm::LevelMap<D> map;
  ASSERT_TRUE(map.Build(tree, executor).IsOk());
  map.Split(tree.LeafAnchors[split], level);
  stm::Spacetree<D> collected = tree;
  ASSERT_TRUE(map.CollectLeaves(collected, executor).IsOk());

  // Expected: the same list with the split leaf replaced by its 2^D children, in linear order.
  stm::Spacetree<D> expected = tree;
  expected.ClearLeaves();
  for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
  {
    if (leaf != split)
    {
      expected.AddLeaf(tree.LeafLevels[leaf], tree.LeafAnchors[leaf], tree.LeafMaterials[leaf]);
      continue;
    }
    for (int child = 0; child < (1 << D); ++child)
    {
      stm::LatticeIndex<D> anchor = tree.LeafAnchors[leaf];
      for (int axis = 0; axis < D; ++axis)
      {
        anchor[axis] += ((child >> axis) & 1) * tree.GetCellSize(level + 1)[axis];
      }
      expected.AddLeaf(level + 1, anchor, tree.LeafMaterials[leaf]);
    }
  }
  EXPECT_EQ(collected.LeafLevels, expected.LeafLevels);
  EXPECT_EQ(collected.LeafAnchors, expected.LeafAnchors);
  EXPECT_EQ(collected.LeafMaterials, expected.LeafMaterials);
}

TYPED_TEST(LevelMapTest, AbortedExecutorStopsBuildAndCollect)
{
  constexpr int D = TypeParam::value;
  const stm::Spacetree<D> tree = MakeLevelMapTree<D>(5);
  stm::SequentialExecutor executor;
  stm::LevelMap<D> map;
  ASSERT_TRUE(map.Build(tree, executor).IsOk());
  executor.RequestAbort();
  EXPECT_EQ(map.Build(tree, executor).GetCode(), stm::Status::Code::Aborted);
  stm::Spacetree<D> collected = tree;
  EXPECT_EQ(map.CollectLeaves(collected, executor).GetCode(), stm::Status::Code::Aborted);
}

} // namespace
