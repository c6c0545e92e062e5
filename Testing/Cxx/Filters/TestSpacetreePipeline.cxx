// SPDX-License-Identifier: BSD-3-Clause
// The three filters end to end, in 2D and 3D, unbalanced and at L = 1, 2, 3, on synthetic images
// and on the real AAL atlas: conformity, positive volumes, closed boundaries, exact volume per
// label, balance, file round trips, thread-count determinism and bad input.

#include "stmFilterTestUtilities.h"
#include "stmVerdictQuality.h"

#include "vtkCallbackCommand.h"
#include "vtkCommand.h"
#include "vtkDoubleArray.h"
#include "vtkExecutive.h"
#include "vtkExtractVOI.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkIntArray.h"
#include "vtkMatrix3x3.h"
#include "vtkNIFTIImageReader.h"
#include "vtkPolyData.h"
#include "vtkSMPTools.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGridReader.h"
#include "vtkUnstructuredGridWriter.h"
#include "vtkXMLUnstructuredGridReader.h"
#include "vtkXMLUnstructuredGridWriter.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <set>
#include <string>

namespace
{
const char* const AalPath = "/usr/share/mricron/templates/aal.nii.gz";

using stmTest::ErrorRecorder;

/// Largest |level difference| between leaves sharing at least a vertex, computed by brute force
/// on a lattice rasterisation of the spacetree output (independent of the core's balancer).
int MaxNeighbourLevelDifference(vtkUnstructuredGrid* tree, bool facetsOnly)
{
  vtkFieldData* fd = tree->GetFieldData();
  const int dim = static_cast<int>(fd->GetArray("SpacetreeDimension")->GetComponent(0, 0));
  // Cell edges per level and axis, in lattice units, root first.
  vtkDataArray* cellSizes = fd->GetArray("SpacetreeCellSizes");
  auto edge = [&](int l, int a)
  { return static_cast<int>(cellSizes->GetComponent(l * dim + a, 0)); };
  int dims[3] = { 1, 1, 1 };
  for (int a = 0; a < dim; ++a)
  {
    dims[a] = static_cast<int>(fd->GetArray("SpacetreeRootGridDimensions")->GetComponent(a, 0)) *
      edge(0, a);
  }
  std::vector<int> level(static_cast<std::size_t>(dims[0]) * dims[1] * dims[2], -1);
  vtkDataArray* levels = tree->GetCellData()->GetArray("Level");
  vtkDataArray* indices = tree->GetCellData()->GetArray("LatticeIndex");
  for (vtkIdType c = 0; c < tree->GetNumberOfCells(); ++c)
  {
    const int l = static_cast<int>(levels->GetComponent(c, 0));
    int lo[3] = { 0, 0, 0 }, hi[3] = { 1, 1, 1 };
    for (int a = 0; a < dim; ++a)
    {
      lo[a] = static_cast<int>(indices->GetComponent(c, a)) * edge(l, a);
      hi[a] = lo[a] + edge(l, a);
    }
    for (int k = lo[2]; k < hi[2]; ++k)
      for (int j = lo[1]; j < hi[1]; ++j)
        for (int i = lo[0]; i < hi[0]; ++i)
        {
          level[(static_cast<std::size_t>(k) * dims[1] + j) * dims[0] + i] = l;
        }
  }
  int worst = 0;
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i)
      {
        const int here = level[(static_cast<std::size_t>(k) * dims[1] + j) * dims[0] + i];
        EXPECT_GE(here, 0) << "lattice cell not covered by a leaf";
        for (int dk = (dim == 3 ? -1 : 0); dk <= (dim == 3 ? 1 : 0); ++dk)
          for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di)
            {
              const int nonZero = (di != 0) + (dj != 0) + (dk != 0);
              if (nonZero == 0 || (facetsOnly && nonZero != 1))
              {
                continue;
              }
              const int ni = i + di, nj = j + dj, nk = k + dk;
              if (ni < 0 || nj < 0 || nk < 0 || ni >= dims[0] || nj >= dims[1] || nk >= dims[2])
              {
                continue;
              }
              const int there = level[(static_cast<std::size_t>(nk) * dims[1] + nj) * dims[0] + ni];
              worst = std::max(worst, std::abs(here - there));
            }
      }
  return worst;
}

/// Exact area (length in 2D) of the boundary of the voxel model of the body (all non-zero
/// labels): faces between a body voxel and a non-body voxel or the image border.
double VoxelBoundaryMeasure(vtkImageData* image, int dim, const double spacing[3])
{
  int dims[3];
  image->GetDimensions(dims);
  vtkDataArray* labels = image->GetPointData()->GetScalars();
  auto body = [&](int i, int j, int k)
  {
    if (i < 0 || j < 0 || k < 0 || i >= dims[0] || j >= dims[1] || k >= dims[2])
    {
      return false;
    }
    return labels->GetComponent((static_cast<vtkIdType>(k) * dims[1] + j) * dims[0] + i, 0) != 0;
  };
  const double faceMeasure[3] = { dim == 3 ? spacing[1] * spacing[2] : spacing[1],
    dim == 3 ? spacing[0] * spacing[2] : spacing[0], spacing[0] * spacing[1] };
  double measure = 0;
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i)
      {
        if (!body(i, j, k))
        {
          continue;
        }
        measure += (!body(i - 1, j, k) + !body(i + 1, j, k)) * faceMeasure[0];
        measure += (!body(i, j - 1, k) + !body(i, j + 1, k)) * faceMeasure[1];
        if (dim == 3)
        {
          measure += (!body(i, j, k - 1) + !body(i, j, k + 1)) * faceMeasure[2];
        }
      }
  return measure;
}

struct Case
{
  int Dimension;
  int BalanceLevel; // 0: unbalanced
  int CellTemplate;
};

std::string CaseName(const ::testing::TestParamInfo<Case>& info)
{
  return std::to_string(info.param.Dimension) + "D_L" + std::to_string(info.param.BalanceLevel) +
    (info.param.CellTemplate == 0 ? "_Checkerboard" : "_Kuhn");
}

class SyntheticPipeline : public ::testing::TestWithParam<Case>
{
};

TEST_P(SyntheticPipeline, ValidExactMesh)
{
  const Case c = GetParam();
  const int dims[3] = { 37, 29, c.Dimension == 3 ? 23 : 1 };
  const double spacing[3] = { 0.5, 0.75, 1.25 };
  const double origin[3] = { -3.0, 2.0, 7.5 };
  auto image = stmTest::MakeLabelImage(dims, spacing, origin,
    [&](int i, int j, int k) { return stmTest::NestedEllipsoids(i, j, k, dims); });
  stmTest::Pipeline pipeline;
  vtkUnstructuredGrid* mesh = pipeline.Run(image, c.BalanceLevel, c.CellTemplate);

  ASSERT_GT(mesh->GetNumberOfCells(), 0);
  const int cellType = c.Dimension == 3 ? VTK_TETRA : VTK_TRIANGLE;
  for (vtkIdType cell = 0; cell < mesh->GetNumberOfCells(); ++cell)
  {
    ASSERT_EQ(mesh->GetCellType(cell), cellType);
  }
  const int axes[3] = { 0, 1, 2 };
  const stm::MeshInvariantReport report = c.Dimension == 3
    ? stmTest::CheckMesh<3>(mesh, axes, 1e-6)
    : stmTest::CheckMesh<2>(mesh, axes, 1e-6);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_EQ(report.HangingNodes, 0);
  EXPECT_EQ(report.OpenRidges, 0);

  const double voxel = spacing[0] * spacing[1] * (c.Dimension == 3 ? spacing[2] : 1.0);
  const auto counts = stmTest::CountLabels(image);
  std::set<long long> meshLabels;
  for (const auto& entry : report.VolumePerMaterial)
  {
    meshLabels.insert(entry.first);
  }
  EXPECT_EQ(meshLabels, (std::set<long long>{ 1, 2, 5 }));
  for (long long label : { 1, 2, 5 })
  {
    EXPECT_NEAR(
      report.VolumePerMaterial.at(label), counts.at(label) * voxel, 1e-9 * counts.at(label))
      << "label " << label;
  }
  EXPECT_NEAR(report.BoundaryMeasure, VoxelBoundaryMeasure(image, c.Dimension, spacing), 1e-7);

  // The mesh spans exactly the voxel model: point-data voxels are centred on their points.
  double bounds[6];
  mesh->GetBounds(bounds);
  int lo[3] = { dims[0], dims[1], dims[2] }, hi[3] = { -1, -1, -1 };
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i)
      {
        if (stmTest::NestedEllipsoids(i, j, k, dims) != 0)
        {
          const int ijk[3] = { i, j, k };
          for (int a = 0; a < 3; ++a)
          {
            lo[a] = std::min(lo[a], ijk[a]);
            hi[a] = std::max(hi[a], ijk[a]);
          }
        }
      }
  for (int a = 0; a < c.Dimension; ++a)
  {
    EXPECT_NEAR(bounds[2 * a], origin[a] + (lo[a] - 0.5) * spacing[a], 1e-9);
    EXPECT_NEAR(bounds[2 * a + 1], origin[a] + (hi[a] + 0.5) * spacing[a], 1e-9);
  }
  if (c.Dimension == 2)
  {
    EXPECT_EQ(bounds[4], origin[2]);
    EXPECT_EQ(bounds[5], origin[2]);
  }

  if (c.BalanceLevel > 0)
  {
    vtkUnstructuredGrid* tree = pipeline.Balance->GetOutput();
    EXPECT_LE(MaxNeighbourLevelDifference(tree, false), c.BalanceLevel);
    EXPECT_GE(tree->GetNumberOfCells(), pipeline.Tree->GetOutput()->GetNumberOfCells());
  }
}

INSTANTIATE_TEST_SUITE_P(DimensionsAndBalance, SyntheticPipeline,
  ::testing::Values(Case{ 2, 0, 0 }, Case{ 2, 1, 0 }, Case{ 2, 2, 0 }, Case{ 2, 3, 0 },
    Case{ 2, 1, 1 }, Case{ 3, 0, 0 }, Case{ 3, 1, 0 }, Case{ 3, 2, 0 }, Case{ 3, 3, 0 },
    Case{ 3, 1, 1 }, Case{ 3, 3, 1 }),
  CaseName);

/// Element quality never exceeds the worst case observed over the AAL atlas and random images
/// (docs/quality.md, isotropic voxels): the tessellation yields a finite set of shapes per
/// balance level, and a regression that made worse elements would show here.
class BalancedQuality : public ::testing::TestWithParam<Case>
{
};

TEST_P(BalancedQuality, WithinObservedBounds)
{
  const Case c = GetParam();
  const int dims[3] = { 45, 38, c.Dimension == 3 ? 31 : 1 };
  const double spacing[3] = { 1, 1, 1 }, origin[3] = { 0, 0, 0 };
  auto image = stmTest::MakeLabelImage(dims, spacing, origin,
    [&](int i, int j, int k) { return stmTest::NestedEllipsoids(i, j, k, dims); });
  stmTest::Pipeline pipeline;
  vtkUnstructuredGrid* mesh = pipeline.Run(image, c.BalanceLevel, c.CellTemplate);

  struct Bound
  {
    double Condition;
    double Angle;
  };
  static const Bound bounds2D[3] = { { 1.155, 45.0 }, { 2.021, 18.43 }, { 4.186, 8.13 } };
  static const Bound checkerboard3D[3] = { { 1.318, 45.0 }, { 2.208, 18.43 }, { 5.016, 8.13 } };
  static const Bound kuhn3D[3] = { { 1.563, 35.26 }, { 2.833, 18.43 }, { 5.828, 8.13 } };
  const Bound bound = c.Dimension == 2 ? bounds2D[c.BalanceLevel - 1]
    : c.CellTemplate == 0              ? checkerboard3D[c.BalanceLevel - 1]
                                       : kuhn3D[c.BalanceLevel - 1];
  const stmTest::VerdictQualityRange range = stmTest::MeasureVerdictQuality(mesh);
  const double worst = range.WorstCondition;
  const double smallest = range.SmallestAngle;
  // The bounds are printed rounded to 3 decimals (condition) and 2 (angle).
  EXPECT_LE(worst, bound.Condition + 5e-4);
  EXPECT_GE(smallest, bound.Angle - 5e-3);
  if (c.BalanceLevel == 1)
  {
    EXPECT_NEAR(smallest, bound.Angle, 5e-3) << "L = 1 meshes are made of the best shapes only";
  }
}

// An unbalanced tree has no level-specific bound.
INSTANTIATE_TEST_SUITE_P(DimensionsAndBalance, BalancedQuality,
  ::testing::Values(Case{ 2, 1, 0 }, Case{ 2, 2, 0 }, Case{ 2, 3, 0 }, Case{ 2, 1, 1 },
    Case{ 3, 1, 0 }, Case{ 3, 2, 0 }, Case{ 3, 3, 0 }, Case{ 3, 1, 1 }, Case{ 3, 2, 1 },
    Case{ 3, 3, 1 }),
  CaseName);

TEST(SpacetreePipeline, BalanceOnlyRefinesAndKeepsMaterials)
{
  const int dims[3] = { 40, 33, 26 };
  const double spacing[3] = { 1, 1, 1 }, origin[3] = { 0, 0, 0 };
  auto image = stmTest::MakeLabelImage(dims, spacing, origin,
    [&](int i, int j, int k) { return stmTest::NestedEllipsoids(i, j, k, dims); });
  stmTest::Pipeline pipeline;
  pipeline.Run(image, 1);
  vtkUnstructuredGrid* before = pipeline.Tree->GetOutput();
  vtkUnstructuredGrid* after = pipeline.Balance->GetOutput();
  EXPECT_GT(MaxNeighbourLevelDifference(before, false), 1);
  EXPECT_EQ(MaxNeighbourLevelDifference(after, false), 1);
  // Each leaf after balancing lies inside one leaf before, with the same material and a level
  // at least as fine.
  auto rasterise = [](
                     vtkUnstructuredGrid* tree, std::vector<int>& level, std::vector<int>& material)
  {
    const int maxLevel =
      static_cast<int>(tree->GetFieldData()->GetArray("SpacetreeMaxLevel")->GetComponent(0, 0));
    int n[3];
    for (int a = 0; a < 3; ++a)
    {
      n[a] = static_cast<int>(
               tree->GetFieldData()->GetArray("SpacetreeRootGridDimensions")->GetComponent(a, 0))
        << maxLevel;
    }
    level.assign(static_cast<std::size_t>(n[0]) * n[1] * n[2], -1);
    material.assign(level.size(), -1);
    for (vtkIdType c = 0; c < tree->GetNumberOfCells(); ++c)
    {
      const int l = static_cast<int>(tree->GetCellData()->GetArray("Level")->GetComponent(c, 0));
      const int m = static_cast<int>(tree->GetCellData()->GetArray("Material")->GetComponent(c, 0));
      const int size = 1 << (maxLevel - l);
      int lo[3];
      for (int a = 0; a < 3; ++a)
      {
        lo[a] =
          static_cast<int>(tree->GetCellData()->GetArray("LatticeIndex")->GetComponent(c, a)) *
          size;
      }
      for (int k = lo[2]; k < lo[2] + size; ++k)
        for (int j = lo[1]; j < lo[1] + size; ++j)
          for (int i = lo[0]; i < lo[0] + size; ++i)
          {
            const std::size_t v = (static_cast<std::size_t>(k) * n[1] + j) * n[0] + i;
            level[v] = l;
            material[v] = m;
          }
    }
  };
  std::vector<int> levelBefore, materialBefore, levelAfter, materialAfter;
  rasterise(before, levelBefore, materialBefore);
  rasterise(after, levelAfter, materialAfter);
  ASSERT_EQ(levelBefore.size(), levelAfter.size());
  EXPECT_EQ(materialBefore, materialAfter);
  for (std::size_t v = 0; v < levelBefore.size(); ++v)
  {
    ASSERT_GE(levelAfter[v], levelBefore[v]);
  }
}

TEST(SpacetreePipeline, FaceBalanceOnly)
{
  const int dims[3] = { 40, 33, 26 };
  const double spacing[3] = { 1, 1, 1 }, origin[3] = { 0, 0, 0 };
  auto image = stmTest::MakeLabelImage(dims, spacing, origin,
    [&](int i, int j, int k) { return stmTest::NestedEllipsoids(i, j, k, dims); });
  stmTest::Pipeline pipeline;
  pipeline.Balance->FaceBalanceOnlyOn();
  vtkUnstructuredGrid* mesh = pipeline.Run(image, 1);
  EXPECT_EQ(MaxNeighbourLevelDifference(pipeline.Balance->GetOutput(), true), 1);
  const int axes[3] = { 0, 1, 2 };
  EXPECT_TRUE(stmTest::CheckMesh<3>(mesh, axes, 1e-6).IsValid());
}

TEST(SpacetreePipeline, MirroringDirectionMatrixKeepsPositiveVolumes)
{
  const int dims[3] = { 20, 18, 16 };
  const double spacing[3] = { 1, 2, 3 }, origin[3] = { 5, 5, 5 };
  auto image = stmTest::MakeLabelImage(dims, spacing, origin,
    [&](int i, int j, int k) { return stmTest::NestedEllipsoids(i, j, k, dims); });
  const double flipX[9] = { -1, 0, 0, 0, 1, 0, 0, 0, 1 };
  image->SetDirectionMatrix(flipX);
  stmTest::Pipeline pipeline;
  vtkUnstructuredGrid* mesh = pipeline.Run(image, 1);
  const int axes[3] = { 0, 1, 2 };
  const auto report = stmTest::CheckMesh<3>(mesh, axes, 1e-6);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  double bounds[6];
  mesh->GetBounds(bounds);
  EXPECT_LE(bounds[1], origin[0] + 0.5 * spacing[0] + 1e-12); // mirrored along x
}

TEST(SpacetreePipeline, CellDataLabelsGiveTheSameMesh)
{
  const int dims[3] = { 21, 17, 13 };
  const double spacing[3] = { 1, 1, 1 }, origin[3] = { 0, 0, 0 };
  auto pointImage = stmTest::MakeLabelImage(dims, spacing, origin,
    [&](int i, int j, int k) { return stmTest::NestedEllipsoids(i, j, k, dims); });
  vtkNew<vtkImageData> cellImage;
  cellImage->SetDimensions(dims[0] + 1, dims[1] + 1, dims[2] + 1);
  cellImage->SetOrigin(-0.5, -0.5, -0.5);
  cellImage->GetCellData()->SetScalars(pointImage->GetPointData()->GetScalars());
  stmTest::Pipeline a, b;
  vtkUnstructuredGrid* fromPoints = a.Run(pointImage, 1);
  vtkUnstructuredGrid* fromCells = b.Run(cellImage, 1);
  ASSERT_EQ(fromPoints->GetNumberOfCells(), fromCells->GetNumberOfCells());
  ASSERT_EQ(fromPoints->GetNumberOfPoints(), fromCells->GetNumberOfPoints());
  for (vtkIdType p = 0; p < fromPoints->GetNumberOfPoints(); p += 7)
  {
    double x[3], y[3];
    fromPoints->GetPoint(p, x);
    fromCells->GetPoint(p, y);
    EXPECT_NEAR(x[0], y[0], 1e-12);
    EXPECT_NEAR(x[1], y[1], 1e-12);
    EXPECT_NEAR(x[2], y[2], 1e-12);
  }
}

/// Same points, cells and order, whatever the number of threads.
TEST(SpacetreePipeline, OutputDoesNotDependOnThreadCount)
{
  const int dims[3] = { 48, 40, 36 };
  const double spacing[3] = { 1, 1, 1 }, origin[3] = { 0, 0, 0 };
  auto image = stmTest::MakeLabelImage(dims, spacing, origin,
    [&](int i, int j, int k) { return stmTest::NestedEllipsoids(i, j, k, dims); });
  const std::string previousBackend = vtkSMPTools::GetBackend();
  ASSERT_TRUE(vtkSMPTools::SetBackend("STDThread"));
  std::vector<std::vector<double>> coordinates;
  std::vector<std::vector<vtkIdType>> connectivity;
  for (int threads : { 1, 2, 3 })
  {
    vtkSMPTools::Initialize(threads);
    stmTest::Pipeline pipeline;
    vtkUnstructuredGrid* mesh = pipeline.Run(image, 1);
    std::vector<double> xyz(static_cast<std::size_t>(mesh->GetNumberOfPoints()) * 3);
    for (vtkIdType p = 0; p < mesh->GetNumberOfPoints(); ++p)
    {
      mesh->GetPoint(p, &xyz[3 * p]);
    }
    std::vector<vtkIdType> ids;
    vtkNew<vtkIdList> cell;
    for (vtkIdType c = 0; c < mesh->GetNumberOfCells(); ++c)
    {
      mesh->GetCellPoints(c, cell);
      ids.insert(ids.end(), cell->begin(), cell->end());
    }
    coordinates.push_back(xyz);
    connectivity.push_back(ids);
  }
  vtkSMPTools::SetBackend(previousBackend.c_str());
  EXPECT_EQ(coordinates[0], coordinates[1]);
  EXPECT_EQ(coordinates[0], coordinates[2]);
  EXPECT_EQ(connectivity[0], connectivity[1]);
  EXPECT_EQ(connectivity[0], connectivity[2]);
}

/// The spacetree survives a file round trip (inline binary XML), and meshes identically.
TEST(SpacetreePipeline, SpacetreeAndMeshFileRoundTrip)
{
  const int dims[3] = { 30, 26, 22 };
  const double spacing[3] = { 0.5, 0.5, 1.0 }, origin[3] = { 1, 2, 3 };
  auto image = stmTest::MakeLabelImage(dims, spacing, origin,
    [&](int i, int j, int k) { return stmTest::NestedEllipsoids(i, j, k, dims); });
  stmTest::Pipeline pipeline;
  vtkUnstructuredGrid* direct = pipeline.Run(image, 2);

  const std::string treeFile = "TestSpacetreeRoundTrip_tree.vtu";
  vtkNew<vtkXMLUnstructuredGridWriter> writer;
  writer->SetInputConnection(pipeline.Balance->GetOutputPort());
  writer->SetFileName(treeFile.c_str());
  writer->SetDataModeToBinary();
  ASSERT_EQ(writer->Write(), 1);
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName(treeFile.c_str());
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetInputConnection(reader->GetOutputPort());
  tessellate->SetSeparatingFunction(stmSpacetreeTessellate::NO_FUNCTION);
  tessellate->Update();
  vtkUnstructuredGrid* fromFile = tessellate->GetOutput();
  ASSERT_EQ(fromFile->GetNumberOfCells(), direct->GetNumberOfCells());
  ASSERT_EQ(fromFile->GetNumberOfPoints(), direct->GetNumberOfPoints());
  vtkNew<vtkIdList> a, b;
  for (vtkIdType c = 0; c < direct->GetNumberOfCells(); ++c)
  {
    direct->GetCellPoints(c, a);
    fromFile->GetCellPoints(c, b);
    ASSERT_EQ(a->GetNumberOfIds(), b->GetNumberOfIds());
    for (vtkIdType v = 0; v < a->GetNumberOfIds(); ++v)
    {
      ASSERT_EQ(a->GetId(v), b->GetId(v));
    }
  }

  // The mesh in both formats the CLI writes.
  const std::string vtuFile = "TestSpacetreeRoundTrip_mesh.vtu";
  const std::string vtkFile = "TestSpacetreeRoundTrip_mesh.vtk";
  vtkNew<vtkXMLUnstructuredGridWriter> meshWriter;
  meshWriter->SetInputData(direct);
  meshWriter->SetFileName(vtuFile.c_str());
  meshWriter->SetDataModeToBinary();
  ASSERT_EQ(meshWriter->Write(), 1);
  vtkNew<vtkUnstructuredGridWriter> legacyWriter;
  legacyWriter->SetInputData(direct);
  legacyWriter->SetFileName(vtkFile.c_str());
  legacyWriter->SetFileTypeToBinary();
  ASSERT_EQ(legacyWriter->Write(), 1);
  vtkNew<vtkXMLUnstructuredGridReader> vtuReader;
  vtuReader->SetFileName(vtuFile.c_str());
  vtuReader->Update();
  vtkNew<vtkUnstructuredGridReader> vtkReader;
  vtkReader->SetFileName(vtkFile.c_str());
  vtkReader->Update();
  for (vtkUnstructuredGrid* readBack : { vtuReader->GetOutput(), vtkReader->GetOutput() })
  {
    EXPECT_EQ(readBack->GetNumberOfCells(), direct->GetNumberOfCells());
    EXPECT_EQ(readBack->GetNumberOfPoints(), direct->GetNumberOfPoints());
    ASSERT_NE(readBack->GetCellData()->GetArray("Material"), nullptr);
    EXPECT_EQ(readBack->GetCellData()->GetArray("Material")->GetRange()[1], 5);
  }
  std::remove(treeFile.c_str());
  std::remove(vtuFile.c_str());
  std::remove(vtkFile.c_str());
}

TEST(SpacetreePipeline, BadInputGetsClearErrors)
{
  const int dims[3] = { 10, 10, 10 };
  const double spacing[3] = { 1, 1, 1 }, origin[3] = { 0, 0, 0 };
  const auto check = stmTest::ExpectErrorAndEmptyOutput;

  { // floating-point labels
    vtkNew<vtkImageData> image;
    image->SetDimensions(4, 4, 4);
    image->AllocateScalars(VTK_FLOAT, 1);
    vtkNew<stmImageToSpacetree> tree;
    tree->SetInputData(image);
    check(tree, "needs integer labels");
  }
  { // no label array
    vtkNew<vtkImageData> image;
    image->SetDimensions(4, 4, 4);
    vtkNew<stmImageToSpacetree> tree;
    tree->SetInputData(image);
    check(tree, "No label array");
  }
  { // one voxel
    vtkNew<vtkImageData> image;
    image->SetDimensions(1, 1, 1);
    image->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
    vtkNew<stmImageToSpacetree> tree;
    tree->SetInputData(image);
    check(tree, "needs a 2D or 3D image");
  }
  { // negative and zero spacing
    for (double bad : { 0.0, -1.0 })
    {
      auto image =
        stmTest::MakeLabelImage(dims, spacing, origin, [](int i, int, int) { return i > 4; });
      image->SetSpacing(1, bad, 1);
      vtkNew<stmImageToSpacetree> tree;
      tree->SetInputData(image);
      check(tree, "must be positive");
    }
  }
  { // empty body of interest
    auto image = stmTest::MakeLabelImage(dims, spacing, origin, [](int, int, int) { return 0; });
    vtkNew<stmImageToSpacetree> tree;
    tree->SetInputData(image);
    check(tree, "body of interest is empty");
  }
  { // a label absent from the image, and the background as a body label
    auto image =
      stmTest::MakeLabelImage(dims, spacing, origin, [](int i, int, int) { return i > 4; });
    vtkNew<stmImageToSpacetree> tree;
    tree->SetInputData(image);
    tree->AddBodyLabel(7);
    check(tree, "does not occur");
    tree->RemoveAllBodyLabels();
    tree->AddBodyLabel(0);
    check(tree, "equals the background label");
  }
  { // not a spacetree
    vtkNew<vtkUnstructuredGrid> notATree;
    vtkNew<stmSpacetreeBalance> balance;
    balance->SetInputData(notATree);
    check(balance, "SpacetreeDimension");
    vtkNew<stmSpacetreeTessellate> tessellate;
    tessellate->SetInputData(notATree);
    check(tessellate, "SpacetreeDimension");
  }
  { // a corrupted spacetree: one leaf's level changed, so the leaves overlap
    auto image = stmTest::MakeLabelImage(
      dims, spacing, origin, [](int i, int j, int) { return i > 4 && j > 3; });
    vtkNew<stmImageToSpacetree> tree;
    tree->SetInputData(image);
    tree->Update();
    vtkNew<vtkUnstructuredGrid> corrupt;
    corrupt->DeepCopy(tree->GetOutput());
    auto* levels = vtkUnsignedCharArray::SafeDownCast(corrupt->GetCellData()->GetArray("Level"));
    levels->SetValue(
      0, static_cast<unsigned char>(levels->GetValue(0) == 0 ? 1 : levels->GetValue(0) - 1));
    vtkNew<stmSpacetreeTessellate> tessellate;
    tessellate->SetInputData(corrupt);
    check(tessellate, "invalid spacetree");
    levels->SetValue(0, 99);
    levels->Modified();
    tessellate->Modified();
    check(tessellate, "invalid level");
  }
  { // the wrong data type entirely is refused by the pipeline
    vtkNew<vtkPolyData> polyData;
    vtkNew<stmImageToSpacetree> tree;
    tree->SetInputData(polyData);
    ErrorRecorder errors(tree->GetExecutive());
    tree->Update();
    EXPECT_EQ(tree->GetOutput()->GetNumberOfCells(), 0);
  }
}

class AalAtlas : public ::testing::TestWithParam<int>
{
protected:
  static void SetUpTestSuite()
  {
    Reader = vtkNIFTIImageReader::New();
    Reader->SetFileName(AalPath);
    Reader->Update();
  }
  static void TearDownTestSuite()
  {
    Reader->Delete();
    Reader = nullptr;
  }
  static vtkNIFTIImageReader* Reader;
};
vtkNIFTIImageReader* AalAtlas::Reader = nullptr;

/// The real AAL atlas (116 labels, 181 x 217 x 181 voxels of 1 mm): a valid mesh with every
/// label's volume exactly its voxel volume.
TEST_P(AalAtlas, ValidExactMesh)
{
  if (!std::ifstream(AalPath).good())
  {
    GTEST_SKIP() << AalPath << " is missing; install Debian's mricron-data";
  }
  vtkImageData* image = Reader->GetOutput();
  ASSERT_EQ(image->GetNumberOfPoints(), 181 * 217 * 181);
  stmTest::Pipeline pipeline;
  vtkUnstructuredGrid* mesh = pipeline.Run(image, GetParam());
  const int axes[3] = { 0, 1, 2 };
  const auto report = stmTest::CheckMesh<3>(mesh, axes, 1e-6);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  auto counts = stmTest::CountLabels(image);
  counts.erase(0);
  EXPECT_EQ(counts.size(), 116u);
  ASSERT_EQ(report.VolumePerMaterial.size(), counts.size());
  double spacing[3];
  image->GetSpacing(spacing);
  const double voxel = spacing[0] * spacing[1] * spacing[2];
  for (const auto& entry : counts)
  {
    EXPECT_NEAR(report.VolumePerMaterial.at(entry.first), entry.second * voxel, 1e-9 * entry.second)
      << "label " << entry.first;
  }
  EXPECT_NEAR(report.BoundaryMeasure, VoxelBoundaryMeasure(image, 3, spacing), 1e-6);
  if (GetParam() > 0)
  {
    EXPECT_LE(MaxNeighbourLevelDifference(pipeline.Balance->GetOutput(), false), GetParam());
  }
}

/// 2D: axial slices of the atlas give valid triangle meshes with exact areas per label.
TEST_P(AalAtlas, AxialSlicesGiveValidExactMeshes)
{
  if (!std::ifstream(AalPath).good())
  {
    GTEST_SKIP() << AalPath << " is missing; install Debian's mricron-data";
  }
  for (int z : { 45, 90, 120 })
  {
    vtkNew<vtkExtractVOI> slice;
    slice->SetInputConnection(Reader->GetOutputPort());
    slice->SetVOI(0, 180, 0, 216, z, z);
    slice->Update();
    vtkImageData* image = slice->GetOutput();
    stmTest::Pipeline pipeline;
    vtkUnstructuredGrid* mesh = pipeline.Run(image, GetParam());
    for (vtkIdType cell = 0; cell < mesh->GetNumberOfCells(); ++cell)
    {
      ASSERT_EQ(mesh->GetCellType(cell), VTK_TRIANGLE);
    }
    const int axes[2] = { 0, 1 };
    const auto report = stmTest::CheckMesh<2>(mesh, axes, 1e-6);
    EXPECT_TRUE(report.IsValid()) << "slice " << z << ": " << report.Summary();
    auto counts = stmTest::CountLabels(image);
    counts.erase(0);
    ASSERT_EQ(report.VolumePerMaterial.size(), counts.size()) << "slice " << z;
    for (const auto& entry : counts)
    {
      EXPECT_EQ(report.VolumePerMaterial.at(entry.first), static_cast<double>(entry.second))
        << "slice " << z << ", label " << entry.first;
    }
    const double spacing[3] = { 1, 1, 1 };
    EXPECT_EQ(report.BoundaryMeasure, VoxelBoundaryMeasure(image, 2, spacing)) << "slice " << z;
    if (GetParam() > 0)
    {
      EXPECT_LE(MaxNeighbourLevelDifference(pipeline.Balance->GetOutput(), false), GetParam());
    }
  }
}

INSTANTIATE_TEST_SUITE_P(BalanceLevels, AalAtlas, ::testing::Values(0, 1, 2, 3),
  [](const ::testing::TestParamInfo<int>& info)
  { return info.param == 0 ? std::string("Unbalanced") : "L" + std::to_string(info.param); });

} // namespace
