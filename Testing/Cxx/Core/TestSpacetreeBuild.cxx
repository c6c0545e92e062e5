// SPDX-License-Identifier: BSD-3-Clause
// SpacetreeBuilder: the root grid, the leaves (a partition of the root grid into homogeneous
// cubes, each as coarse as the image allows, in canonical order) and the error statuses.

#include "CoreTestUtilities.h"

namespace
{
using namespace stmtest;

template <class DimensionTag>
class SpacetreeBuildTest : public ::testing::Test
{
};
TYPED_TEST_SUITE(SpacetreeBuildTest, AllDimensions);

/// Non-power-of-two extents, so that the root grid needs padding on every axis.
template <int D>
stm::LatticeIndex<D> AwkwardExtents()
{
  return FirstExtents<D>({ 13, 7, 5, 3 });
}

/// Images for the generic tests: small in 4D, where 8^4 voxels is already 4096 cells.
template <int D>
LabelImage<D> MakeTestImage(unsigned seed)
{
  const stm::LatticeIndex<D> dims =
    D == 4 ? FirstExtents<D>({ 8, 7, 6, 5 }) : FirstExtents<D>({ 45, 29, 19, 1 });
  return MakeRandomImage<D>(dims, seed, 3, 4, 20);
}

/// The reference spacetree, written from the definition: a cube is a leaf when every voxel in
/// it (padding included, as background) has the same material; otherwise its 2^D children
/// follow in linear order. Roots are visited in linear order.
template <int D>
void ReferenceRefine(const LabelImage<D>& image, const stm::LatticeIndex<D>& anchor, int level,
  int maxLevel, stm::Spacetree<D>& out)
{
  const std::int64_t size = std::int64_t{ 1 } << (maxLevel - level);
  stm::LatticeIndex<D> upper;
  for (int axis = 0; axis < D; ++axis)
  {
    upper[axis] = anchor[axis] + size;
  }
  const stm::MaterialIndex first = image.At(anchor);
  bool uniform = true;
  ForEachIndexInBox<D>(anchor, upper,
    [&](const stm::LatticeIndex<D>& voxel) { uniform = uniform && image.At(voxel) == first; });
  if (uniform)
  {
    out.AddLeaf(level, anchor, first);
    return;
  }
  for (int child = 0; child < (1 << D); ++child)
  {
    stm::LatticeIndex<D> childAnchor = anchor;
    for (int axis = 0; axis < D; ++axis)
    {
      childAnchor[axis] += ((child >> axis) & 1) * size / 2;
    }
    ReferenceRefine<D>(image, childAnchor, level + 1, maxLevel, out);
  }
}

template <int D>
stm::Spacetree<D> ReferenceTree(const LabelImage<D>& image, const stm::Spacetree<D>& built)
{
  stm::Spacetree<D> reference;
  ForEachIndex<D>(built.RootGridDimensions,
    [&](const stm::LatticeIndex<D>& root)
    {
      stm::LatticeIndex<D> anchor;
      for (int axis = 0; axis < D; ++axis)
      {
        anchor[axis] = root[axis] * built.GetRootCellSize()[axis];
      }
      ReferenceRefine<D>(image, anchor, 0, built.MaxLevel, reference);
    });
  return reference;
}

/// Expected root edge, from the definition: the largest power of two not above MaxCellSize,
/// but no larger than the smallest power of two that covers the largest image extent.
std::int64_t ExpectedRootSize(std::int64_t maxCellSize, std::int64_t largestExtent)
{
  std::int64_t allowed = 1;
  while (allowed * 2 <= maxCellSize)
  {
    allowed *= 2;
  }
  std::int64_t needed = 1;
  while (needed < largestExtent)
  {
    needed *= 2;
  }
  return std::min(allowed, needed);
}

TYPED_TEST(SpacetreeBuildTest, RootGridIsTheCoarsestPowerOfTwoGridCoveringTheImage)
{
  constexpr int D = TypeParam::value;
  const stm::LatticeIndex<D> dims = AwkwardExtents<D>();
  const LabelImage<D> image = MakeRandomImage<D>(dims, 11, 2, 3, 50);
  ASSERT_GT(image.CountBodyVoxels(), 0);
  const std::vector<std::int64_t> labels = MaterialLabels(image.LargestMaterial() + 1);
  for (std::int64_t maxCellSize : { 1, 2, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 1000, 1 << 30 })
  {
    SCOPED_TRACE("MaxCellSize " + std::to_string(maxCellSize));
    stm::SequentialExecutor executor;
    stm::Spacetree<D> tree;
    stm::RefinementPlanOptions<D> options;
    options.MaxCellSize = maxCellSize;
    const stm::Status status =
      stm::SpacetreeBuilder<D>().Build(image.View(), labels, options, tree, executor);
    ASSERT_TRUE(status.IsOk()) << status.GetMessage();

    const std::int64_t rootSize = ExpectedRootSize(maxCellSize, 13);
    EXPECT_EQ(tree.GetRootCellSize(), UniformExtents<D>(rootSize));
    EXPECT_EQ(std::int64_t{ 1 } << tree.MaxLevel, rootSize);
    for (int axis = 0; axis < D; ++axis)
    {
      EXPECT_EQ(tree.RootGridDimensions[axis], (dims[axis] + rootSize - 1) / rootSize)
        << "axis " << axis;
      EXPECT_EQ(tree.GetLatticeDimensions()[axis], tree.RootGridDimensions[axis] * rootSize);
    }
    EXPECT_EQ(tree.ImageDimensions, dims);
    EXPECT_EQ(tree.MaterialLabels, labels);
    EXPECT_EQ(tree.BalanceLevel, -1) << "a freshly built tree is not known to be balanced";
  }
}

TEST(SpacetreeBuild, ExplicitRootGridsOfA13x7x5Image)
{
  constexpr int D = 3;
  LabelImage<D> image(FirstExtents<D>({ 13, 7, 5 }));
  image.GetValues()[0] = 1;
  const std::vector<std::pair<std::int64_t, stm::LatticeIndex<D>>> cases = {
    { 16, FirstExtents<D>({ 1, 1, 1 }) }, { 8, FirstExtents<D>({ 2, 1, 1 }) },
    { 6, FirstExtents<D>({ 4, 2, 2 }) }, { 4, FirstExtents<D>({ 4, 2, 2 }) },
    { 2, FirstExtents<D>({ 7, 4, 3 }) }, { 1, FirstExtents<D>({ 13, 7, 5 }) }
  };
  for (const auto& [maxCellSize, rootGrid] : cases)
  {
    SCOPED_TRACE("MaxCellSize " + std::to_string(maxCellSize));
    stm::SequentialExecutor executor;
    stm::Spacetree<D> tree;
    ASSERT_TRUE(BuildTree<D>(image, maxCellSize, 0, false, executor, tree).IsOk());
    EXPECT_EQ(tree.RootGridDimensions, rootGrid);
  }
}

TYPED_TEST(SpacetreeBuildTest, LeavesPartitionTheRootGridAndMatchTheImageVoxelByVoxel)
{
  constexpr int D = TypeParam::value;
  for (unsigned seed : { 1u, 2u, 3u })
  {
    const LabelImage<D> image = MakeTestImage<D>(seed);
    for (std::int64_t maxCellSize : { 4, 16 })
    {
      SCOPED_TRACE("seed " + std::to_string(seed) + ", MaxCellSize " + std::to_string(maxCellSize));
      stm::SequentialExecutor executor;
      stm::Spacetree<D> tree;
      ASSERT_TRUE(BuildTree<D>(image, maxCellSize, 0, false, executor, tree).IsOk());
      ASSERT_EQ(tree.LeafAnchors.size(), tree.LeafLevels.size());
      ASSERT_EQ(tree.LeafMaterials.size(), tree.LeafLevels.size());

      std::int64_t volume = 0, misaligned = 0, badLevels = 0;
      for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
      {
        badLevels += tree.LeafLevels[leaf] > tree.MaxLevel;
        volume += LeafVolume<D>(tree, leaf);
        for (int axis = 0; axis < D; ++axis)
        {
          misaligned +=
            tree.LeafAnchors[leaf][axis] % tree.GetCellSize(tree.LeafLevels[leaf])[axis] != 0;
        }
      }
      EXPECT_EQ(badLevels, 0);
      EXPECT_EQ(misaligned, 0) << "a leaf anchor is not a multiple of its edge";
      EXPECT_EQ(volume, LatticeVolume<D>(tree)) << "leaf volumes do not add up to the root grid";

      std::vector<std::int64_t> cellToLeaf;
      EXPECT_EQ(MapCellsToLeaves<D>(tree, cellToLeaf), 0) << "leaves overlap or leave the grid";
      EXPECT_EQ(std::count(cellToLeaf.begin(), cellToLeaf.end(), -1), 0) << "uncovered cells";
      EXPECT_EQ(CountMaterialMismatches<D>(tree, image), 0)
        << "a leaf is not homogeneous, or padding is not background";
    }
  }
}

TYPED_TEST(SpacetreeBuildTest, LeavesAreTheCoarsestHomogeneousCubesInCanonicalOrder)
{
  constexpr int D = TypeParam::value;
  for (unsigned seed : { 4u, 5u })
  {
    const LabelImage<D> image = MakeTestImage<D>(seed);
    for (std::int64_t maxCellSize : { 2, 8, 64 })
    {
      SCOPED_TRACE("seed " + std::to_string(seed) + ", MaxCellSize " + std::to_string(maxCellSize));
      stm::SequentialExecutor executor;
      stm::Spacetree<D> tree;
      ASSERT_TRUE(BuildTree<D>(image, maxCellSize, 0, false, executor, tree).IsOk());
      const stm::Spacetree<D> reference = ReferenceTree<D>(image, tree);
      EXPECT_EQ(tree.LeafLevels, reference.LeafLevels);
      EXPECT_EQ(tree.LeafAnchors, reference.LeafAnchors);
      EXPECT_EQ(tree.LeafMaterials, reference.LeafMaterials);
    }
  }
}

TYPED_TEST(SpacetreeBuildTest, InterfaceAtAnOddVoxelPlaneIsResolvedByUnitLeaves)
{
  constexpr int D = TypeParam::value;
  // Material 1 for x0 < 5, material 2 beyond, in a 16^D image with one 16^D root. Along x0 the
  // root splits like the 1D tree [0,4) [4,5) [5,6) [6,8) [8,16) (levels 2 4 4 3 1), and every
  // other axis is split alongside, so a 1D leaf of level l stands for 2^((D-1) l) leaves.
  LabelImage<D> image(UniformExtents<D>(16));
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel) { image.Set(voxel, voxel[0] < 5 ? 1 : 2); });
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  ASSERT_TRUE(BuildTree<D>(image, 16, 0, false, executor, tree).IsOk());
  ASSERT_EQ(tree.MaxLevel, 4);
  std::int64_t expectedLeaves = 0;
  for (int level : { 2, 4, 4, 3, 1 })
  {
    expectedLeaves += std::int64_t{ 1 } << ((D - 1) * level);
  }
  EXPECT_EQ(tree.GetNumberOfLeaves(), expectedLeaves);

  std::int64_t coarseNextToInterface = 0, unitLeavesAwayFromIt = 0;
  for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
  {
    const std::int64_t x = tree.LeafAnchors[leaf][0];
    const bool touchesInterface = x == 4 || x == 5;
    const bool unit = tree.GetCellSize(tree.LeafLevels[leaf])[0] == 1;
    coarseNextToInterface += touchesInterface && !unit;
    unitLeavesAwayFromIt += !touchesInterface && unit;
  }
  EXPECT_EQ(coarseNextToInterface, 0);
  EXPECT_EQ(unitLeavesAwayFromIt, 0) << "refinement away from the interface";

  // The same interface moved to x0 = 8 falls on a root child boundary: 2^D leaves of edge 8.
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel) { image.Set(voxel, voxel[0] < 8 ? 1 : 2); });
  ASSERT_TRUE(BuildTree<D>(image, 16, 0, false, executor, tree).IsOk());
  EXPECT_EQ(tree.GetNumberOfLeaves(), 1 << D);
  EXPECT_TRUE(std::all_of(
    tree.LeafLevels.begin(), tree.LeafLevels.end(), [](std::uint8_t level) { return level == 1; }));
}

TYPED_TEST(SpacetreeBuildTest, VoxelCheckerboardGivesOnlyUnitLeaves)
{
  constexpr int D = TypeParam::value;
  // Every voxel face is an interface: no cube larger than a voxel is homogeneous.
  LabelImage<D> image(UniformExtents<D>(8));
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      std::int64_t sum = 0;
      for (int axis = 0; axis < D; ++axis)
      {
        sum += voxel[axis];
      }
      image.Set(voxel, sum % 2 == 0 ? 1 : 2);
    });
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  ASSERT_TRUE(BuildTree<D>(image, 8, 0, false, executor, tree).IsOk());
  EXPECT_EQ(tree.GetNumberOfLeaves(), stm::IntPow(8, D));
  EXPECT_TRUE(std::all_of(tree.LeafLevels.begin(), tree.LeafLevels.end(),
    [&](std::uint8_t level) { return level == tree.MaxLevel; }));
  EXPECT_EQ(CountMaterialMismatches<D>(tree, image), 0);
}

TYPED_TEST(SpacetreeBuildTest, PaddingAroundAFullImageIsBackground)
{
  constexpr int D = TypeParam::value;
  LabelImage<D> image(AwkwardExtents<D>());
  std::fill(image.GetValues().begin(), image.GetValues().end(), 1);
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  ASSERT_TRUE(BuildTree<D>(image, 16, 0, false, executor, tree).IsOk());
  std::int64_t bodyVolume = 0;
  for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
  {
    bodyVolume += tree.LeafMaterials[leaf] == 1 ? LeafVolume<D>(tree, leaf) : 0;
  }
  EXPECT_EQ(bodyVolume, stm::NumberOfLatticeCells<D>(image.GetDimensions()));
  EXPECT_EQ(CountMaterialMismatches<D>(tree, image), 0);
}

TYPED_TEST(SpacetreeBuildTest, InvalidInputsAreReportedAsInvalidArgument)
{
  constexpr int D = TypeParam::value;
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  const std::vector<std::int64_t> labels = MaterialLabels(2);
  stm::RefinementPlanOptions<D> options;
  auto expectInvalid = [&](const stm::MaterialImage<D>& view, const std::vector<std::int64_t>& l,
                         const stm::RefinementPlanOptions<D>& o, const char* what)
  {
    SCOPED_TRACE(what);
    const stm::Status status = stm::SpacetreeBuilder<D>().Build(view, l, o, tree, executor);
    EXPECT_FALSE(status.IsOk());
    EXPECT_EQ(status.GetCode(), stm::Status::Code::InvalidArgument);
    EXPECT_FALSE(status.GetMessage().empty());
  };

  LabelImage<D> single(UniformExtents<D>(1));
  single.GetValues()[0] = 1;
  expectInvalid(single.View(), labels, options, "one-voxel image");

  LabelImage<D> image(AwkwardExtents<D>());
  image.GetValues()[3] = 1;
  stm::RefinementPlanOptions<D> zero;
  zero.MaxCellSize = 0;
  expectInvalid(image.View(), labels, zero, "MaxCellSize 0");
  stm::RefinementPlanOptions<D> negative;
  negative.MaxCellSize = -4;
  expectInvalid(image.View(), labels, negative, "negative MaxCellSize");

  stm::MaterialImage<D> noValues = image.View();
  noValues.Values = nullptr;
  expectInvalid(noValues, labels, options, "null values");

  stm::MaterialImage<D> flat = image.View();
  flat.Dimensions[D - 1] = 0;
  expectInvalid(flat, labels, options, "zero extent");

  expectInvalid(image.View(), {}, options, "empty material table");

  LabelImage<D> empty(AwkwardExtents<D>());
  expectInvalid(empty.View(), labels, options, "empty body");
}

TYPED_TEST(SpacetreeBuildTest, AbortedExecutorReturnsAborted)
{
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = MakeTestImage<D>(6);
  stm::SequentialExecutor executor;
  executor.RequestAbort();
  stm::Spacetree<D> tree;
  const stm::Status status = BuildTree<D>(image, 4, 0, false, executor, tree);
  EXPECT_EQ(status.GetCode(), stm::Status::Code::Aborted);
  EXPECT_FALSE(status.GetMessage().empty());
}

} // namespace
