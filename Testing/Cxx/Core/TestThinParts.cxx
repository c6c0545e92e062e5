// SPDX-License-Identifier: BSD-3-Clause
// Thin parts in 2D and 3D: single voxels, one-voxel plates (flat, so every corner is a tie) and
// one-voxel lines are thin, blocks three voxels wide are not, the body-only mode joins the
// body's labels; and refining the thin voxels to half their size makes the multi-material cut keep
// every face-connected component of a speckled random image, which the cut at voxel size loses.

#include "CoreTestUtilities.h"

#include "Cut/MultiMaterialCut.h"
#include "Spacetree/ThinParts.h"

#include <gtest/gtest.h>

#include <functional>
#include <map>
#include <numeric>
#include <set>
#include <vector>

namespace
{
using namespace stmtest;

template <int D>
std::vector<std::uint8_t> Thin(const LabelImage<D>& image, bool bodyOnly)
{
  stm::SequentialExecutor executor;
  std::vector<std::uint8_t> thin;
  EXPECT_TRUE(stm::ThinPartVoxels<D>(image.View(), bodyOnly, thin, executor).IsOk());
  return thin;
}

template <int D>
std::int64_t Count(const std::vector<std::uint8_t>& flags)
{
  return std::accumulate(flags.begin(), flags.end(), std::int64_t{ 0 });
}

template <class T>
class ThinPartsTest : public ::testing::Test
{
};
using ThinDimensions = ::testing::Types<Dim<2>, Dim<3>>;
TYPED_TEST_SUITE(ThinPartsTest, ThinDimensions);

TYPED_TEST(ThinPartsTest, ShapesThatTheLabelsFunctionLosesOrPinches)
{
  constexpr int D = TypeParam::value;
  const stm::LatticeIndex<D> dims = UniformExtents<D>(10);
  auto centre = [](const stm::LatticeIndex<D>& voxel, std::int64_t from, std::int64_t to)
  {
    bool inside = true;
    for (int axis = 0; axis < D; ++axis)
    {
      inside = inside && voxel[axis] >= from && voxel[axis] < to;
    }
    return inside;
  };
  { // One voxel of 2 in 1: thin; the 1s around it are not.
    LabelImage<D> image(dims);
    ForEachIndex<D>(dims,
      [&](const stm::LatticeIndex<D>& voxel) { image.Set(voxel, centre(voxel, 4, 5) ? 2 : 1); });
    const std::vector<std::uint8_t> thin = Thin<D>(image, false);
    EXPECT_EQ(Count<D>(thin), 1);
    stm::LatticeIndex<D> four;
    four.fill(4);
    EXPECT_EQ(thin[stm::LinearIndex<D>(four, dims)], 1);
    // In body-only mode both are body: nothing is thin.
    EXPECT_EQ(Count<D>(Thin<D>(image, true)), 0);
  }
  { // A block two voxels wide: in 2D each voxel centre keeps it (9 of 16 weights); in 3D none
    // does (27 of 64: the cut keeps only a blob around the block's centre), so all are thin.
    // Three voxels wide: the middle voxel keeps it.
    for (const std::int64_t width : { 2, 3 })
    {
      LabelImage<D> image(dims);
      ForEachIndex<D>(dims,
        [&](const stm::LatticeIndex<D>& voxel)
        { image.Set(voxel, centre(voxel, 4, 4 + width) ? 2 : 1); });
      EXPECT_EQ(Count<D>(Thin<D>(image, false)), D == 3 && width == 2 ? 8 : 0) << width;
    }
  }
  { // A flat layer one voxel thick between 1 and 3: every corner of it is a tie, all thin; two
    // voxels thick: none.
    for (const std::int64_t thickness : { 1, 2 })
    {
      LabelImage<D> image(dims);
      ForEachIndex<D>(dims,
        [&](const stm::LatticeIndex<D>& voxel) {
          image.Set(voxel, voxel[0] < 4 ? 1 : voxel[0] < 4 + thickness ? 2 : 3);
        });
      const std::int64_t layer = image.CountVoxels(2);
      EXPECT_EQ(Count<D>(Thin<D>(image, false)), thickness == 1 ? layer : 0);
    }
  }
  { // A line one voxel wide of 2 in 1 (3D: a line; 2D: the same layer, diagonal): all thin.
    LabelImage<D> image(dims);
    ForEachIndex<D>(dims,
      [&](const stm::LatticeIndex<D>& voxel)
      { image.Set(voxel, voxel[1] == 4 && (D == 2 || voxel[D - 1] == 4) ? 2 : 1); });
    EXPECT_EQ(Count<D>(Thin<D>(image, false)), image.CountVoxels(2));
  }
  { // The body against the image border: voxels beyond the image are background, so a body
    // voxel in a corner of the image is kept by its inner corner only when the body is thick.
    LabelImage<D> image(dims);
    ForEachIndex<D>(dims,
      [&](const stm::LatticeIndex<D>& voxel) { image.Set(voxel, centre(voxel, 0, 1) ? 1 : 0); });
    EXPECT_EQ(Count<D>(Thin<D>(image, true)), 1);
  }
}

/// A speckled random image refined at its thin voxels (to half a voxel), tessellated with its
/// background, and cut with the multi-material cut: the face-connected components of every
/// material, against those of the voxels.
template <int D>
void CutSpeckledImage(bool refine, ComponentsKept& kept, std::int64_t& thinVoxels)
{
  const LabelImage<D> image = MakeRandomImage<D>(FirstExtents<D>({ 19, 17, 15 }), 21, 3, 6, 80);
  stm::SequentialExecutor executor;
  std::vector<std::uint8_t> thin;
  ASSERT_TRUE(stm::ThinPartVoxels<D>(image.View(), false, thin, executor).IsOk());
  thinVoxels = Count<D>(thin);
  stm::RefinementPlanOptions<D> planOptions;
  planOptions.MaxCellSize = 4;
  planOptions.Pattern = UniformPattern<D>(2);
  planOptions.FinestSize = refine ? 0.5 : 0.0;
  stm::RefinementPlan<D> plan;
  ASSERT_TRUE(stm::PlanRefinement<D>(image.GetDimensions(), planOptions, plan).IsOk());
  std::vector<std::uint8_t> levels(thin.size(), 0);
  const auto level = static_cast<std::uint8_t>(
    plan.CoarsestLevelWithin(0.5, plan.LargestEdges(stm::RefinementPlanOptions<D>::UnitSpacing())));
  for (std::size_t v = 0; v < thin.size() && refine; ++v)
  {
    levels[v] = thin[v] ? level : 0;
  }
  stm::Spacetree<D> tree;
  ASSERT_TRUE(stm::SpacetreeBuilder<D>()
                .Build(image.View(), MaterialLabels(image.LargestMaterial() + 1), plan,
                  levels.data(), tree, executor)
                .IsOk());
  stm::SpacetreeBalanceOptions balance;
  ASSERT_TRUE(stm::SpacetreeBalancer<D>().Balance(tree, balance, executor).IsOk());
  stm::SpacetreeTessellationOptions options;
  options.IncludeBackground = true;
  SimplicialMesh<D> mesh;
  ASSERT_TRUE(TessellateTree<D>(tree, options, executor, mesh).IsOk());
  // Materials as peeling indices (labels ascending, the background last); coordinates in
  // voxel units.
  std::vector<std::int64_t> order;
  for (stm::MaterialIndex m = 1; m <= image.LargestMaterial(); ++m)
  {
    order.push_back(m);
  }
  order.push_back(stm::BackgroundMaterial);
  std::vector<std::int32_t> materials;
  for (const stm::MaterialIndex m : mesh.Materials)
  {
    materials.push_back(m == stm::BackgroundMaterial ? static_cast<std::int32_t>(order.size()) - 1
                                                     : static_cast<std::int32_t>(m) - 1);
  }
  std::vector<double> points3;
  for (const auto& point : mesh.HalfUnitPoints)
  {
    for (int axis = 0; axis < 3; ++axis)
    {
      points3.push_back(axis < D ? 0.5 * static_cast<double>(point[axis]) /
            static_cast<double>(tree.VoxelSubdivision[axis])
                                 : 0.0);
    }
  }
  stm::MaterialFractions fractions;
  ASSERT_TRUE(stm::CornerFractions<D>(points3.data(), mesh.GetNumberOfPoints(),
    mesh.Connectivity.data(), mesh.GetNumberOfSimplices(), materials.data(),
    static_cast<int>(order.size()), static_cast<int>(order.size()) - 1, fractions, executor)
                .IsOk());
  stm::MultiMaterialCut<D> cut;
  ASSERT_TRUE(cut
                .Run(mesh.GetNumberOfPoints(), nullptr, mesh.Connectivity.data(),
                  mesh.GetNumberOfSimplices(), materials.data(), static_cast<int>(order.size()),
                  std::move(fractions), stm::MultiMaterialCutOptions(), executor)
                .IsOk());
  std::vector<std::int64_t> labels;
  for (const std::int32_t material : cut.GetCellMaterials())
  {
    labels.push_back(order[material]);
  }
  std::vector<double> points;
  for (std::int64_t p = 0; p < cut.GetNumberOfPoints(); ++p)
  {
    if (p < mesh.GetNumberOfPoints())
    {
      points.insert(points.end(), points3.begin() + 3 * p, points3.begin() + 3 * p + D);
      continue;
    }
    const stm::CutEdge& edge = cut.GetAddedPoints()[p - mesh.GetNumberOfPoints()];
    for (int axis = 0; axis < D; ++axis)
    {
      points.push_back(
        (1.0 - edge.T) * points[edge.A * D + axis] + edge.T * points[edge.B * D + axis]);
    }
  }
  kept = CheckComponentsKept<D>(image, points, cut.GetCells(), labels);
}

TYPED_TEST(ThinPartsTest, RefiningThinVoxelsKeepsEveryComponent)
{
  constexpr int D = TypeParam::value;
  ComponentsKept voxelSize, refined;
  std::int64_t thin = 0;
  CutSpeckledImage<D>(false, voxelSize, thin);
  CutSpeckledImage<D>(true, refined, thin);
  std::cout << refined.Components << " components, " << thin << " thin voxels; lost "
            << voxelSize.Lost << " and split " << voxelSize.Split << " at voxel size, lost "
            << refined.Lost << " and split " << refined.Split << " refined\n";
  EXPECT_GT(thin, 0);
  EXPECT_GT(voxelSize.Lost, 0);
  EXPECT_EQ(refined.Lost, 0);
  EXPECT_EQ(refined.Split, 0);
}

TEST(ThinParts, RejectsBadImages)
{
  stm::SequentialExecutor executor;
  std::vector<std::uint8_t> thin;
  stm::MaterialImage<2> empty;
  EXPECT_FALSE(stm::ThinPartVoxels<2>(empty, false, thin, executor).IsOk());
  empty.Dimensions = { 3, 3 };
  EXPECT_FALSE(stm::ThinPartVoxels<2>(empty, false, thin, executor).IsOk());
}

} // namespace
