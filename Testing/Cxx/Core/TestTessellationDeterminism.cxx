// SPDX-License-Identifier: BSD-3-Clause
// The whole pipeline must give bit-identical trees and meshes whatever the number of threads and
// however the ranges happen to be scheduled: point ids come from a lattice-order rank and
// simplices from per-leaf offsets, never from the order in which threads finish.

#include "CoreTestUtilities.h"

namespace
{
using namespace stmtest;

template <class DimensionTag>
class TessellationDeterminismTest : public ::testing::Test
{
};
using DeterminismDimensions = ::testing::Types<Dim<2>, Dim<3>>;
TYPED_TEST_SUITE(TessellationDeterminismTest, DeterminismDimensions);

/// Large enough that every parallel loop has several ranges: many roots (MaxCellSize 8) for the
/// build, and well over 2048 leaves (the tessellation grain) thanks to the specks.
template <int D>
LabelImage<D> MakeDeterminismImage()
{
  return MakeRandomImage<D>(
    D == 2 ? FirstExtents<D>({ 251, 203 }) : FirstExtents<D>({ 45, 39, 34 }), 2024, 3, 6, 40);
}

template <int D>
struct PipelineOutput
{
  stm::Spacetree<D> Tree;
  SimplicialMesh<D> Mesh;
};

template <int D, class Executor>
PipelineOutput<D> RunPipeline(const LabelImage<D>& image, int L, stm::CellTemplate cellTemplate,
  bool includeBackground, Executor& executor)
{
  PipelineOutput<D> output;
  const stm::Status built = BuildTree<D>(image, 8, L, false, executor, output.Tree);
  EXPECT_TRUE(built.IsOk()) << built.GetMessage();
  stm::SpacetreeTessellationOptions options;
  options.Template = cellTemplate;
  options.IncludeBackground = includeBackground;
  const stm::Status tessellated = TessellateTree<D>(output.Tree, options, executor, output.Mesh);
  EXPECT_TRUE(tessellated.IsOk()) << tessellated.GetMessage();
  return output;
}

template <int D>
void ExpectIdentical(const PipelineOutput<D>& expected, const PipelineOutput<D>& actual)
{
  EXPECT_EQ(actual.Tree.LeafLevels, expected.Tree.LeafLevels);
  EXPECT_EQ(actual.Tree.LeafAnchors, expected.Tree.LeafAnchors);
  EXPECT_EQ(actual.Tree.LeafMaterials, expected.Tree.LeafMaterials);
  // Whole-vector comparisons: one message for a mismatch, not one per entry.
  EXPECT_TRUE(actual.Mesh.Connectivity == expected.Mesh.Connectivity) << "connectivity differs";
  EXPECT_TRUE(actual.Mesh.Materials == expected.Mesh.Materials) << "materials differ";
  EXPECT_TRUE(actual.Mesh.HalfUnitPoints == expected.Mesh.HalfUnitPoints) << "points differ";
  EXPECT_TRUE(actual.Mesh.Coordinates() == expected.Mesh.Coordinates()) << "coordinates differ";
  EXPECT_TRUE(actual.Mesh.VisitCounts == expected.Mesh.VisitCounts) << "point visits differ";
}

TYPED_TEST(TessellationDeterminismTest, ThreadPoolsReproduceTheSequentialMeshExactly)
{
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = MakeDeterminismImage<D>();
  for (int L : { 0, 2 })
  {
    for (stm::CellTemplate cellTemplate :
      { stm::CellTemplate::Kuhn, stm::CellTemplate::Checkerboard })
    {
      for (bool includeBackground : { false, true })
      {
        SCOPED_TRACE("L " + std::to_string(L) +
          (cellTemplate == stm::CellTemplate::Kuhn ? ", Kuhn" : ", Checkerboard") +
          (includeBackground ? ", with background" : ""));
        stm::SequentialExecutor sequential;
        const PipelineOutput<D> expected =
          RunPipeline<D>(image, L, cellTemplate, includeBackground, sequential);
        ASSERT_GT(expected.Tree.GetNumberOfLeaves(), 3 * 2048);
        ASSERT_GT(expected.Mesh.GetNumberOfSimplices(), 0);
        for (int threads : { 2, 3 })
        {
          SCOPED_TRACE(std::to_string(threads) + " threads");
          stm::ThreadPoolExecutor pool(threads);
          ExpectIdentical<D>(
            expected, RunPipeline<D>(image, L, cellTemplate, includeBackground, pool));
        }
      }
    }
  }
}

} // namespace
