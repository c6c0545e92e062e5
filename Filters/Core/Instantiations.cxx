// SPDX-License-Identifier: BSD-3-Clause
// Compiles every core algorithm for every supported dimension, so that a change that breaks one
// dimension fails the build rather than a later user.

#include "Balance/SpacetreeBalance.h"
#include "Balance/SpacetreeGrading.h"
#include "Check/MeshInvariants.h"
#include "Cut/MarchingSimplices.h"
#include "Cut/MultiMaterialCut.h"
#include "Cut/SeparatingFunction.h"
#include "Cut/VertexSnap.h"
#include "Smooth/BoundarySmooth.h"
#include "Smooth/InteriorEdgeSplit.h"
#include "Spacetree/SpacetreeBuild.h"
#include "Spacetree/ThinPartPieces.h"
#include "Spacetree/ThinParts.h"
#include "Surface/InterfaceFacets.h"
#include "Tessellate/SpacetreeTessellation.h"

namespace stm
{
template class Spacetree<1>;
template class Spacetree<2>;
template class Spacetree<3>;
template class Spacetree<4>;
template class LevelMap<1>;
template class LevelMap<2>;
template class LevelMap<3>;
template class LevelMap<4>;
template class SpacetreeTessellator<1>;
template class SpacetreeTessellator<2>;
template class SpacetreeTessellator<3>;
template class SpacetreeTessellator<4>;

namespace
{
template <int Dim>
void InstantiatePipeline()
{
  SequentialExecutor executor;
  MaterialImage<Dim> image;
  Spacetree<Dim> tree;
  SpacetreeBuilder<Dim>().Build(image, { 0 }, RefinementPlanOptions<Dim>(), tree, executor);
  SpacetreeGrader<Dim>().Grade(tree, 2.0, RefinementPlanOptions<Dim>::UnitSpacing(), executor);
  SpacetreeBalancer<Dim>().Balance(tree, SpacetreeBalanceOptions(), executor);
  SpacetreeTessellator<Dim> tessellator;
  tessellator.Prepare(tree, SpacetreeTessellationOptions(), executor);
  tessellator.WriteSimplices(static_cast<std::int64_t*>(nullptr), nullptr, executor);
  CheckSimplicialMesh<Dim>({}, {}, nullptr);
  std::vector<std::uint8_t> thin;
  ThinPartVoxels<Dim>(image, false, thin, executor);
  ThinPartPiece<Dim> thinPiece;
  thinPiece.Classify(
    image, VoxelBox<Dim>(), VoxelBox<Dim>(), LatticeIndex<Dim>(), false, 0, executor);
  thinPiece.Finish(thinPiece.Records(), thin, executor);
  std::vector<std::int8_t> indicator;
  BodyIndicator<Dim>(tree, indicator, executor);
  MarchingSimplices<Dim> cutter;
  auto outside = [](std::int64_t) { return CutSide::Outside; };
  cutter.Classify(static_cast<const double*>(nullptr), 0, static_cast<const std::int64_t*>(nullptr),
    0, MarchingSimplicesOptions(), outside, executor);
  cutter.WriteCells(static_cast<const std::int64_t*>(nullptr), static_cast<std::int32_t*>(nullptr),
    nullptr, nullptr, executor);
  std::vector<std::int64_t> facets, parents;
  cutter.ExtractSurface(static_cast<const std::int64_t*>(nullptr), facets, parents, executor);
  MultiMaterialCut<Dim> materials;
  materials.Run(0, nullptr, static_cast<const std::int64_t*>(nullptr), 0, nullptr, 1,
    MaterialFractions(), MultiMaterialCutOptions(), executor);
  if constexpr (Dim <= 3)
  {
    MaterialFractions fractions;
    CornerFractions<Dim>(static_cast<const double*>(nullptr), 0,
      static_cast<const std::int32_t*>(nullptr), 0, nullptr, 1, -1, fractions, executor);
  }
  VertexSnap<Dim> snap;
  snap.Snap(static_cast<double*>(nullptr), nullptr, 0, static_cast<const std::int64_t*>(nullptr), 0,
    VertexSnapOptions(), executor);
  snap.Snap(
    static_cast<double*>(nullptr), nullptr, 0, static_cast<const std::int32_t*>(nullptr), 0,
    VertexSnapOptions(),
    [](std::int64_t, const double*, const double*, const double*, double*) { return true; },
    executor);
  BoundarySmoother<Dim>().Smooth(static_cast<double*>(nullptr), 0,
    static_cast<const std::int64_t*>(nullptr), 0, static_cast<const std::int64_t*>(nullptr),
    BoundarySmoothOptions(), executor);
  if constexpr (Dim >= 2)
  {
    InteriorEdgeSplit<Dim>().Split(static_cast<const double*>(nullptr), 0,
      static_cast<const std::int32_t*>(nullptr), 0, nullptr, InteriorEdgeSplitOptions(), executor);
  }
  InterfaceFacets<Dim> interfaces;
  ExtractInterfaceFacets<Dim>(static_cast<const double*>(nullptr), 0,
    static_cast<const std::int64_t*>(nullptr), 0, static_cast<const std::int64_t*>(nullptr),
    InterfaceFacetOptions(), executor, interfaces);
}
} // namespace

void InstantiateAllDimensions()
{
  InstantiatePipeline<1>();
  InstantiatePipeline<2>();
  InstantiatePipeline<3>();
  InstantiatePipeline<4>();
}
} // namespace stm
