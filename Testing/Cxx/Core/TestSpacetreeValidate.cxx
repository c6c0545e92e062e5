// SPDX-License-Identifier: BSD-3-Clause
// ValidateSpacetree guards the algorithms against trees from outside the core (files, other
// programs): every tree the core builds must pass, and every way of breaking the partition of
// the root grid must be rejected before an algorithm reads out of bounds.

#include "CoreTestUtilities.h"

#include "Spacetree/SpacetreeValidate.h"

namespace
{
using namespace stmtest;

template <class DimensionTag>
class SpacetreeValidateTest : public ::testing::Test
{
};
TYPED_TEST_SUITE(SpacetreeValidateTest, AllDimensions);

template <int D>
stm::Spacetree<D> MakeValidTree(int balanceLevel)
{
  const stm::LatticeIndex<D> dims =
    D == 4 ? FirstExtents<D>({ 8, 7, 6, 5 }) : FirstExtents<D>({ 37, 23, 13, 1 });
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  EXPECT_TRUE(
    BuildTree<D>(MakeRandomImage<D>(dims, 3, 2, 4, 20), 8, balanceLevel, false, executor, tree)
      .IsOk());
  return tree;
}

/// Index of a leaf that can be split (not at the finest level).
template <int D>
std::int64_t CoarseLeaf(const stm::Spacetree<D>& tree)
{
  return std::min_element(tree.LeafLevels.begin(), tree.LeafLevels.end()) - tree.LeafLevels.begin();
}

template <int D>
void ExpectInvalid(const stm::Spacetree<D>& tree, stm::Status::Code code, const char* what)
{
  const stm::Status status = stm::ValidateSpacetree<D>(tree);
  EXPECT_FALSE(status.IsOk()) << what;
  EXPECT_EQ(status.GetCode(), code) << what << ": " << status.GetMessage();
  EXPECT_FALSE(status.GetMessage().empty()) << what;
}

TYPED_TEST(SpacetreeValidateTest, TreesBuiltAndBalancedByTheCoreAreValid)
{
  constexpr int D = TypeParam::value;
  for (int L : { 0, 1, 2 })
  {
    const stm::Status status = stm::ValidateSpacetree<D>(MakeValidTree<D>(L));
    EXPECT_TRUE(status.IsOk()) << "L " << L << ": " << status.GetMessage();
  }
}

TYPED_TEST(SpacetreeValidateTest, SplittingALeafIntoItsChildrenKeepsTheTreeValid)
{
  constexpr int D = TypeParam::value;
  stm::Spacetree<D> tree = MakeValidTree<D>(0);
  const std::int64_t leaf = CoarseLeaf<D>(tree);
  const int level = tree.LeafLevels[leaf];
  ASSERT_LT(level, tree.MaxLevel);
  const stm::LatticeIndex<D> anchor = tree.LeafAnchors[leaf];
  const stm::MaterialIndex material = tree.LeafMaterials[leaf];
  // Replace the leaf by its first child and append the others: the order does not matter.
  tree.LeafLevels[leaf] = static_cast<std::uint8_t>(level + 1);
  for (int child = 1; child < (1 << D); ++child)
  {
    stm::LatticeIndex<D> childAnchor = anchor;
    for (int axis = 0; axis < D; ++axis)
    {
      childAnchor[axis] += ((child >> axis) & 1) * tree.GetCellSize(level + 1)[axis];
    }
    tree.AddLeaf(level + 1, childAnchor, material);
  }
  const stm::Status status = stm::ValidateSpacetree<D>(tree);
  EXPECT_TRUE(status.IsOk()) << status.GetMessage();
}

TYPED_TEST(SpacetreeValidateTest, BrokenHeadersAreRejected)
{
  constexpr int D = TypeParam::value;
  const stm::Spacetree<D> valid = MakeValidTree<D>(0);
  const auto invalid = stm::Status::Code::InvalidArgument;
  {
    stm::Spacetree<D> tree = valid;
    tree.MaxLevel = -1;
    ExpectInvalid<D>(tree, invalid, "negative MaxLevel");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.MaxLevel = 21;
    ExpectInvalid<D>(tree, invalid, "MaxLevel above 20");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.RootGridDimensions[D - 1] = 0;
    ExpectInvalid<D>(tree, invalid, "empty root grid");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.ImageDimensions[0] = 0;
    ExpectInvalid<D>(tree, invalid, "empty image");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.ImageDimensions[0] = tree.GetLatticeDimensions()[0] + 1;
    ExpectInvalid<D>(tree, invalid, "image larger than the root grid");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.MaterialLabels.clear();
    ExpectInvalid<D>(tree, invalid, "no material table");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.MaterialLabels.resize(65537, 0);
    ExpectInvalid<D>(tree, invalid, "more materials than MaterialIndex can hold");
  }
}

TYPED_TEST(SpacetreeValidateTest, BrokenLeavesAreRejected)
{
  constexpr int D = TypeParam::value;
  const stm::Spacetree<D> valid = MakeValidTree<D>(0);
  const std::int64_t coarse = CoarseLeaf<D>(valid);
  ASSERT_LT(valid.LeafLevels[coarse], valid.MaxLevel);
  const auto invalid = stm::Status::Code::InvalidArgument;
  {
    stm::Spacetree<D> tree = valid;
    tree.LeafLevels.back() = static_cast<std::uint8_t>(tree.MaxLevel + 1);
    ExpectInvalid<D>(tree, invalid, "leaf finer than MaxLevel");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.LeafMaterials.back() = static_cast<stm::MaterialIndex>(tree.MaterialLabels.size());
    ExpectInvalid<D>(tree, invalid, "unknown material");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.LeafAnchors[coarse][0] += 1;
    ExpectInvalid<D>(tree, invalid, "anchor off its level's lattice");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.LeafAnchors.back()[D - 1] = -tree.GetCellSize(tree.LeafLevels.back())[D - 1];
    ExpectInvalid<D>(tree, invalid, "leaf below the root grid");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.LeafAnchors.back()[0] = tree.GetLatticeDimensions()[0];
    ExpectInvalid<D>(tree, invalid, "leaf beyond the root grid");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.AddLeaf(tree.LeafLevels[0], tree.LeafAnchors[0], tree.LeafMaterials[0]);
    ExpectInvalid<D>(tree, invalid, "duplicated leaf");
  }
  {
    stm::Spacetree<D> tree = valid;
    // A child of a coarse leaf, on top of it.
    tree.AddLeaf(tree.LeafLevels[coarse] + 1, tree.LeafAnchors[coarse], tree.LeafMaterials[coarse]);
    ExpectInvalid<D>(tree, invalid, "leaf inside another leaf");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.LeafLevels.pop_back();
    tree.LeafAnchors.pop_back();
    tree.LeafMaterials.pop_back();
    ExpectInvalid<D>(tree, invalid, "missing leaf (hole)");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.ClearLeaves();
    ExpectInvalid<D>(tree, invalid, "no leaves at all");
  }
}

TYPED_TEST(SpacetreeValidateTest, LeafArraysOfDifferentLengthsAreRejected)
{
  // The leaves are three parallel arrays; GetNumberOfLeaves() is the length of LeafLevels, and
  // every algorithm indexes the other two with it. A tree read from a file with arrays of
  // different lengths must be rejected (a shorter array would be read out of bounds; the
  // longer ones here keep this test free of undefined behaviour).
  constexpr int D = TypeParam::value;
  const stm::Spacetree<D> valid = MakeValidTree<D>(0);
  {
    stm::Spacetree<D> tree = valid;
    tree.LeafAnchors.push_back(tree.LeafAnchors.front());
    ExpectInvalid<D>(tree, stm::Status::Code::InvalidArgument, "one anchor too many");
  }
  {
    stm::Spacetree<D> tree = valid;
    tree.LeafMaterials.push_back(0);
    ExpectInvalid<D>(tree, stm::Status::Code::InvalidArgument, "one material too many");
  }
}

TYPED_TEST(SpacetreeValidateTest, HugeLatticeIsOutOfRange)
{
  constexpr int D = TypeParam::value;
  // MaxLevel 20, the largest allowed: root cells of edge 2^20. A lattice of more than 2^40 cells
  // must be refused as OutOfRange before anything is allocated: 2^41 cells (1D, 2D), 2^60 (one
  // 3D root), and lattices of exactly 2^64 cells (2^44 roots in 1D, 2^12 x 2^12 in 2D, 16 in 3D)
  // or 2^80 (one 4D root), whose cell count wraps around in 64-bit arithmetic.
  std::vector<stm::LatticeIndex<D>> rootGrids;
  if (D == 1)
  {
    rootGrids = { FirstExtents<D>({ std::int64_t{ 1 } << 21 }),
      FirstExtents<D>({ std::int64_t{ 1 } << 44 }) };
  }
  else if (D == 2)
  {
    rootGrids = { FirstExtents<D>({ 2, 1 }), FirstExtents<D>({ 1 << 12, 1 << 12 }) };
  }
  else if (D == 3)
  {
    rootGrids = { FirstExtents<D>({ 1, 1, 1 }), FirstExtents<D>({ 16, 1, 1 }) };
  }
  else
  {
    rootGrids = { UniformExtents<D>(1) };
  }
  for (const auto& rootGrid : rootGrids)
  {
    SCOPED_TRACE("root grid " + ToString<D>(rootGrid));
    stm::Spacetree<D> tree;
    tree.SetUniformRefinement(20);
    tree.RootGridDimensions = rootGrid;
    tree.ImageDimensions = UniformExtents<D>(1);
    tree.MaterialLabels.assign(1, 0); // "= { 0 }" draws a false GCC 12 -Wnonnull warning at -O3
    // No leaves: a validator that skipped the size check would still have to find the hole.
    ExpectInvalid<D>(tree, stm::Status::Code::OutOfRange, "huge lattice");
  }
}

} // namespace
