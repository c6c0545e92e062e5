// SPDX-License-Identifier: BSD-3-Clause
// Spacetrees in full generality: level tables from refinement patterns (2^d, 3^d, anisotropic,
// per level, automatic), given root cells, levels below the voxel, per-voxel minimum levels,
// local balance levels and grading. Every tree must mesh into a valid simplicial complex with the
// exact volumes and boundary of the voxel model, in every dimension, with every template.

#include "Balance/SpacetreeGrading.h"
#include "CoreTestUtilities.h"
#include "Spacetree/RefinementPlan.h"
#include "Spacetree/SpacetreeValidate.h"

namespace
{
using namespace stmtest;

template <class DimensionTag>
class RefinementPatternTest : public ::testing::Test
{
};
TYPED_TEST_SUITE(RefinementPatternTest, AllDimensions);

template <int D>
stm::SplitCounts<D> Counts(std::initializer_list<int> values)
{
  stm::SplitCounts<D> counts;
  auto value = values.begin();
  for (int axis = 0; axis < D; ++axis, ++value)
  {
    counts[axis] = *value;
  }
  return counts;
}

template <int D>
std::vector<stm::LatticeIndex<D>> Sizes(
  std::initializer_list<std::initializer_list<std::int64_t>> rows)
{
  std::vector<stm::LatticeIndex<D>> sizes;
  for (const auto& row : rows)
  {
    sizes.push_back(FirstExtents<D>(row));
  }
  return sizes;
}

template <int D>
stm::RefinementPlan<D> Plan(
  const stm::LatticeIndex<D>& dims, const stm::RefinementPlanOptions<D>& options)
{
  stm::RefinementPlan<D> plan;
  const stm::Status status = stm::PlanRefinement<D>(dims, options, plan);
  EXPECT_TRUE(status.IsOk()) << status.GetMessage();
  return plan;
}

TEST(RefinementPlan, AutomaticPatternMakesCubesOfHalfMillimetreInPlaneVoxels)
{
  // 0.5 x 0.5 x 1.0 mm voxels: 2x2x1 at the finest level, then 2x2x2.
  stm::RefinementPlanOptions<3> options;
  options.Spacing = { 0.5, 0.5, 1.0 };
  const auto plan = Plan<3>(UniformExtents<3>(100), options);
  EXPECT_EQ(plan.CellSizes,
    Sizes<3>({ { 16, 16, 8 }, { 8, 8, 4 }, { 4, 4, 2 }, { 2, 2, 1 }, { 1, 1, 1 } }));
  EXPECT_EQ(plan.VoxelLevel, 4);
  EXPECT_EQ(plan.VoxelSubdivision, UniformExtents<3>(1));
}

TEST(RefinementPlan, AutomaticPatternForClinicalAnisotropy)
{
  // 0.62 x 0.62 x 1.33 mm: doubling x and y gives 1.24 x 1.24 x 1.33, the closest to a cube.
  stm::RefinementPlanOptions<3> options;
  options.Spacing = { 0.62, 0.62, 1.33 };
  options.MaxCellSize = 8;
  const auto plan = Plan<3>(FirstExtents<3>({ 512, 512, 200 }), options);
  EXPECT_EQ(plan.CellSizes, Sizes<3>({ { 8, 8, 4 }, { 4, 4, 2 }, { 2, 2, 1 }, { 1, 1, 1 } }));
}

TEST(RefinementPlan, AutomaticPatternInTwoDimensionsSplitsTheShortAxisFirst)
{
  stm::RefinementPlanOptions<2> options;
  options.Spacing = { 1.0, 0.25 };
  options.MaxCellSize = 16;
  const auto plan = Plan<2>(FirstExtents<2>({ 40, 40 }), options);
  EXPECT_EQ(plan.CellSizes, Sizes<2>({ { 4, 16 }, { 2, 8 }, { 1, 4 }, { 1, 2 }, { 1, 1 } }));
}

TYPED_TEST(RefinementPatternTest, AutomaticPatternOnCubicVoxelsIsTwoToTheD)
{
  constexpr int D = TypeParam::value;
  stm::RefinementPlanOptions<D> options;
  options.MaxCellSize = 9;
  const auto plan = Plan<D>(UniformExtents<D>(30), options);
  EXPECT_EQ(plan.CellSizes, stm::Spacetree<D>::UniformCellSizes(3));
}

TEST(RefinementPlan, PatternListStartsAtTheFinestLevelAndRepeatsItsLastEntry)
{
  stm::RefinementPlanOptions<3> options;
  options.Pattern = { Counts<3>({ 2, 2, 1 }), Counts<3>({ 3, 3, 3 }) };
  options.MaxCellSize = 100;
  const auto plan = Plan<3>(UniformExtents<3>(200), options);
  EXPECT_EQ(plan.CellSizes,
    Sizes<3>({ { 54, 54, 27 }, { 18, 18, 9 }, { 6, 6, 3 }, { 2, 2, 1 }, { 1, 1, 1 } }));
}

TEST(RefinementPlan, GivenRootCellSizeIsReachedAndAxesStopThere)
{
  stm::RefinementPlanOptions<3> options;
  options.Spacing = { 1.0, 1.0, 2.0 };
  options.RootCellSize = FirstExtents<3>({ 8, 8, 4 });
  EXPECT_EQ(Plan<3>(UniformExtents<3>(50), options).CellSizes,
    Sizes<3>({ { 8, 8, 4 }, { 4, 4, 2 }, { 2, 2, 1 }, { 1, 1, 1 } }));
  options.Pattern = { Counts<3>({ 2, 2, 2 }) };
  EXPECT_EQ(Plan<3>(UniformExtents<3>(50), options).CellSizes,
    Sizes<3>({ { 8, 8, 4 }, { 4, 4, 4 }, { 2, 2, 2 }, { 1, 1, 1 } }));
  // The image need not be divisible by the root cells: padding covers the rest.
  options.RootCellSize = FirstExtents<3>({ 3, 9, 9 });
  options.Pattern = { Counts<3>({ 3, 3, 3 }) };
  EXPECT_EQ(Plan<3>(FirstExtents<3>({ 10, 11, 12 }), options).CellSizes,
    Sizes<3>({ { 3, 9, 9 }, { 3, 3, 3 }, { 1, 1, 1 } }));
}

TEST(RefinementPlan, FinestSizeAddsLevelsBelowTheVoxel)
{
  stm::RefinementPlanOptions<3> options;
  options.MaxCellSize = 2;
  options.FinestSize = 0.5;
  auto plan = Plan<3>(UniformExtents<3>(10), options);
  EXPECT_EQ(plan.VoxelSubdivision, UniformExtents<3>(2));
  EXPECT_EQ(plan.VoxelLevel, 1);
  EXPECT_EQ(plan.CellSizes, Sizes<3>({ { 4, 4, 4 }, { 2, 2, 2 }, { 1, 1, 1 } }));
  // 1 x 1 x 2 mm voxels to 0.5 mm: the long axis is halved alone first, then all three.
  options.Spacing = { 1.0, 1.0, 2.0 };
  options.MaxCellSize = 1;
  plan = Plan<3>(UniformExtents<3>(10), options);
  EXPECT_EQ(plan.VoxelSubdivision, FirstExtents<3>({ 2, 2, 4 }));
  EXPECT_EQ(plan.CellSizes, Sizes<3>({ { 2, 2, 4 }, { 2, 2, 2 }, { 1, 1, 1 } }));
  const std::vector<double> edges = plan.LargestEdges(options.Spacing);
  EXPECT_EQ(edges, (std::vector<double>{ 2.0, 1.0, 0.5 }));
  EXPECT_EQ(plan.CoarsestLevelWithin(1.0, edges), 1);
  EXPECT_EQ(plan.CoarsestLevelWithin(0.7, edges), 2);
  EXPECT_EQ(plan.CoarsestLevelWithin(100, edges), 0);
}

TEST(RefinementPlan, BadPatternsAndSizesAreRejectedWithAMessage)
{
  const stm::LatticeIndex<3> dims = UniformExtents<3>(20);
  auto expectInvalid = [&](const stm::RefinementPlanOptions<3>& options, const char* what)
  {
    SCOPED_TRACE(what);
    stm::RefinementPlan<3> plan;
    const stm::Status status = stm::PlanRefinement<3>(dims, options, plan);
    EXPECT_EQ(status.GetCode(), stm::Status::Code::InvalidArgument) << status.GetMessage();
    EXPECT_FALSE(status.GetMessage().empty());
  };
  stm::RefinementPlanOptions<3> options;
  options.Pattern = { Counts<3>({ 2, 0, 2 }) };
  expectInvalid(options, "zero split count");
  options.Pattern = { Counts<3>({ 2, -2, 2 }) };
  expectInvalid(options, "negative split count");
  options.Pattern = { Counts<3>({ 2, 2, 2 }), Counts<3>({ 1, 1, 1 }) };
  expectInvalid(options, "a pattern entry of only ones");
  options.Pattern = { Counts<3>({ 9, 2, 2 }) };
  expectInvalid(options, "split count above the maximum");
  options.Pattern = {};
  options.RootCellSize = FirstExtents<3>({ 32, 8, 8 });
  expectInvalid(options, "root cell size larger than the image");
  options.RootCellSize = FirstExtents<3>({ 8, 8, 0 });
  expectInvalid(options, "root cell size of zero on one axis");
  options.RootCellSize = FirstExtents<3>({ 8, 8, 8 });
  options.Pattern = { Counts<3>({ 3, 3, 3 }) };
  expectInvalid(options, "root cell size the pattern cannot reach");
  options.Pattern = { Counts<3>({ 2, 2, 1 }) };
  expectInvalid(options, "a pattern that never splits an axis the root needs");
  options = stm::RefinementPlanOptions<3>();
  options.Spacing = { 1.0, 0.0, 1.0 };
  expectInvalid(options, "zero spacing");
  options = stm::RefinementPlanOptions<3>();
  options.FinestSize = -1;
  expectInvalid(options, "negative finest size");
  options = stm::RefinementPlanOptions<3>();
  options.MaxCellSize = 0;
  expectInvalid(options, "MaxCellSize 0");
}

/// Patterns exercised in every dimension: 2^D, 3^D, one axis only at the finest level then 2^D,
/// all but the last axis at the finest level (2x2x1), and 3 and 2 alternating per level.
template <int D>
std::vector<std::pair<std::string, std::vector<stm::SplitCounts<D>>>> TestPatterns()
{
  std::vector<std::pair<std::string, std::vector<stm::SplitCounts<D>>>> patterns;
  stm::SplitCounts<D> two, three, firstOnly, allButLast, mixed;
  two.fill(2);
  three.fill(3);
  firstOnly.fill(1);
  firstOnly[0] = 2;
  allButLast.fill(2);
  mixed.fill(2);
  mixed[0] = 3;
  if (D > 1)
  {
    allButLast[D - 1] = 1;
  }
  patterns.push_back({ "2^D", { two } });
  patterns.push_back({ "3^D", { three } });
  patterns.push_back({ "first axis, then 2^D", { firstOnly, two } });
  patterns.push_back({ "2x2x1 then 2^D", { allButLast, two } });
  patterns.push_back({ "3x2x2 and 2^D alternating", { mixed, two, mixed, two } });
  if (D > 2)
  {
    stm::SplitCounts<D> lastOnly;
    lastOnly.fill(1);
    lastOnly[D - 1] = 2;
    patterns.push_back({ "1x1x2 then 2x2x1 then 2^D", { lastOnly, allButLast, two } });
  }
  return patterns;
}

template <int D>
LabelImage<D> MakePatternImage(unsigned seed)
{
  const stm::LatticeIndex<D> dims =
    D == 4 ? FirstExtents<D>({ 9, 7, 6, 5 }) : FirstExtents<D>({ 41, 23, 14, 1 });
  return MakeRandomImage<D>(dims, seed, 2, 5, 25);
}

TYPED_TEST(RefinementPatternTest, EveryPatternGivesValidConformingMeshesAtEveryBalanceLevel)
{
  constexpr int D = TypeParam::value;
  for (const auto& [name, pattern] : TestPatterns<D>())
  {
    for (unsigned seed : { 5u, 6u })
    {
      const LabelImage<D> image = MakePatternImage<D>(seed);
      stm::RefinementPlanOptions<D> plan;
      plan.Pattern = pattern;
      plan.MaxCellSize = 27;
      for (int L : { 0, 1, 2, 3 })
      {
        stm::SequentialExecutor executor;
        stm::Spacetree<D> tree;
        ASSERT_TRUE(BuildTreeWithPlan<D>(image, plan, L, false, executor, tree).IsOk());
        ASSERT_TRUE(stm::ValidateSpacetree<D>(tree).IsOk());
        EXPECT_EQ(CountMaterialMismatches<D>(tree, image), 0);
        if (L > 0)
        {
          EXPECT_LE(stm::MaximumLevelDifference<D>(tree, false, executor), L);
        }
        for (stm::CellTemplate cellTemplate : TemplatesOf<D>())
        {
          SCOPED_TRACE(name + ", seed " + std::to_string(seed) + ", L " + std::to_string(L) + ", " +
            TemplateName(cellTemplate));
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

TYPED_TEST(RefinementPatternTest, AnisotropicVoxelsWithTheAutomaticPatternMeshValidly)
{
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = MakePatternImage<D>(7);
  stm::RefinementPlanOptions<D> plan;
  for (int axis = 0; axis < D; ++axis)
  {
    plan.Spacing[axis] = axis == D - 1 ? 2.0 : 1.0;
  }
  for (int L : { 1, 2 })
  {
    stm::SequentialExecutor executor;
    stm::Spacetree<D> tree;
    ASSERT_TRUE(BuildTreeWithPlan<D>(image, plan, L, true, executor, tree).IsOk());
    if (D > 1)
    {
      // The finest level splits all but the last axis.
      const stm::LatticeIndex<D> finestSplits = tree.GetSplitCounts(tree.MaxLevel - 1);
      EXPECT_EQ(finestSplits[D - 1], 1);
      EXPECT_EQ(finestSplits[0], 2);
    }
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

TYPED_TEST(RefinementPatternTest, ThreePowDUniformImageUsesOneTemplatePerCell)
{
  constexpr int D = TypeParam::value;
  LabelImage<D> image(UniformExtents<D>(9));
  std::fill(image.GetValues().begin(), image.GetValues().end(), stm::MaterialIndex{ 1 });
  stm::RefinementPlanOptions<D> plan;
  plan.Pattern = UniformPattern<D>(3);
  plan.MaxCellSize = 9;
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  ASSERT_TRUE(BuildTreeWithPlan<D>(image, plan, 0, false, executor, tree).IsOk());
  ASSERT_EQ(tree.GetNumberOfLeaves(), 1);
  SimplicialMesh<D> mesh;
  ASSERT_TRUE(
    TessellateTree<D>(tree, TessellationOptions(stm::CellTemplate::Kuhn), executor, mesh).IsOk());
  EXPECT_EQ(mesh.GetNumberOfSimplices(), stm::Factorial(D));
  EXPECT_EQ(mesh.GetNumberOfPoints(), stm::IntPow(2, D));
}

TEST(RefinementPattern, CheckerboardCellsNextToAnUnsplitAxisLevelUseTheMidpointRule)
{
  // With 1x1x2 between two levels, square faces orthogonal to z are shared by cells of both
  // levels, and the cube template of the coarser level could disagree with them: those cells
  // take the midpoint rule, so a uniform body gets cell centres, and stays valid.
  LabelImage<3> image(FirstExtents<3>({ 4, 4, 8 }));
  std::fill(image.GetValues().begin(), image.GetValues().end(), stm::MaterialIndex{ 1 });
  image.Set(FirstExtents<3>({ 0, 0, 0 }), 2);
  stm::RefinementPlanOptions<3> plan;
  plan.Pattern = { Counts<3>({ 2, 2, 2 }), Counts<3>({ 1, 1, 2 }), Counts<3>({ 2, 2, 2 }) };
  plan.RootCellSize = FirstExtents<3>({ 4, 4, 8 });
  stm::SequentialExecutor executor;
  stm::Spacetree<3> tree;
  ASSERT_TRUE(BuildTreeWithPlan<3>(image, plan, 1, false, executor, tree).IsOk());
  SimplicialMesh<3> kuhn, checkerboard;
  ASSERT_TRUE(
    TessellateTree<3>(tree, TessellationOptions(stm::CellTemplate::Kuhn), executor, kuhn).IsOk());
  ASSERT_TRUE(TessellateTree<3>(
    tree, TessellationOptions(stm::CellTemplate::Checkerboard), executor, checkerboard)
                .IsOk());
  ExpectMeshMatchesVoxelModel<3>(kuhn, tree, image);
  ExpectMeshMatchesVoxelModel<3>(checkerboard, tree, image);
  // The same faces are split and the same face centres inserted with both templates; the
  // checkerboard mesh has the centres of the coarser cells on top.
  EXPECT_GT(checkerboard.GetNumberOfPoints(), kuhn.GetNumberOfPoints());
}

TYPED_TEST(RefinementPatternTest, MinimumLevelsRefineExactlyWhereAsked)
{
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = MakePatternImage<D>(8);
  stm::RefinementPlanOptions<D> options;
  options.MaxCellSize = 8;
  options.FinestSize = 0.5; // one level below the voxel
  stm::RefinementPlan<D> plan;
  ASSERT_TRUE(stm::PlanRefinement<D>(image.GetDimensions(), options, plan).IsOk());
  ASSERT_EQ(plan.VoxelLevel + 1, plan.GetMaxLevel());
  // Minimum levels: the finest level in the lower half of axis 0, level 1 elsewhere.
  std::vector<std::uint8_t> minimum(
    static_cast<std::size_t>(stm::NumberOfLatticeCells<D>(image.GetDimensions())));
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      minimum[stm::LinearIndex<D>(voxel, image.GetDimensions())] =
        static_cast<std::uint8_t>(2 * voxel[0] < image.GetDimensions()[0] ? plan.GetMaxLevel() : 1);
    });
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  ASSERT_TRUE(stm::SpacetreeBuilder<D>()
                .Build(image.View(), MaterialLabels(image.LargestMaterial() + 1), plan,
                  minimum.data(), tree, executor)
                .IsOk());
  ASSERT_TRUE(stm::ValidateSpacetree<D>(tree).IsOk());
  EXPECT_EQ(CountMaterialMismatches<D>(tree, image), 0);
  std::int64_t tooCoarse = 0, halfVoxelLeaves = 0, halfVoxelOutside = 0;
  for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
  {
    const auto& anchor = tree.LeafAnchors[leaf];
    const int level = tree.LeafLevels[leaf];
    stm::LatticeIndex<D> voxel;
    bool inImage = true;
    for (int axis = 0; axis < D; ++axis)
    {
      voxel[axis] = anchor[axis] / tree.VoxelSubdivision[axis];
      inImage = inImage && voxel[axis] < image.GetDimensions()[axis];
    }
    if (inImage)
    {
      tooCoarse += level < minimum[stm::LinearIndex<D>(voxel, image.GetDimensions())];
    }
    if (level == tree.MaxLevel)
    {
      ++halfVoxelLeaves;
      halfVoxelOutside += !(inImage && 2 * voxel[0] < image.GetDimensions()[0]);
    }
  }
  EXPECT_EQ(tooCoarse, 0);
  EXPECT_EQ(halfVoxelOutside, 0) << "no refinement below the voxel outside the asked region";
  const std::int64_t lowerHalf = (image.GetDimensions()[0] + 1) / 2;
  EXPECT_EQ(halfVoxelLeaves,
    lowerHalf * stm::NumberOfLatticeCells<D>(image.GetDimensions()) / image.GetDimensions()[0] *
      stm::IntPow(2, D));

  stm::SpacetreeBalanceOptions balance;
  ASSERT_TRUE(stm::SpacetreeBalancer<D>().Balance(tree, balance, executor).IsOk());
  for (stm::CellTemplate cellTemplate : TemplatesOf<D>())
  {
    SCOPED_TRACE(TemplateName(cellTemplate));
    SimplicialMesh<D> mesh;
    ASSERT_TRUE(TessellateTree<D>(tree, TessellationOptions(cellTemplate), executor, mesh).IsOk());
    ExpectMeshMatchesVoxelModel<D>(mesh, tree, image);
  }
}

TYPED_TEST(RefinementPatternTest, LocalBalanceLevelsHoldAndOnlyTightenWhereAsked)
{
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = MakePatternImage<D>(9);
  stm::RefinementPlanOptions<D> plan;
  plan.MaxCellSize = 16;
  stm::SequentialExecutor executor;
  stm::Spacetree<D> unbalanced;
  ASSERT_TRUE(BuildTreeWithPlan<D>(image, plan, 0, false, executor, unbalanced).IsOk());

  auto balanced = [&](const stm::SpacetreeBalanceOptions& options)
  {
    stm::Spacetree<D> tree = unbalanced;
    const stm::Status status = stm::SpacetreeBalancer<D>().Balance(tree, options, executor);
    EXPECT_TRUE(status.IsOk()) << status.GetMessage();
    EXPECT_EQ(stm::CountBalanceViolations<D>(tree, options, executor), 0);
    EXPECT_TRUE(stm::ValidateSpacetree<D>(tree).IsOk());
    return tree;
  };
  stm::SpacetreeBalanceOptions loose, tight, perMaterial, region;
  loose.BalanceLevel = 3;
  tight.BalanceLevel = 1;
  perMaterial.BalanceLevel = 3;
  perMaterial.MaterialBalanceLevels = { 0, 1 }; // material 1 at L = 1, the rest at 3
  region.BalanceLevel = 3;
  // L = 1 in the lower half of axis 0 (lattice units).
  const double half = 0.5 * unbalanced.GetLatticeDimensions()[0];
  region.RegionBalanceLevel = [half](const double* centre) { return centre[0] < half ? 1 : 0; };

  const auto looseTree = balanced(loose);
  const auto tightTree = balanced(tight);
  const auto materialTree = balanced(perMaterial);
  const auto regionTree = balanced(region);
  if (D == 1)
  {
    return; // too few levels in 1D for the local levels to differ from the global ones
  }
  EXPECT_LT(looseTree.GetNumberOfLeaves(), materialTree.GetNumberOfLeaves());
  EXPECT_LT(materialTree.GetNumberOfLeaves(), tightTree.GetNumberOfLeaves());
  EXPECT_LT(looseTree.GetNumberOfLeaves(), regionTree.GetNumberOfLeaves());
  if (D < 4) // the small 4D image is balanced at L = 1 throughout by its lower half alone
  {
    EXPECT_LT(regionTree.GetNumberOfLeaves(), tightTree.GetNumberOfLeaves());
  }
  // The looser global level is violated by the tight trees only where allowed: material 1 and
  // the region satisfy L = 1.
  EXPECT_GT(stm::CountBalanceViolations<D>(looseTree, perMaterial, executor), 0);
  EXPECT_GT(stm::CountBalanceViolations<D>(looseTree, region, executor), 0);
}

TYPED_TEST(RefinementPatternTest, GradingBoundsTheSizeRatioWithinEachLeafsOwnSize)
{
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = MakePatternImage<D>(10);
  stm::RefinementPlanOptions<D> plan;
  plan.MaxCellSize = 16;
  std::array<double, D> spacing;
  spacing.fill(1.0);
  spacing[0] = 0.5;
  plan.Spacing = spacing;
  for (double grading : { 2.0, 4.0 })
  {
    SCOPED_TRACE("grading " + std::to_string(grading));
    stm::SequentialExecutor executor;
    stm::Spacetree<D> tree;
    ASSERT_TRUE(BuildTreeWithPlan<D>(image, plan, 0, false, executor, tree).IsOk());
    const std::int64_t before = tree.GetNumberOfLeaves();
    const bool gradedBefore = stm::IsGraded<D>(tree, grading, spacing);
    if (grading == 2.0)
    {
      EXPECT_FALSE(gradedBefore);
    }
    ASSERT_TRUE(stm::SpacetreeGrader<D>().Grade(tree, grading, spacing, executor).IsOk());
    EXPECT_TRUE(stm::IsGraded<D>(tree, grading, spacing));
    // Grading splits exactly when the tree was not graded.
    EXPECT_EQ(tree.GetNumberOfLeaves() > before, !gradedBefore);
    EXPECT_TRUE(stm::ValidateSpacetree<D>(tree).IsOk());
    EXPECT_EQ(CountMaterialMismatches<D>(tree, image), 0);
    // Grading again changes nothing.
    const std::int64_t graded = tree.GetNumberOfLeaves();
    ASSERT_TRUE(stm::SpacetreeGrader<D>().Grade(tree, grading, spacing, executor).IsOk());
    EXPECT_EQ(tree.GetNumberOfLeaves(), graded);
  }
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  ASSERT_TRUE(BuildTreeWithPlan<D>(image, plan, 0, false, executor, tree).IsOk());
  EXPECT_FALSE(stm::SpacetreeGrader<D>().Grade(tree, 1.0, spacing, executor).IsOk());
}

} // namespace
