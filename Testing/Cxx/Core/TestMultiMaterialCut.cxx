// SPDX-License-Identifier: BSD-3-Clause
// The multi-material cut in 2D and 3D: the corner fractions of a tessellation are the voxel
// indicators interpolated d-linearly; two materials give exactly the binary cut of the labels
// function; the synthetic cases (three blocks along a line, four materials at a point, a
// thin shell between two materials, a checkerboard of 27 labels) give valid conforming meshes in
// which every material keeps its voxels' connected components and, within a stated bound, their
// volume; the result does not depend on the number of threads; bad input is refused.

#include "CoreTestUtilities.h"
#include "MemoryPieces.h"

#include "Check/SimplexQuality.h"
#include "Cut/MultiMaterialCut.h"
#include "Cut/SeparatingFunction.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <numeric>
#include <set>
#include <thread>
#include <vector>

namespace
{
using namespace stmtest;

/// A tessellated label image with the materials as peeling indices: the body labels ascending,
/// the background last.
template <int D>
struct LabelledMesh
{
  SimplicialMesh<D> Mesh;
  std::vector<std::int64_t> Labels; // per material index
  std::vector<std::int32_t> CellMaterials;
  std::vector<double> Points3; // three coordinates per point, lattice units

  int GetNumberOfMaterials() const { return static_cast<int>(this->Labels.size()); }
};

template <int D>
LabelledMesh<D> Tessellate(const LabelImage<D>& image, std::int64_t maxCellSize)
{
  LabelledMesh<D> result;
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  EXPECT_TRUE(BuildTree<D>(image, maxCellSize, 1, false, executor, tree).IsOk());
  stm::SpacetreeTessellationOptions options;
  options.IncludeBackground = true;
  EXPECT_TRUE(TessellateTree<D>(tree, options, executor, result.Mesh).IsOk());
  std::set<std::int64_t> labels(result.Mesh.Materials.begin(), result.Mesh.Materials.end());
  for (const std::int64_t label : labels)
  {
    if (label != stm::BackgroundMaterial)
    {
      result.Labels.push_back(label);
    }
  }
  if (labels.count(stm::BackgroundMaterial) != 0)
  {
    result.Labels.push_back(stm::BackgroundMaterial);
  }
  for (const stm::MaterialIndex label : result.Mesh.Materials)
  {
    result.CellMaterials.push_back(static_cast<std::int32_t>(
      std::find(result.Labels.begin(), result.Labels.end(), label) - result.Labels.begin()));
  }
  const std::vector<double> coordinates = result.Mesh.Coordinates();
  for (std::int64_t p = 0; p < result.Mesh.GetNumberOfPoints(); ++p)
  {
    for (int axis = 0; axis < 3; ++axis)
    {
      result.Points3.push_back(axis < D ? coordinates[p * D + axis] : 0.0);
    }
  }
  return result;
}

template <int D, class Executor>
stm::MaterialFractions Fractions(const LabelledMesh<D>& labelled, Executor& executor)
{
  stm::MaterialFractions fractions;
  EXPECT_TRUE(stm::CornerFractions<D>(labelled.Points3.data(), labelled.Mesh.GetNumberOfPoints(),
    labelled.Mesh.Connectivity.data(), labelled.Mesh.GetNumberOfSimplices(),
    labelled.CellMaterials.data(), labelled.GetNumberOfMaterials(),
    labelled.Labels.back() == stm::BackgroundMaterial ? labelled.GetNumberOfMaterials() - 1 : -1,
    fractions, executor)
                .IsOk());
  return fractions;
}

/// The cut mesh: points (D coordinates each, placed along their edges in order), cells and
/// their labels.
template <int D>
struct CutMesh
{
  std::vector<double> Points;
  std::vector<std::int64_t> Cells;
  std::vector<std::int64_t> Labels;
  stm::MultiMaterialCutCounts Counts;
};

/// The cut, with the quality-driven snap before each step when `snap`.
template <int D, class Executor>
CutMesh<D> Cut(const LabelledMesh<D>& labelled, Executor& executor, bool snap = false,
  bool stepsSideBySide = true)
{
  stm::MultiMaterialCut<D> cut;
  stm::MultiMaterialCutOptions options;
  options.SnapVertices = snap;
  options.StepsSideBySide = stepsSideBySide;
  const std::vector<double> coordinates = labelled.Mesh.Coordinates();
  EXPECT_TRUE(cut
                .Run(labelled.Mesh.GetNumberOfPoints(), snap ? coordinates.data() : nullptr,
                  labelled.Mesh.Connectivity.data(), labelled.Mesh.GetNumberOfSimplices(),
                  labelled.CellMaterials.data(), labelled.GetNumberOfMaterials(),
                  Fractions<D>(labelled, executor), options, executor)
                .IsOk());
  CutMesh<D> result;
  result.Points = coordinates;
  for (const stm::CutEdge& edge : cut.GetAddedPoints())
  {
    EXPECT_LT(edge.A, static_cast<std::int64_t>(result.Points.size() / D));
    EXPECT_LT(edge.B, static_cast<std::int64_t>(result.Points.size() / D));
    for (int axis = 0; axis < D; ++axis)
    {
      result.Points.push_back((1.0 - edge.T) * result.Points[edge.A * D + axis] +
        edge.T * result.Points[edge.B * D + axis]);
    }
  }
  if (snap)
  {
    // Snapped points moved, and cut points were placed between moved points.
    result.Points = cut.GetPoints();
  }
  result.Cells = cut.GetCells();
  for (const std::int32_t material : cut.GetCellMaterials())
  {
    result.Labels.push_back(labelled.Labels[material]);
  }
  result.Counts = cut.GetCounts();
  return result;
}

/// Checks a case: a valid conforming mesh, the voxels' components of every label, and every
/// body label's volume within `relativeVolume` of its voxels' (the background's mesh extends
/// beyond the image). Returns the cut mesh and its report.
template <int D>
CutMesh<D> CheckCase(const LabelImage<D>& image, std::int64_t maxCellSize, double relativeVolume,
  stm::MeshInvariantReport& report, bool snap = false)
{
  const LabelledMesh<D> labelled = Tessellate<D>(image, maxCellSize);
  stm::SequentialExecutor executor;
  CutMesh<D> cut = Cut<D>(labelled, executor, snap);
  report = stm::CheckSimplicialMesh<D>(cut.Points, cut.Cells, &cut.Labels);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_EQ(CellComponents<D>(cut.Cells, cut.Labels), VoxelComponents<D>(image));
  for (const std::int64_t label : labelled.Labels)
  {
    if (label == stm::BackgroundMaterial)
    {
      continue;
    }
    const double voxels =
      static_cast<double>(image.CountVoxels(static_cast<stm::MaterialIndex>(label)));
    EXPECT_NEAR(report.VolumePerMaterial.at(label), voxels, relativeVolume * voxels)
      << "label " << label;
  }
  return cut;
}

template <int D>
bool OnBorder(const stm::LatticeIndex<D>& voxel, std::int64_t extent)
{
  for (int axis = 0; axis < D; ++axis)
  {
    if (voxel[axis] == 0 || voxel[axis] == extent - 1)
    {
      return true;
    }
  }
  return false;
}

template <class T>
class MultiMaterialCutTest : public ::testing::Test
{
};
using CutDimensions = ::testing::Types<Dim<2>, Dim<3>>;
TYPED_TEST_SUITE(MultiMaterialCutTest, CutDimensions);

TYPED_TEST(MultiMaterialCutTest, CornerFractionsInterpolateTheVoxelIndicators)
{
  constexpr int D = TypeParam::value;
  LabelImage<D> image = MakeRandomImage<D>(FirstExtents<D>({ 13, 11, 9 }), 7, 4, 6, 40);
  const LabelledMesh<D> labelled = Tessellate<D>(image, 4);
  stm::SequentialExecutor executor;
  const stm::MaterialFractions fractions = Fractions<D>(labelled, executor);
  ASSERT_EQ(fractions.GetNumberOfPoints(), labelled.Mesh.GetNumberOfPoints());
  const std::vector<double> coordinates = labelled.Mesh.Coordinates();
  std::int64_t compared = 0;
  for (int material = 0; material < labelled.GetNumberOfMaterials(); ++material)
  {
    std::vector<double> indicator(image.GetValues().size());
    for (std::size_t v = 0; v < indicator.size(); ++v)
    {
      indicator[v] = image.GetValues()[v] == labelled.Labels[material] ? 1.0 : 0.0;
    }
    stm::VoxelField<D, double> field{ image.GetDimensions(), indicator.data(), 0.0 };
    for (std::int64_t p = 0; p < labelled.Mesh.GetNumberOfPoints(); ++p)
    {
      bool interior = true;
      for (int axis = 0; axis < D; ++axis)
      {
        const double x = coordinates[p * D + axis];
        interior = interior && x > 0.0 && x < static_cast<double>(image.GetDimensions()[axis]);
      }
      if (!interior)
      {
        continue;
      }
      ++compared;
      ASSERT_NEAR(fractions.Of(p, material), field.Sample(coordinates.data() + p * D), 1e-12)
        << "point " << p << ", material " << material;
    }
  }
  EXPECT_GT(compared, D == 2 ? 200 : 1000);
  // Rows are sorted and sum to 1.
  for (std::int64_t p = 0; p < fractions.GetNumberOfPoints(); ++p)
  {
    double sum = 0.0;
    for (std::int64_t e = fractions.Begins[p]; e < fractions.Ends[p]; ++e)
    {
      sum += fractions.Values[e];
      EXPECT_TRUE(e == fractions.Begins[p] || fractions.Materials[e - 1] < fractions.Materials[e]);
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
  }
}

TYPED_TEST(MultiMaterialCutTest, TwoMaterialsGiveTheBinaryCutOfTheLabelsFunction)
{
  constexpr int D = TypeParam::value;
  LabelImage<D> image = MakeRandomImage<D>(FirstExtents<D>({ 14, 12, 10 }), 3, 1, 5, 30);
  const LabelledMesh<D> labelled = Tessellate<D>(image, 4);
  ASSERT_EQ(labelled.GetNumberOfMaterials(), 2);
  stm::SequentialExecutor executor;
  const CutMesh<D> multi = Cut<D>(labelled, executor);

  // The binary cut of the labels function (body indicator -1 / +1, interpolated), ties inside
  // a body cell.
  std::vector<double> body(image.GetValues().size());
  for (std::size_t v = 0; v < body.size(); ++v)
  {
    body[v] = image.GetValues()[v] == stm::BackgroundMaterial ? 1.0 : -1.0;
  }
  const stm::VoxelField<D, double> field{ image.GetDimensions(), body.data(), 1.0 };
  const std::vector<double> coordinates = labelled.Mesh.Coordinates();
  std::vector<double> values;
  for (std::int64_t p = 0; p < labelled.Mesh.GetNumberOfPoints(); ++p)
  {
    values.push_back(field.Sample(coordinates.data() + p * D));
  }
  stm::MarchingSimplices<D> binary;
  stm::MarchingSimplicesOptions options;
  options.ZeroTolerance = 1e-9;
  ASSERT_TRUE(binary
                .Classify(
                  values.data(), labelled.Mesh.GetNumberOfPoints(),
                  labelled.Mesh.Connectivity.data(), labelled.Mesh.GetNumberOfSimplices(), options,
                  [&](std::int64_t cell)
                  {
                    return labelled.Mesh.Materials[cell] == stm::BackgroundMaterial
                      ? stm::CutSide::Outside
                      : stm::CutSide::Inside;
                  },
                  executor)
                .IsOk());
  ASSERT_GT(binary.GetNumberOfSplitCells(), 0);
  EXPECT_EQ(multi.Counts.SplitCells, binary.GetNumberOfSplitCells());
  EXPECT_EQ(multi.Counts.SplitAssignedCells, 0);
  ASSERT_EQ(static_cast<std::int64_t>(multi.Labels.size()), binary.GetNumberOfCells());
  ASSERT_EQ(multi.Counts.AddedPoints, static_cast<std::int64_t>(binary.GetCutEdges().size()));
  std::vector<std::int64_t> cells(static_cast<std::size_t>(binary.GetNumberOfCells() * (D + 1)));
  std::vector<std::int64_t> parents(static_cast<std::size_t>(binary.GetNumberOfCells()));
  std::vector<std::uint8_t> sides(parents.size());
  ASSERT_TRUE(binary
                .WriteCells(labelled.Mesh.Connectivity.data(), cells.data(), parents.data(),
                  sides.data(), executor)
                .IsOk());
  std::vector<std::int64_t> binaryLabels;
  for (const std::uint8_t side : sides)
  {
    binaryLabels.push_back(side == 0 ? labelled.Labels[0] : stm::BackgroundMaterial);
  }
  std::vector<double> binaryPoints = coordinates;
  for (const stm::CutEdge& edge : binary.GetCutEdges())
  {
    for (int axis = 0; axis < D; ++axis)
    {
      binaryPoints.push_back(
        (1.0 - edge.T) * coordinates[edge.A * D + axis] + edge.T * coordinates[edge.B * D + axis]);
    }
  }
  const stm::MeshInvariantReport expected =
    stm::CheckSimplicialMesh<D>(binaryPoints, cells, &binaryLabels);
  const stm::MeshInvariantReport actual =
    stm::CheckSimplicialMesh<D>(multi.Points, multi.Cells, &multi.Labels);
  ASSERT_TRUE(actual.IsValid()) << actual.Summary();
  for (const auto& entry : expected.VolumePerMaterial)
  {
    EXPECT_NEAR(actual.VolumePerMaterial.at(entry.first), entry.second, 1e-9 * entry.second);
  }
}

/// 2D: three materials meeting at a point; 3D: four (the fourth above the middle), in a
/// background border.
template <int D>
LabelImage<D> MeetingAtAPoint(std::int64_t extent)
{
  const std::int64_t s = extent / 2;
  LabelImage<D> image(UniformExtents<D>(extent));
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      stm::MaterialIndex material = voxel[0] < s ? 1 : voxel[1] < s ? 2 : 3;
      material = D == 3 && material == 3 && voxel[D - 1] >= s ? 4 : material;
      image.Set(voxel, OnBorder<D>(voxel, extent) ? 0 : material);
    });
  return image;
}

// Where a material holds half of a junction's voxels and two others a quarter each (the
// blocks' edges on the background border), the half material wins the junction line: its
// region reaches 1/3 voxel into the others along the line (on the edge between two voxel
// corners its fraction falls from 1/2 to 0 while theirs rise from 1/4 to 1/2). The blocks lose
// about 1/6 voxel of volume per unit length of such lines, which sets the volume bounds below.
TYPED_TEST(MultiMaterialCutTest, MaterialsMeetingAtAPoint)
{
  // 2D: three materials at a point; 3D: four (the fourth above the middle), in a background
  // border.
  constexpr int D = TypeParam::value;
  const LabelImage<D> image = MeetingAtAPoint<D>(16);
  stm::MeshInvariantReport report;
  const CutMesh<D> cut = CheckCase<D>(image, 4, 0.07, report);
  EXPECT_GT(cut.Counts.SplitCells, 0);
  EXPECT_GT(cut.Counts.SplitAssignedCells, 0);
}

TEST(MultiMaterialCut, ThreeBlocksAlongALine)
{
  constexpr int D = 3;
  const std::int64_t extent = 14, s = extent / 2;
  LabelImage<D> image(UniformExtents<D>(extent));
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      const stm::MaterialIndex material = voxel[0] < s ? 1 : voxel[1] < s ? 2 : 3;
      image.Set(voxel, OnBorder<D>(voxel, extent) ? 0 : material);
    });
  stm::MeshInvariantReport report;
  CheckCase<D>(image, 4, 0.07, report);
}

TYPED_TEST(MultiMaterialCutTest, ThinShellBetweenTwoMaterials)
{
  // A ball of material 1 in a shell of material 2 one voxel thick (the voxels that touch the
  // ball, through a face, an edge or a corner), in material 3, in a background border.
  constexpr int D = TypeParam::value;
  const std::int64_t extent = D == 2 ? 40 : 24;
  const double centre = 0.5 * static_cast<double>(extent);
  const double radius = 0.3 * static_cast<double>(extent);
  LabelImage<D> image(UniformExtents<D>(extent));
  auto inBall = [&](const stm::LatticeIndex<D>& voxel)
  {
    double squared = 0.0;
    for (int axis = 0; axis < D; ++axis)
    {
      const double x = static_cast<double>(voxel[axis]) + 0.5 - centre;
      squared += x * x;
    }
    return squared < radius * radius;
  };
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      stm::MaterialIndex material = 3;
      if (inBall(voxel))
      {
        material = 1;
      }
      else
      {
        stm::LatticeIndex<D> lower = voxel, upper = voxel;
        for (int axis = 0; axis < D; ++axis)
        {
          lower[axis] -= 1;
          upper[axis] += 2;
        }
        ForEachIndexInBox<D>(lower, upper,
          [&](const stm::LatticeIndex<D>& next) { material = inBall(next) ? 2 : material; });
      }
      image.Set(voxel, OnBorder<D>(voxel, extent) ? 0 : material);
    });
  stm::MeshInvariantReport report;
  CheckCase<D>(image, 4, 0.1, report);
}

TEST(MultiMaterialCut, CheckerboardOf27Labels)
{
  // 3 x 3 x 3 blocks of 3^3 voxels, labels 1 to 27, in a background border. The middle block
  // meets other blocks only, at four-way ties along its edges, so it keeps its exact volume.
  constexpr int D = 3;
  const std::int64_t block = 3, extent = 3 * block + 2;
  LabelImage<D> image(UniformExtents<D>(extent));
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      if (OnBorder<D>(voxel, extent))
      {
        return;
      }
      const auto index = [&](int axis) { return (voxel[axis] - 1) / block; };
      image.Set(voxel, static_cast<stm::MaterialIndex>(1 + index(0) + 3 * index(1) + 9 * index(2)));
    });
  stm::MeshInvariantReport report;
  const CutMesh<D> cut = CheckCase<D>(image, 2, 0.3, report);
  EXPECT_EQ(report.VolumePerMaterial.size(), 28u);
  EXPECT_NEAR(report.VolumePerMaterial.at(14), 27.0, 1e-9);
  EXPECT_GT(cut.Counts.SplitAssignedCells, 0);
}

TYPED_TEST(MultiMaterialCutTest, SameResultOnAnyNumberOfThreads)
{
  constexpr int D = TypeParam::value;
  LabelImage<D> image = MakeRandomImage<D>(FirstExtents<D>({ 17, 15, 13 }), 11, 6, 8, 60);
  const LabelledMesh<D> labelled = Tessellate<D>(image, 4);
  stm::SequentialExecutor sequential;
  const CutMesh<D> reference = Cut<D>(labelled, sequential);
  const stm::MeshInvariantReport report =
    stm::CheckSimplicialMesh<D>(reference.Points, reference.Cells, &reference.Labels);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_GT(reference.Counts.SplitAssignedCells, 0);
  for (const int threads : { 2, 3 })
  {
    stm::ThreadPoolExecutor pool(threads);
    const CutMesh<D> other = Cut<D>(labelled, pool);
    EXPECT_EQ(other.Cells, reference.Cells) << threads << " threads";
    EXPECT_EQ(other.Labels, reference.Labels) << threads << " threads";
    EXPECT_EQ(other.Points, reference.Points) << threads << " threads";
  }
}

// Steps whose points are disjoint (labels that do not touch) are computed side by side and
// applied in order: the result is that of the steps one at a time, bit for bit, with and
// without snapping and on any number of threads.
TYPED_TEST(MultiMaterialCutTest, StepsSideBySideGiveTheResultOfOneAtATime)
{
  constexpr int D = TypeParam::value;
  // Labels 1 to 4 in boxes six voxels apart and from the border (disjoint steps), 5 and 6
  // touching each other and 4.
  const std::int64_t extent = 29;
  LabelImage<D> image(UniformExtents<D>(extent));
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      const std::int64_t x = voxel[0], y = voxel[1];
      const bool low = y >= 6 && y < 10, high = y >= 16 && y < 20;
      stm::MaterialIndex label = 0;
      if (low && x >= 6 && x < 10)
      {
        label = 1;
      }
      else if (low && x >= 16 && x < 20)
      {
        label = 2;
      }
      else if (high && x >= 6 && x < 10)
      {
        label = 3;
      }
      else if (high && x >= 16 && x < 20)
      {
        label = 4;
      }
      else if (high && x >= 20 && x < 22)
      {
        label = 5;
      }
      else if (y >= 12 && y < 20 && x >= 22 && x < 24)
      {
        label = 6;
      }
      if (label != 0 && (D < 3 || (voxel[D - 1] >= 6 && voxel[D - 1] < 20)))
      {
        image.Set(voxel, label);
      }
    });
  // Leaves of at most 2 voxels: a step's cells reach at most that far from its label.
  const LabelledMesh<D> labelled = Tessellate<D>(image, 2);
  ASSERT_EQ(labelled.GetNumberOfMaterials(), 7);
  for (const bool snap : { false, true })
  {
    stm::SequentialExecutor sequential;
    const CutMesh<D> oneAtATime = Cut<D>(labelled, sequential, snap, false);
    EXPECT_EQ(oneAtATime.Counts.SideBySideSteps, 0);
    const stm::MeshInvariantReport report =
      stm::CheckSimplicialMesh<D>(oneAtATime.Points, oneAtATime.Cells, &oneAtATime.Labels);
    EXPECT_TRUE(report.IsValid()) << report.Summary();
    for (const int threads : { 1, 2, 3 })
    {
      stm::ThreadPoolExecutor pool(threads);
      const CutMesh<D> batched = Cut<D>(labelled, pool, snap, true);
      // Steps 0 to 3 (labels 1 to 4) in one batch; 4 (label 5, touching 4) starts the next.
      EXPECT_EQ(batched.Counts.SideBySideSteps, 4) << threads << " threads";
      EXPECT_EQ(batched.Counts.Steps, oneAtATime.Counts.Steps);
      EXPECT_EQ(batched.Counts.SnappedPoints, oneAtATime.Counts.SnappedPoints);
      EXPECT_EQ(batched.Counts.AddedPoints, oneAtATime.Counts.AddedPoints);
      EXPECT_EQ(batched.Cells, oneAtATime.Cells) << threads << " threads, snap " << snap;
      EXPECT_EQ(batched.Labels, oneAtATime.Labels) << threads << " threads, snap " << snap;
      EXPECT_EQ(batched.Points, oneAtATime.Points) << threads << " threads, snap " << snap;
    }
  }
}

// Snapping before each step keeps the mesh valid and every component, moves only points that
// no assigned cell uses (earlier interfaces stay), and takes the worst element well below that
// of the plain cut, on any number of threads.
TYPED_TEST(MultiMaterialCutTest, SnappingKeepsValidityAndImprovesTheWorstElement)
{
  constexpr int D = TypeParam::value;
  LabelImage<D> image = MakeRandomImage<D>(FirstExtents<D>({ 17, 15, 13 }), 5, 4, 8, 0);
  const LabelledMesh<D> labelled = Tessellate<D>(image, 4);
  stm::SequentialExecutor executor;
  const CutMesh<D> plain = Cut<D>(labelled, executor, false);
  const CutMesh<D> snapped = Cut<D>(labelled, executor, true);
  const stm::MeshInvariantReport report =
    stm::CheckSimplicialMesh<D>(snapped.Points, snapped.Cells, &snapped.Labels);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_EQ(CellComponents<D>(snapped.Cells, snapped.Labels), VoxelComponents<D>(image));
  EXPECT_GT(snapped.Counts.SnappedPoints, 0);
  EXPECT_LT(snapped.Counts.AddedPoints, plain.Counts.AddedPoints);
  const double before = WorstSimplexCondition<D>(plain.Points, plain.Cells),
               after = WorstSimplexCondition<D>(snapped.Points, snapped.Cells);
  std::cout << "worst condition " << before << " -> " << after << ", "
            << snapped.Counts.SnappedPoints << " snaps\n";
  EXPECT_LT(after, 0.5 * before);
  stm::ThreadPoolExecutor pool(3);
  const CutMesh<D> threaded = Cut<D>(labelled, pool, true);
  EXPECT_EQ(threaded.Cells, snapped.Cells);
  EXPECT_EQ(threaded.Points, snapped.Points);
  // The synthetic cases with snapping: valid, every component, the volumes as without.
  stm::MeshInvariantReport caseReport;
  CheckCase<D>(MeetingAtAPoint<D>(16), 4, 0.07, caseReport, true);
}

// Pieces of a distributed mesh, each on its own thread with exchanges in memory: every piece
// cuts out the input cells whose centres lie in its slab along x, and `rings` rings of ghost
// cells around them (in the whole mesh's order, which the ties by point id need), computes its
// points' fractions from its own cells and ghost cells alone, as a rank does, and cuts with
// snapping.

/// The cut cells that lie in input cells with skipped[parent] == 0, each as its corners' places
/// sorted and its label: comparable between a piece and the whole mesh.
template <int D>
std::vector<std::vector<double>> CutCellKeys(const stm::MultiMaterialCut<D>& cut,
  const std::vector<std::int64_t>& labels, const std::vector<std::uint8_t>& skipped)
{
  std::vector<std::vector<double>> keys;
  const std::vector<double>& points = cut.GetPoints();
  const std::vector<std::int64_t>& cells = cut.GetCells();
  for (std::int64_t c = 0; c < cut.GetNumberOfCells(); ++c)
  {
    if (skipped[cut.GetCellParents()[c]])
    {
      continue;
    }
    std::vector<std::vector<double>> corners;
    for (int v = 0; v <= D; ++v)
    {
      const std::int64_t p = cells[c * (D + 1) + v];
      corners.emplace_back(points.begin() + p * D, points.begin() + (p + 1) * D);
    }
    std::sort(corners.begin(), corners.end());
    std::vector<double> key;
    for (const std::vector<double>& corner : corners)
    {
      key.insert(key.end(), corner.begin(), corner.end());
    }
    key.push_back(static_cast<double>(labels[cut.GetCellMaterials()[c]]));
    keys.push_back(std::move(key));
  }
  std::sort(keys.begin(), keys.end());
  return keys;
}

/// The whole mesh's cut cells that differ from the pieces' own cut cells (counted both ways),
/// and the held points no piece sent.
template <int D>
std::int64_t CountPieceCutDifferences(const LabelledMesh<D>& labelled, int pieces, int rings,
  bool exchange, std::int64_t& unmatched, std::int64_t& exchangedSteps)
{
  stm::SequentialExecutor executor;
  const std::vector<double> points = labelled.Mesh.Coordinates();
  const std::vector<std::int64_t>& cells = labelled.Mesh.Connectivity;
  const std::int64_t cellCount = labelled.Mesh.GetNumberOfSimplices();
  const int materials = labelled.GetNumberOfMaterials();
  stm::MultiMaterialCutOptions options;
  options.SnapVertices = true;
  stm::MultiMaterialCut<D> whole;
  EXPECT_TRUE(whole
                .Run(labelled.Mesh.GetNumberOfPoints(), points.data(), cells.data(), cellCount,
                  labelled.CellMaterials.data(), materials, Fractions<D>(labelled, executor),
                  options, executor)
                .IsOk());
  std::vector<std::vector<double>> expected =
    CutCellKeys<D>(whole, labelled.Labels, std::vector<std::uint8_t>(cellCount, 0));

  PieceHub hub(pieces);
  std::vector<std::vector<std::vector<double>>> found(static_cast<std::size_t>(pieces));
  std::vector<std::int64_t> unmatchedPerPiece(found.size(), 0), exchangedPerPiece(found.size(), 0);
  std::vector<std::thread> threads;
  for (int piece = 0; piece < pieces; ++piece)
  {
    threads.emplace_back(
      [&, piece]()
      {
        std::vector<std::uint8_t> own, kept;
        CutOutSlab<D>(points, cells, piece, pieces, rings, own, kept);
        const std::size_t pointCount = points.size() / D;
        std::vector<std::int64_t> local(pointCount, -1);
        for (std::int64_t c = 0; c < cellCount; ++c)
        {
          for (int v = 0; v <= D && kept[c]; ++v)
          {
            local[cells[c * (D + 1) + v]] = 0;
          }
        }
        std::vector<double> piecePoints, piecePoints3;
        std::int64_t pieceCount = 0;
        for (std::size_t p = 0; p < pointCount; ++p)
        {
          if (local[p] == 0)
          {
            local[p] = pieceCount++;
            piecePoints.insert(
              piecePoints.end(), points.begin() + p * D, points.begin() + (p + 1) * D);
            piecePoints3.insert(piecePoints3.end(), labelled.Points3.begin() + 3 * p,
              labelled.Points3.begin() + 3 * (p + 1));
          }
        }
        std::vector<std::int64_t> pieceCells;
        std::vector<std::int32_t> pieceMaterials;
        std::vector<std::uint8_t> ghosts;
        for (std::int64_t c = 0; c < cellCount; ++c)
        {
          if (kept[c])
          {
            for (int v = 0; v <= D; ++v)
            {
              pieceCells.push_back(local[cells[c * (D + 1) + v]]);
            }
            pieceMaterials.push_back(labelled.CellMaterials[c]);
            ghosts.push_back(own[c] ? 0 : 1);
          }
        }
        const auto pieceCellCount = static_cast<std::int64_t>(pieceMaterials.size());
        stm::SequentialExecutor pieceExecutor;
        stm::MaterialFractions fractions;
        EXPECT_TRUE(stm::CornerFractions<D>(piecePoints3.data(), pieceCount, pieceCells.data(),
          pieceCellCount, pieceMaterials.data(), materials, materials - 1, fractions, pieceExecutor)
                      .IsOk());
        MemoryStepExchanges<D> exchanges(hub, piece);
        stm::MultiMaterialCutOptions pieceOptions = options;
        pieceOptions.GhostCells = exchange ? ghosts.data() : nullptr;
        pieceOptions.Exchanges = exchange ? &exchanges : nullptr;
        stm::MultiMaterialCut<D> cut;
        const stm::Status status =
          cut.Run(pieceCount, piecePoints.data(), pieceCells.data(), pieceCellCount,
            pieceMaterials.data(), materials, std::move(fractions), pieceOptions, pieceExecutor);
        EXPECT_TRUE(status.IsOk()) << status.GetMessage();
        // The steps whose materials lie near a piece's border, those of every piece.
        EXPECT_EQ(exchanges.Steps,
          exchange ? std::count(exchanges.Flags.begin(), exchanges.Flags.end() - 1, 1) : 0);
        EXPECT_EQ(exchanges.Flags.size(), exchange ? static_cast<std::size_t>(materials) : 0);
        found[piece] = CutCellKeys<D>(cut, labelled.Labels, ghosts);
        unmatchedPerPiece[piece] = exchanges.GetUnmatched();
        exchangedPerPiece[piece] = exchanges.Steps;
      });
  }
  for (std::thread& thread : threads)
  {
    thread.join();
  }
  std::vector<std::vector<double>> all;
  unmatched = 0;
  for (int piece = 0; piece < pieces; ++piece)
  {
    all.insert(all.end(), found[piece].begin(), found[piece].end());
    unmatched += unmatchedPerPiece[piece];
    EXPECT_EQ(exchangedPerPiece[piece], exchangedPerPiece[0]);
  }
  exchangedSteps = exchangedPerPiece[0];
  std::sort(all.begin(), all.end());
  std::vector<std::vector<double>> onlyOne;
  std::set_symmetric_difference(
    all.begin(), all.end(), expected.begin(), expected.end(), std::back_inserter(onlyOne));
  return static_cast<std::int64_t>(onlyOne.size());
}

// Pieces with three rings of ghost cells whose steps' snaps exchange their states after every
// round cut their own cells as the whole mesh does, bit for bit (the corners' places and the
// materials), with 2 and 3 pieces; each piece makes every step, some without cells. Without the
// exchange the 3D pieces do not (76 cells differ): on boxes of labels, whose interfaces lie
// halfway between lattice planes, equal cut distances leave the snap's conflicts to the point
// ids, and those decisions chain further than three rings. Only the steps whose materials lie
// near a piece's border exchange: the same boxes moved to the high end of a longer image, with
// a box of another label at the low end, take that label's step alone. Held points at the far
// end of the ghost cells may go unmatched (their stars are not whole there, so a piece may not
// see them move); they are too far from the own cells to matter.
TYPED_TEST(MultiMaterialCutTest, PiecesThatExchangeCutAsTheWholeMesh)
{
  constexpr int D = TypeParam::value;
  std::int64_t differingWithout = 0, stepsAlone = 0;
  for (unsigned seed : { 5U, 6U })
  {
    const LabelImage<D> boxes =
      MakeRandomImage<D>(D == 2 ? FirstExtents<D>({ 61, 45, 1 }) : FirstExtents<D>({ 23, 15, 13 }),
        seed, 4, D == 2 ? 14 : 8, 0);
    stm::LatticeIndex<D> longer = boxes.GetDimensions();
    longer[0] = D == 2 ? 120 : 64;
    LabelImage<D> apart(longer);
    const LabelImage<D>* const cases[] = { &boxes, &apart };
    ForEachIndex<D>(boxes.GetDimensions(),
      [&](const stm::LatticeIndex<D>& voxel)
      {
        stm::LatticeIndex<D> shifted = voxel;
        shifted[0] += longer[0] - boxes.GetDimensions()[0];
        apart.Set(shifted, boxes.At(voxel));
      });
    ForEachIndexInBox<D>(FirstExtents<D>({ 2, 2, 2 }), FirstExtents<D>({ 5, 5, 5 }),
      [&](const stm::LatticeIndex<D>& voxel) { apart.Set(voxel, 5); });
    for (const LabelImage<D>* image : cases)
    {
      const LabelledMesh<D> labelled = Tessellate<D>(*image, 4);
      const std::int64_t steps = labelled.GetNumberOfMaterials() - 1;
      for (int pieces : { 2, 3 })
      {
        SCOPED_TRACE(::testing::Message()
          << "seed " << seed << ", pieces " << pieces << (image == &apart ? ", apart" : ""));
        std::int64_t unmatched = 0, exchanged = 0;
        EXPECT_EQ(CountPieceCutDifferences<D>(labelled, pieces, 3, true, unmatched, exchanged), 0);
        std::cout << D << "D, seed " << seed << (image == &apart ? ", apart, " : ", ") << pieces
                  << " pieces: " << exchanged << " of " << steps << " steps exchanged, "
                  << unmatched << " held points unmatched\n";
        EXPECT_GT(exchanged, 0);
        stepsAlone += steps - exchanged;
        if (image == &boxes)
        {
          differingWithout +=
            CountPieceCutDifferences<D>(labelled, pieces, 3, false, unmatched, exchanged);
        }
      }
    }
  }
  std::cout << D << "D: " << differingWithout
            << " cut cells differ from the whole mesh's without the exchange\n";
  // In 2D no chain of these cases reaches past three rings (seeds 5 to 8, two rings too).
  EXPECT_EQ(differingWithout > 0, D == 3);
  EXPECT_GT(stepsAlone, 0);
}

TEST(MultiMaterialCut, RejectsBadInput)
{
  constexpr int D = 2;
  const std::vector<std::int64_t> cells = { 0, 1, 2 };
  const std::vector<double> points = { 0, 0, 0, 1, 0, 0, 0, 1, 0 };
  const std::vector<std::int32_t> materials = { 0 };
  stm::SequentialExecutor executor;
  stm::MaterialFractions fractions;
  EXPECT_FALSE(stm::CornerFractions<D>(
    points.data(), 3, cells.data(), 1, materials.data(), 1, 1, fractions, executor)
                 .IsOk());
  const std::vector<std::int64_t> badCells = { 0, 1, 3 };
  EXPECT_FALSE(stm::CornerFractions<D>(
    points.data(), 3, badCells.data(), 1, materials.data(), 1, -1, fractions, executor)
                 .IsOk());
  const std::vector<std::int32_t> badMaterials = { 2 };
  EXPECT_FALSE(stm::CornerFractions<D>(
    points.data(), 3, cells.data(), 1, badMaterials.data(), 2, -1, fractions, executor)
                 .IsOk());
  std::vector<double> nanPoints = points;
  nanPoints[4] = std::nan("");
  EXPECT_FALSE(stm::CornerFractions<D>(
    nanPoints.data(), 3, cells.data(), 1, materials.data(), 1, -1, fractions, executor)
                 .IsOk());
  ASSERT_TRUE(stm::CornerFractions<D>(
    points.data(), 3, cells.data(), 1, materials.data(), 1, -1, fractions, executor)
                .IsOk());
  EXPECT_NEAR(fractions.Of(0, 0), 1.0, 1e-15);

  stm::MultiMaterialCut<D> cut;
  stm::MultiMaterialCutOptions options;
  EXPECT_TRUE(
    cut.Run(3, nullptr, cells.data(), 1, materials.data(), 1, fractions, options, executor).IsOk());
  EXPECT_EQ(cut.GetCellMaterials(), materials);
  EXPECT_FALSE(
    cut.Run(3, nullptr, cells.data(), 1, materials.data(), 0, fractions, options, executor).IsOk());
  EXPECT_FALSE(
    cut.Run(3, nullptr, badCells.data(), 1, materials.data(), 1, fractions, options, executor)
      .IsOk());
  EXPECT_FALSE(
    cut.Run(4, nullptr, cells.data(), 1, materials.data(), 1, fractions, options, executor).IsOk());
  stm::MaterialFractions nan = fractions;
  nan.Values[0] = std::nan("");
  EXPECT_FALSE(
    cut.Run(3, nullptr, cells.data(), 1, materials.data(), 1, nan, options, executor).IsOk());
  options.ZeroTolerance = -1.0;
  EXPECT_FALSE(
    cut.Run(3, nullptr, cells.data(), 1, materials.data(), 1, fractions, options, executor).IsOk());
}

TEST(MultiMaterialCut, OneAndFourDimensions)
{
  // 1D: fractions are shares of the two directions; 4D: the peeling, from fractions given by
  // hand, on the Kuhn simplices of a tesseract split at x0 = 1/2 between two materials.
  {
    const std::vector<std::int64_t> cells = { 0, 1, 1, 2, 2, 3 };
    const std::vector<double> points = { 0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0 };
    const std::vector<std::int32_t> materials = { 0, 1, 1 };
    stm::SequentialExecutor executor;
    stm::MaterialFractions fractions;
    ASSERT_TRUE(stm::CornerFractions<1>(
      points.data(), 4, cells.data(), 3, materials.data(), 2, 1, fractions, executor)
                  .IsOk());
    EXPECT_DOUBLE_EQ(fractions.Of(0, 0), 0.5); // the other half is the outside material
    EXPECT_DOUBLE_EQ(fractions.Of(0, 1), 0.5);
    EXPECT_DOUBLE_EQ(fractions.Of(1, 0), 0.5);
    EXPECT_DOUBLE_EQ(fractions.Of(2, 1), 1.0);
    stm::MultiMaterialCut<1> cut;
    ASSERT_TRUE(cut
                  .Run(4, nullptr, cells.data(), 3, materials.data(), 2, fractions,
                    stm::MultiMaterialCutOptions(), executor)
                  .IsOk());
    // Point 0 ties and point 1 ties: the first cell is a tie cell and keeps material 0.
    EXPECT_EQ(cut.GetCellMaterials(), (std::vector<std::int32_t>{ 0, 1, 1 }));
  }
  {
    constexpr int D = 4;
    std::vector<std::int64_t> cells;
    std::vector<std::int32_t> materials;
    // Kuhn simplices: the paths through the 16 corners (bit a of a corner id is axis a).
    std::array<int, D> order = { 0, 1, 2, 3 };
    do
    {
      int corner = 0;
      const std::size_t first = cells.size();
      cells.push_back(corner);
      for (const int axis : order)
      {
        corner |= 1 << axis;
        cells.push_back(corner);
      }
      // Odd permutations give negatively oriented simplices.
      int inversions = 0;
      for (int i = 0; i < D; ++i)
      {
        for (int j = i + 1; j < D; ++j)
        {
          inversions += order[i] > order[j] ? 1 : 0;
        }
      }
      if (inversions % 2 == 1)
      {
        std::swap(cells[first], cells[first + 1]);
      }
      materials.push_back(0);
    } while (std::next_permutation(order.begin(), order.end()));
    stm::MaterialFractions fractions;
    for (int corner = 0; corner < 16; ++corner)
    {
      // Material 0 dominates at x0 = 0 (3/4), material 1 at x0 = 1 (3/4).
      fractions.Begins.push_back(static_cast<std::int64_t>(fractions.Materials.size()));
      fractions.Materials.insert(fractions.Materials.end(), { 0, 1 });
      fractions.Values.insert(
        fractions.Values.end(), { corner & 1 ? 0.25 : 0.75, corner & 1 ? 0.75 : 0.25 });
      fractions.Ends.push_back(static_cast<std::int64_t>(fractions.Materials.size()));
    }
    stm::SequentialExecutor executor;
    stm::MultiMaterialCut<D> cut;
    ASSERT_TRUE(cut
                  .Run(16, nullptr, cells.data(), 24, materials.data(), 2, fractions,
                    stm::MultiMaterialCutOptions(), executor)
                  .IsOk());
    // Every edge from a corner with x0 = 0 to one with x0 = 1 is cut at its middle: the pairs
    // of corners c < c' (as bit sets) that differ in bit 0, 3^3 of them; every simplex is split.
    EXPECT_EQ(cut.GetCounts().AddedPoints, 27);
    EXPECT_EQ(cut.GetCounts().SplitCells, 24);
    std::vector<double> coordinates;
    for (int corner = 0; corner < 16; ++corner)
    {
      for (int axis = 0; axis < D; ++axis)
      {
        coordinates.push_back((corner >> axis) & 1);
      }
    }
    for (const stm::CutEdge& edge : cut.GetAddedPoints())
    {
      EXPECT_DOUBLE_EQ(edge.T, 0.5);
      for (int axis = 0; axis < D; ++axis)
      {
        coordinates.push_back(
          0.5 * (coordinates[edge.A * D + axis] + coordinates[edge.B * D + axis]));
      }
    }
    std::vector<std::int64_t> labels(cut.GetCellMaterials().begin(), cut.GetCellMaterials().end());
    const stm::MeshInvariantReport report =
      stm::CheckSimplicialMesh<D>(coordinates, cut.GetCells(), &labels);
    EXPECT_TRUE(report.IsValid()) << report.Summary();
    EXPECT_NEAR(report.VolumePerMaterial.at(0), 0.5, 1e-12);
    EXPECT_NEAR(report.VolumePerMaterial.at(1), 0.5, 1e-12);
  }
}

} // namespace
