// SPDX-License-Identifier: BSD-3-Clause
// Thin parts in 2D and 3D: single voxels, one-voxel plates (flat, so every corner is a tie) and
// one-voxel lines are thin, blocks three voxels wide are not, the body-only mode joins the
// body's labels; and refining the thin voxels to half their size makes the multi-material cut keep
// every face-connected component of a speckled random image, which the cut at voxel size loses;
// and the smoothing (SmallPartPoints) keeps a voxel centre of every component in a cell of its
// label.

#include "CoreTestUtilities.h"

#include "Common/Determinant.h"
#include "Cut/MultiMaterialCut.h"
#include "Smooth/BoundarySmooth.h"
#include "Spacetree/ThinPartPieces.h"
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

/// The definition of a thin voxel (Spacetree/ThinParts.h), tested voxel by voxel with no
/// shortcut: the reference for the kernels, which answer voxels inside one material from whole
/// rows.
template <int D>
std::vector<std::uint8_t> ThinByDefinition(const LabelImage<D>& image, bool bodyOnly)
{
  const stm::LatticeIndex<D>& dims = image.GetDimensions();
  auto material = [&](const stm::LatticeIndex<D>& voxel) -> int
  {
    const int value = image.At(voxel); // the background beyond the image
    return bodyOnly ? (value == stm::BackgroundMaterial ? 0 : 1) : value;
  };
  // The strict majority of the 2^D voxels at a corner, or -1.
  auto majority = [&](const stm::LatticeIndex<D>& corner)
  {
    std::map<int, int> counts;
    for (int k = 0; k < (1 << D); ++k)
    {
      stm::LatticeIndex<D> voxel = corner;
      for (int axis = 0; axis < D; ++axis)
      {
        voxel[axis] -= (k >> axis) & 1;
      }
      ++counts[material(voxel)];
    }
    int best = -1, bestCount = 0, ties = 0;
    for (const auto& entry : counts)
    {
      ties = entry.second == bestCount ? ties + 1 : entry.second > bestCount ? 0 : ties;
      if (entry.second > bestCount)
      {
        best = entry.first;
        bestCount = entry.second;
      }
    }
    return ties > 0 ? -1 : best;
  };
  // Whether the labels function gives a voxel's material more than one half at its centre.
  auto centreKeeps = [&](const stm::LatticeIndex<D>& voxel)
  {
    int own = 0, total = 0;
    ForEachIndexInBox<D>(stm::LatticeIndex<D>{}, UniformExtents<D>(3),
      [&](const stm::LatticeIndex<D>& offset)
      {
        stm::LatticeIndex<D> other = voxel;
        int weight = 1;
        for (int axis = 0; axis < D; ++axis)
        {
          other[axis] += offset[axis] - 1;
          weight *= offset[axis] == 1 ? 2 : 1;
        }
        own += material(other) == material(voxel) ? weight : 0;
        total += weight;
      });
    return 2 * own > total;
  };
  LabelImage<D> mapped(dims);
  ForEachIndex<D>(dims,
    [&](const stm::LatticeIndex<D>& voxel)
    { mapped.Set(voxel, static_cast<stm::MaterialIndex>(material(voxel))); });
  const std::vector<std::int64_t> components = VoxelComponentIds<D>(mapped);
  std::set<std::int64_t> keptComponents;
  ForEachIndex<D>(dims,
    [&](const stm::LatticeIndex<D>& voxel)
    {
      if (centreKeeps(voxel))
      {
        keptComponents.insert(components[stm::LinearIndex<D>(voxel, dims)]);
      }
    });
  std::vector<std::uint8_t> thin(static_cast<std::size_t>(stm::NumberOfLatticeCells<D>(dims)), 0);
  ForEachIndex<D>(dims,
    [&](const stm::LatticeIndex<D>& voxel)
    {
      const std::int64_t linear = stm::LinearIndex<D>(voxel, dims);
      bool joined = true;
      for (int axis = 0; axis < D; ++axis)
      {
        for (const int side : { 0, 1 })
        {
          stm::LatticeIndex<D> neighbour = voxel;
          neighbour[axis] += side == 1 ? 1 : -1;
          if (!image.Contains(neighbour) || material(neighbour) != material(voxel))
          {
            continue;
          }
          bool shared = false;
          for (int k = 0; k < (1 << (D - 1)); ++k)
          {
            stm::LatticeIndex<D> corner = voxel;
            corner[axis] += side;
            for (int other = 0, bit = 0; other < D; ++other)
            {
              corner[other] += other == axis ? 0 : (k >> bit++) & 1;
            }
            shared = shared || majority(corner) == material(voxel);
          }
          joined = joined && shared;
        }
      }
      thin[linear] = keptComponents.count(components[linear]) != 0 && joined ? 0 : 1;
    });
  return thin;
}

/// The cut mesh: D coordinates per point (voxel units), D + 1 point ids and a label per cell.
template <int D>
struct CutLabels
{
  std::vector<double> Points;
  std::vector<std::int64_t> Cells;
  std::vector<std::int64_t> Labels;
};

template <int D>
LabelImage<D> SpeckledImage()
{
  return MakeRandomImage<D>(FirstExtents<D>({ 19, 17, 15 }), 21, 3, 6, 80);
}

/// The spacetree of an image on a plan with the coarsest level of each voxel (levels), balanced,
/// tessellated with its background and cut with the multi-material cut: the face-connected
/// components of every material, against those of the voxels.
template <int D>
void CutWithLevels(const LabelImage<D>& image, const stm::RefinementPlan<D>& plan,
  const std::vector<std::uint8_t>& levels, ComponentsKept& kept, CutLabels<D>* result);

/// A speckled random image refined at its thin voxels (to half a voxel), tessellated with its
/// background, and cut with the multi-material cut: the face-connected components of every
/// material, against those of the voxels.
template <int D>
void CutSpeckledImage(
  bool refine, ComponentsKept& kept, std::int64_t& thinVoxels, CutLabels<D>* result = nullptr)
{
  const LabelImage<D> image = SpeckledImage<D>();
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
  CutWithLevels<D>(image, plan, levels, kept, result);
}

template <int D>
void CutWithLevels(const LabelImage<D>& image, const stm::RefinementPlan<D>& plan,
  const std::vector<std::uint8_t>& levels, ComponentsKept& kept, CutLabels<D>* result)
{
  stm::SequentialExecutor executor;
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
  if (result)
  {
    result->Points = std::move(points);
    result->Cells = cut.GetCells();
    result->Labels = std::move(labels);
  }
}

/// The face-connected components of the image none of whose voxel centres lies in a closed
/// cell of its label (the test of stmesh's structure report).
template <int D>
std::int64_t ComponentsLostByCentres(const LabelImage<D>& image, const CutLabels<D>& mesh)
{
  const std::vector<std::int64_t> ids = VoxelComponentIds<D>(image);
  std::set<std::int64_t> covered;
  const auto cells = static_cast<std::int64_t>(mesh.Labels.size());
  for (std::int64_t c = 0; c < cells; ++c)
  {
    const double* corners[D + 1];
    stm::LatticeIndex<D> lower, upper;
    for (int v = 0; v <= D; ++v)
    {
      corners[v] = mesh.Points.data() + mesh.Cells[c * (D + 1) + v] * D;
    }
    double edges[D][D];
    for (int axis = 0; axis < D; ++axis)
    {
      double lo = corners[0][axis], hi = corners[0][axis];
      for (int v = 1; v <= D; ++v)
      {
        lo = std::min(lo, corners[v][axis]);
        hi = std::max(hi, corners[v][axis]);
        edges[axis][v - 1] = corners[v][axis] - corners[0][axis];
      }
      lower[axis] = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::ceil(lo - 0.5)));
      upper[axis] = std::min<std::int64_t>(
        image.GetDimensions()[axis], static_cast<std::int64_t>(std::floor(hi - 0.5)) + 1);
    }
    const double volume = stm::Determinant<D>(edges);
    ForEachIndexInBox<D>(lower, upper,
      [&](const stm::LatticeIndex<D>& voxel)
      {
        if (image.At(voxel) != mesh.Labels[c])
        {
          return;
        }
        // Barycentric coordinates by Cramer's rule: the centre replaces one edge at a time.
        double sum = 0.0;
        bool inside = true;
        for (int v = 0; v < D; ++v)
        {
          double replaced[D][D];
          for (int axis = 0; axis < D; ++axis)
          {
            for (int k = 0; k < D; ++k)
            {
              replaced[axis][k] =
                k == v ? static_cast<double>(voxel[axis]) + 0.5 - corners[0][axis] : edges[axis][k];
            }
          }
          const double coordinate = stm::Determinant<D>(replaced) / volume;
          inside = inside && coordinate >= -1e-9;
          sum += coordinate;
        }
        if (inside && sum <= 1.0 + 1e-9)
        {
          covered.insert(ids[stm::LinearIndex<D>(voxel, image.GetDimensions())]);
        }
      });
  }
  const std::int64_t components = *std::max_element(ids.begin(), ids.end()) + 1;
  return components - static_cast<std::int64_t>(covered.size());
}

// The kernels give the definition's flags, voxel for voxel, on random images with large regions
// of one material (the kernels' row comparisons) and specks (their counts), at the border too.
TYPED_TEST(ThinPartsTest, KernelsFollowTheDefinition)
{
  constexpr int D = TypeParam::value;
  for (const unsigned seed : { 3u, 21u, 77u })
  {
    const LabelImage<D> image = MakeRandomImage<D>(FirstExtents<D>({ 23, 19, 17 }), seed, 4, 8, 30);
    for (const bool bodyOnly : { false, true })
    {
      const std::vector<std::uint8_t> thin = Thin<D>(image, bodyOnly);
      EXPECT_EQ(thin, ThinByDefinition<D>(image, bodyOnly))
        << "seed " << seed << ", body only " << bodyOnly;
      EXPECT_GT(Count<D>(thin), 0);
      EXPECT_LT(Count<D>(thin), static_cast<std::int64_t>(thin.size()) / 2);
    }
  }
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

/// The minority-corner flags by their definition: a voxel whose material holds less than half
/// of the 2^d voxels around one of its corners (beyond the image: background).
template <int D>
std::vector<std::uint8_t> MinorityCornersByDefinition(const LabelImage<D>& image, bool bodyOnly)
{
  auto material = [&](const stm::LatticeIndex<D>& voxel)
  {
    const stm::MaterialIndex m = image.At(voxel);
    return bodyOnly ? (m == stm::BackgroundMaterial ? 0 : 1) : static_cast<int>(m);
  };
  std::vector<std::uint8_t> flags;
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      bool minority = false;
      for (int corner = 0; corner < (1 << D); ++corner)
      {
        int same = 0;
        for (int k = 0; k < (1 << D); ++k)
        {
          stm::LatticeIndex<D> around;
          for (int axis = 0; axis < D; ++axis)
          {
            around[axis] = voxel[axis] + ((corner >> axis) & 1) - ((k >> axis) & 1);
          }
          same += material(around) == material(voxel) ? 1 : 0;
        }
        minority = minority || 2 * same < (1 << D);
      }
      flags.push_back(minority ? 1 : 0);
    });
  return flags;
}

// Minority corners: a block [0, 8)^d in a corner of a 16^d image has them where two or more of
// a voxel's coordinates are 0 or 7 (its corners in 2D, its twelve edges in 3D: 4 and 80
// voxels; beyond the image is background); random images follow the definition voxel for voxel.
TYPED_TEST(ThinPartsTest, MinorityCornersFollowTheDefinition)
{
  constexpr int D = TypeParam::value;
  LabelImage<D> block(UniformExtents<D>(16));
  ForEachIndex<D>(
    UniformExtents<D>(8), [&](const stm::LatticeIndex<D>& voxel) { block.Set(voxel, 1); });
  stm::SequentialExecutor executor;
  std::vector<std::uint8_t> flags;
  ASSERT_TRUE(stm::MinorityCornerVoxels<D>(block.View(), true, flags, executor).IsOk());
  EXPECT_EQ(Count<D>(flags), D == 2 ? 4 : 80);
  EXPECT_EQ(flags, MinorityCornersByDefinition<D>(block, true));
  for (const unsigned seed : { 3u, 21u, 77u })
  {
    const LabelImage<D> image = MakeRandomImage<D>(FirstExtents<D>({ 23, 19, 17 }), seed, 4, 8, 30);
    for (const bool bodyOnly : { false, true })
    {
      ASSERT_TRUE(stm::MinorityCornerVoxels<D>(image.View(), bodyOnly, flags, executor).IsOk());
      EXPECT_EQ(flags, MinorityCornersByDefinition<D>(image, bodyOnly))
        << "seed " << seed << ", body only " << bodyOnly;
      EXPECT_GT(Count<D>(flags), 0);
    }
  }
  const stm::MaterialImage<D> empty{ stm::LatticeIndex<D>{}, nullptr };
  EXPECT_FALSE(stm::MinorityCornerVoxels<D>(empty, true, flags, executor).IsOk());
}

// The block in the corner of the image is one leaf, all of whose corners are minority corners
// of the body: the cut loses it whole. Leaves of one voxel at the minority corners keep it,
// within 10 % of its volume (the cut rounds its convex edges by up to half a voxel).
TYPED_TEST(ThinPartsTest, LeavesOfOneVoxelAtMinorityCornersKeepABlock)
{
  constexpr int D = TypeParam::value;
  LabelImage<D> block(UniformExtents<D>(16));
  ForEachIndex<D>(
    UniformExtents<D>(8), [&](const stm::LatticeIndex<D>& voxel) { block.Set(voxel, 1); });
  stm::RefinementPlanOptions<D> planOptions;
  planOptions.MaxCellSize = 16;
  planOptions.Pattern = UniformPattern<D>(2);
  stm::RefinementPlan<D> plan;
  ASSERT_TRUE(stm::PlanRefinement<D>(block.GetDimensions(), planOptions, plan).IsOk());
  stm::SequentialExecutor executor;
  std::vector<std::uint8_t> corners;
  ASSERT_TRUE(stm::MinorityCornerVoxels<D>(block.View(), true, corners, executor).IsOk());
  const auto voxelLevel = static_cast<std::uint8_t>(
    plan.CoarsestLevelWithin(1.0, plan.LargestEdges(stm::RefinementPlanOptions<D>::UnitSpacing())));
  std::vector<std::uint8_t> levels(corners.size(), 0);
  ComponentsKept coarse, refined;
  CutLabels<D> coarseCut, refinedCut;
  CutWithLevels<D>(block, plan, levels, coarse, &coarseCut);
  for (std::size_t v = 0; v < corners.size(); ++v)
  {
    levels[v] = corners[v] ? voxelLevel : 0;
  }
  CutWithLevels<D>(block, plan, levels, refined, &refinedCut);
  EXPECT_EQ(coarse.Lost, 1);
  EXPECT_EQ(refined.Lost, 0);
  EXPECT_EQ(refined.Split, 0);
  const stm::MeshInvariantReport report =
    stm::CheckSimplicialMesh<D>(refinedCut.Points, refinedCut.Cells, &refinedCut.Labels);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  const double voxels = D == 2 ? 64.0 : 512.0;
  EXPECT_NEAR(report.VolumePerMaterial.at(1), voxels, 0.1 * voxels);
}

// The smoothing as stmesh runs it (Taubin, interior layers, every label's volume restored) on the
// refined speckled image: with small parts kept (the default), every component keeps a voxel
// centre in a cell of its label, and the held points stay bit for bit; without (0), single
// voxels shrink away from their centres.
TYPED_TEST(ThinPartsTest, SmoothingKeepsAVoxelCentreOfEveryComponent)
{
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = SpeckledImage<D>();
  ComponentsKept kept;
  std::int64_t thin = 0;
  CutLabels<D> cut;
  CutSpeckledImage<D>(true, kept, thin, &cut);
  ASSERT_EQ(kept.Lost, 0);
  ASSERT_EQ(ComponentsLostByCentres<D>(image, cut), 0);
  std::map<bool, std::int64_t> lost;
  for (const bool keep : { true, false })
  {
    CutLabels<D> smoothed = cut;
    stm::BoundarySmoothOptions options;
    options.SmallPartPoints = keep ? stm::BoundarySmoothOptions().SmallPartPoints : 0;
    options.VolumeTargetMaterials = cut.Labels.data();
    stm::BoundarySmoother<D> smoother;
    stm::SequentialExecutor executor;
    const stm::Status status = smoother.Smooth(smoothed.Points.data(),
      static_cast<std::int64_t>(smoothed.Points.size() / D), smoothed.Cells.data(),
      static_cast<std::int64_t>(smoothed.Labels.size()), smoothed.Labels.data(), options, executor);
    ASSERT_TRUE(status.IsOk()) << status.GetMessage();
    const stm::MeshInvariantReport report =
      stm::CheckSimplicialMesh<D>(smoothed.Points, smoothed.Cells, &smoothed.Labels);
    EXPECT_TRUE(report.IsValid()) << report.Summary();
    lost[keep] = ComponentsLostByCentres<D>(image, smoothed);
    const stm::BoundarySmoothStats& stats = smoother.GetStats();
    if (!keep)
    {
      EXPECT_EQ(stats.KeptPoints, 0);
      EXPECT_EQ(stats.SmallParts, 0);
      continue;
    }
    EXPECT_GT(stats.KeptPoints, 0);
    EXPECT_GT(stats.SmallParts, 0);
    // The fixed points (held interior points among them) stay bit for bit; the kept surface
    // points move only where the quality improvement moves them.
    std::int64_t fixed = 0, keptSurface = 0;
    const std::vector<std::uint8_t>& roles = smoother.GetPointRoles();
    for (std::size_t p = 0; p < roles.size(); ++p)
    {
      keptSurface += roles[p] == stm::BoundarySmoother<D>::KeptSurface;
      if (roles[p] != stm::BoundarySmoother<D>::Fixed)
      {
        continue;
      }
      for (int axis = 0; axis < D; ++axis)
      {
        EXPECT_EQ(smoothed.Points[p * D + axis], cut.Points[p * D + axis]) << "point " << p;
      }
      ++fixed;
    }
    EXPECT_GT(keptSurface, 0);
    EXPECT_LT(keptSurface, stats.KeptPoints);
    EXPECT_GE(fixed + keptSurface, stats.KeptPoints);
  }
  std::cout << D << "D: components lost by their voxel centres after the smoothing: " << lost[true]
            << " keeping small parts, " << lost[false] << " without\n";
  EXPECT_EQ(lost[true], 0);
  EXPECT_GT(lost[false], 0);
}

/// The voxels of `box` of an image.
template <int D>
LabelImage<D> CropImage(const LabelImage<D>& image, const stm::VoxelBox<D>& box)
{
  LabelImage<D> crop(box.GetDimensions());
  box.ForEach([&](std::int64_t i, const stm::LatticeIndex<D>& voxel)
    { crop.GetValues()[static_cast<std::size_t>(i)] = image.At(voxel); });
  return crop;
}

/// Each piece's flags on its box grown by `ghosts` voxels, classified in pieces that own the
/// boxes between `cuts` (per axis, the first voxels of the second and later pieces; one piece
/// more, owning nothing) and read their boxes grown by ghosts + 1 voxels; with `join` off the
/// pieces skip step 2 (a mutation: each component is then judged by its parts alone).
template <int D>
std::vector<std::vector<std::uint8_t>> ClassifyInPieces(const LabelImage<D>& image, bool bodyOnly,
  const std::array<std::vector<std::int64_t>, D>& cuts, int ghosts, bool join,
  std::vector<stm::VoxelBox<D>>& ghostBoxes, std::int64_t& ownThinVoxels)
{
  const stm::LatticeIndex<D> dims = image.GetDimensions();
  std::vector<stm::VoxelBox<D>> owned(1);
  for (int axis = 0; axis < D; ++axis)
  {
    owned[0].Upper[axis] = dims[axis];
  }
  for (int axis = 0; axis < D; ++axis)
  {
    std::vector<stm::VoxelBox<D>> split;
    for (const stm::VoxelBox<D>& box : owned)
    {
      std::int64_t lower = 0;
      for (std::size_t k = 0; k <= cuts[axis].size(); ++k)
      {
        stm::VoxelBox<D> part = box;
        part.Lower[axis] = lower;
        part.Upper[axis] = k < cuts[axis].size() ? cuts[axis][k] : dims[axis];
        lower = part.Upper[axis];
        split.push_back(part);
      }
    }
    owned = split;
  }
  owned.push_back(stm::VoxelBox<D>()); // a piece with no voxels
  const int pieces = static_cast<int>(owned.size());
  stm::SequentialExecutor executor;
  std::vector<LabelImage<D>> crops;
  std::vector<stm::VoxelBox<D>> read;
  std::vector<stm::ThinPartPiece<D>> classifiers(static_cast<std::size_t>(pieces));
  ghostBoxes.clear();
  for (int p = 0; p < pieces; ++p)
  {
    read.push_back(owned[p].IsEmpty() ? owned[p] : owned[p].Grown(ghosts + 1, dims));
    ghostBoxes.push_back(owned[p].IsEmpty() ? owned[p] : owned[p].Grown(ghosts, dims));
    crops.push_back(CropImage<D>(image, read.back()));
    EXPECT_TRUE(classifiers[p]
                  .Classify(crops.back().View(), read[p], owned[p], dims, bodyOnly, p, executor)
                  .IsOk());
  }
  for (int from = 0; from < pieces && join; ++from)
  {
    for (int to = 0; to < pieces; ++to)
    {
      const stm::VoxelBox<D> box = read[from].Intersection(owned[to]);
      if (from != to && !box.IsEmpty())
      {
        EXPECT_TRUE(classifiers[to].Join(from, box, classifiers[from].ComponentsIn(box)).IsOk());
      }
    }
  }
  // The records in reverse order of the pieces: the result may not depend on it.
  std::vector<std::int64_t> records;
  for (int p = pieces - 1; p >= 0; --p)
  {
    const std::vector<std::int64_t> own = classifiers[p].Records();
    records.insert(records.end(), own.begin(), own.end());
  }
  std::vector<std::vector<std::uint8_t>> flags;
  ownThinVoxels = 0;
  for (int p = 0; p < pieces; ++p)
  {
    std::vector<std::uint8_t> thin;
    EXPECT_TRUE(classifiers[p].Finish(records, thin, executor).IsOk());
    ownThinVoxels += classifiers[p].CountOwnThinVoxels(thin);
    std::vector<std::uint8_t> onGhostBox;
    ghostBoxes[p].ForEach(
      [&](std::int64_t, const stm::LatticeIndex<D>& voxel)
      {
        std::int64_t linear = 0;
        for (int axis = D - 1; axis >= 0; --axis)
        {
          linear = linear * (read[p].Upper[axis] - read[p].Lower[axis]) + voxel[axis] -
            read[p].Lower[axis];
        }
        onGhostBox.push_back(thin[static_cast<std::size_t>(linear)]);
      });
    flags.push_back(onGhostBox);
  }
  return flags;
}

// Pieces that each read a box of the image classify the voxels of their ghost boxes as the whole
// image does, though components cross several pieces; without the joins of step 2 they do not.
TYPED_TEST(ThinPartsTest, PiecesClassifyAsTheWholeImage)
{
  constexpr int D = TypeParam::value;
  std::array<std::vector<std::int64_t>, D> cuts;
  cuts[0] = { 7, 15 };
  cuts[1] = { 9 };
  std::int64_t differencesWithoutJoins = 0;
  for (const unsigned seed : { 3u, 21u, 77u })
  {
    const LabelImage<D> image = MakeRandomImage<D>(FirstExtents<D>({ 23, 19, 17 }), seed, 4, 8, 30);
    for (const bool bodyOnly : { false, true })
    {
      const std::vector<std::uint8_t> whole = Thin<D>(image, bodyOnly);
      for (const int ghosts : { 0, 2 })
      {
        std::vector<stm::VoxelBox<D>> ghostBoxes;
        std::int64_t ownThin = 0, ownThinWithoutJoins = 0;
        const auto pieces =
          ClassifyInPieces<D>(image, bodyOnly, cuts, ghosts, true, ghostBoxes, ownThin);
        const auto unjoined = ClassifyInPieces<D>(
          image, bodyOnly, cuts, ghosts, false, ghostBoxes, ownThinWithoutJoins);
        ASSERT_EQ(pieces.size(), 3 * 2 + 1u);
        for (std::size_t p = 0; p < pieces.size(); ++p)
        {
          std::vector<std::uint8_t> expected;
          ghostBoxes[p].ForEach([&](std::int64_t, const stm::LatticeIndex<D>& voxel)
            { expected.push_back(whole[stm::LinearIndex<D>(voxel, image.GetDimensions())]); });
          EXPECT_EQ(pieces[p], expected) << "seed " << seed << ", body only " << bodyOnly
                                         << ", ghosts " << ghosts << ", piece " << p;
          for (std::size_t v = 0; v < expected.size(); ++v)
          {
            differencesWithoutJoins += unjoined[p][v] != expected[v] ? 1 : 0;
          }
        }
        EXPECT_EQ(ownThin, Count<D>(whole));
      }
    }
  }
  EXPECT_GT(differencesWithoutJoins, 0);
}

TEST(ThinParts, PiecesRejectBoxesThatDoNotFit)
{
  stm::SequentialExecutor executor;
  LabelImage<2> image(stm::LatticeIndex<2>{ 8, 8 });
  stm::VoxelBox<2> owned{ { 0, 0 }, { 4, 8 } };
  stm::VoxelBox<2> read{ { 0, 0 }, { 4, 8 } }; // not grown by a voxel towards the other piece
  stm::ThinPartPiece<2> piece;
  const LabelImage<2> crop = CropImage<2>(image, read);
  EXPECT_FALSE(
    piece.Classify(crop.View(), read, owned, image.GetDimensions(), false, 0, executor).IsOk());
  read.Upper[0] = 5;
  EXPECT_FALSE(piece.Classify(crop.View(), read, owned, image.GetDimensions(), false, 0, executor)
                 .IsOk()); // the image is not the box's size
  const LabelImage<2> grown = CropImage<2>(image, read);
  ASSERT_TRUE(
    piece.Classify(grown.View(), read, owned, image.GetDimensions(), false, 0, executor).IsOk());
  const stm::VoxelBox<2> notOwn{ { 4, 0 }, { 5, 8 } };
  EXPECT_FALSE(piece.Join(1, notOwn, std::vector<std::int32_t>(8, 0)).IsOk());
  const stm::VoxelBox<2> own{ { 3, 0 }, { 4, 8 } };
  EXPECT_FALSE(piece.Join(1, own, std::vector<std::int32_t>(7, 0)).IsOk());
  std::vector<std::uint8_t> thin;
  EXPECT_FALSE(piece.Finish(std::vector<std::int64_t>(3, 0), thin, executor).IsOk());
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
