// SPDX-License-Identifier: BSD-3-Clause
// stmMarchingSimplices and the separating functions through the VTK filters: the default
// pipeline on the AAL brain mask (valid mesh, volume, closed surface, quality), the analytic
// ball's second-order volume convergence, 2D, one side, gray values, and bad input.

#include "stmFilterTestUtilities.h"
#include "stmVerdictQuality.h"

#include "stmImageToSpacetree.h"
#include "stmMarchingSimplices.h"
#include "stmSeparatingFunction.h"
#include "stmSpacetreeBalance.h"
#include "stmSpacetreeTessellate.h"

#include "vtkCallbackCommand.h"
#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCommand.h"
#include "vtkDoubleArray.h"
#include "vtkFloatArray.h"
#include "vtkIdList.h"
#include "vtkImageData.h"
#include "vtkImageThreshold.h"
#include "vtkIntArray.h"
#include "vtkNIFTIImageReader.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPolyData.h"
#include "vtkSphere.h"
#include "vtkTetra.h"
#include "vtkUnstructuredGrid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <string>

namespace
{
const char* const GrayPath = "/usr/share/mricron/templates/ch2bet.nii.gz";
const int Axes3[3] = { 0, 1, 2 };
const int Axes2[2] = { 0, 1 };

using stmTest::ErrorRecorder;

/// How a triangle (segment) surface's edges (points in 2D) are shared: Open counts those in an
/// odd number of facets (a hole), NonManifold those in an even number other than two (where the
/// surface pinches, e.g. two inside voxels touching along an edge), Edges the distinct ones.
struct EdgeSharing
{
  long long Open = 0;
  long long NonManifold = 0;
  long long Edges = 0;
};

EdgeSharing ShareEdges(vtkPolyData* surface, bool lines)
{
  std::map<std::pair<vtkIdType, vtkIdType>, int> edges;
  vtkCellArray* cells = lines ? surface->GetLines() : surface->GetPolys();
  vtkNew<vtkIdList> ids;
  for (cells->InitTraversal(); cells->GetNextCell(ids);)
  {
    const int count = static_cast<int>(ids->GetNumberOfIds());
    for (int e = 0; e < count; ++e)
    {
      const vtkIdType a = ids->GetId(e), b = lines ? a : ids->GetId((e + 1) % count);
      ++edges[{ std::min(a, b), std::max(a, b) }];
    }
  }
  EdgeSharing sharing;
  for (const auto& edge : edges)
  {
    sharing.Open += edge.second % 2;
    sharing.NonManifold += edge.second % 2 == 0 && edge.second != 2;
  }
  sharing.Edges = static_cast<long long>(edges.size());
  return sharing;
}

double VolumeOfMaterial(const stm::MeshInvariantReport& report, int material)
{
  const auto found = report.VolumePerMaterial.find(material);
  return found == report.VolumePerMaterial.end() ? 0.0 : found->second;
}

// The default pipeline on the AAL brain mask (every non-zero label one body): a valid cut mesh
// whose inside volume is within 2% of the voxel volume, a closed outward surface, and the
// quality before snapping, reported.
TEST(MarchingSimplicesFilter, AalBrainMaskWithTheDefaultFunction)
{
  if (!std::ifstream(stmTest::AalAtlasPath).good())
  {
    GTEST_SKIP() << stmTest::AalAtlasPath << " is missing; install Debian's mricron-data";
  }
  stmTest::AalBrainMask mask;
  const double voxelVolume = mask.VoxelVolume;

  vtkNew<stmImageToSpacetree> tree;
  tree->SetInputConnection(mask.GetOutputPort());
  vtkNew<stmSpacetreeBalance> balance;
  balance->SetInputConnection(tree->GetOutputPort());
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetInputConnection(balance->GetOutputPort());
  vtkNew<stmMarchingSimplices> cut;
  cut->SetInputConnection(tessellate->GetOutputPort());
  cut->Update();
  EXPECT_EQ(tessellate->GetNumberOfBoundaryLayers(), 1);
  auto* mesh = vtkUnstructuredGrid::SafeDownCast(cut->GetOutputDataObject(0));
  ASSERT_NE(mesh, nullptr);
  const stm::MeshInvariantReport before =
    stmTest::CheckMesh<3>(tessellate->GetOutput(), Axes3, 1e-9);
  const stm::MeshInvariantReport report = stmTest::CheckMesh<3>(mesh, Axes3, 1e-9);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_NEAR(report.TotalVolume, before.TotalVolume, 1e-9 * before.TotalVolume);
  const double inside = VolumeOfMaterial(report, 1);
  EXPECT_NEAR(inside, voxelVolume, 0.02 * voxelVolume);
  EXPECT_GT(cut->GetNumberOfSplitCells(), 0);
  EXPECT_EQ(mesh->GetNumberOfPoints(),
    tessellate->GetOutput()->GetNumberOfPoints() + cut->GetNumberOfCutPoints());
  ASSERT_NE(mesh->GetCellData()->GetArray("OriginalMaterial"), nullptr);
  const stmTest::VerdictQualityRange quality = stmTest::MeasureVerdictQuality(mesh);
  std::cout << "AAL brain mask, labels function, no snapping: " << mesh->GetNumberOfCells()
            << " tetrahedra, " << cut->GetNumberOfSplitCells() << " split, inside volume " << inside
            << " mm3 (voxels " << voxelVolume << "), worst condition " << quality.WorstCondition
            << ", smallest dihedral angle " << quality.SmallestAngle << " degrees\n";
  // The labels function takes finitely many values (eq. 2), so the quality is bounded.
  EXPECT_LT(quality.WorstCondition, 100.0);

  cut->SetOutputMode(stmMarchingSimplices::SURFACE);
  cut->Update();
  auto* surface = vtkPolyData::SafeDownCast(cut->GetOutputDataObject(0));
  ASSERT_NE(surface, nullptr);
  EXPECT_GT(surface->GetNumberOfPolys(), 0);
  const EdgeSharing sharing = ShareEdges(surface, false);
  EXPECT_EQ(sharing.Open, 0) << "the brain surface is not closed";
  std::cout << "AAL brain surface: " << surface->GetNumberOfPolys() << " triangles, "
            << sharing.Edges << " edges, " << sharing.NonManifold
            << " pinched (in 4 or more triangles, where inside voxels touch along an edge)\n";
  EXPECT_LT(sharing.NonManifold, sharing.Edges / 1000);
  ASSERT_NE(surface->GetCellData()->GetNormals(), nullptr);
  // Outward: the divergence theorem gives the inside volume, positive.
  double enclosed = 0.0;
  vtkNew<vtkIdList> ids;
  for (surface->GetPolys()->InitTraversal(); surface->GetPolys()->GetNextCell(ids);)
  {
    double a[3], b[3], c[3];
    surface->GetPoint(ids->GetId(0), a);
    surface->GetPoint(ids->GetId(1), b);
    surface->GetPoint(ids->GetId(2), c);
    enclosed += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                  a[2] * (b[0] * c[1] - b[1] * c[0])) /
      6.0;
  }
  EXPECT_NEAR(enclosed, inside, 1e-6 * inside);

  // Real gray values: the same mesh cut by the T1 template at a threshold stays valid and
  // keeps its volume.
  if (std::ifstream(GrayPath).good())
  {
    vtkNew<vtkNIFTIImageReader> grayReader;
    grayReader->SetFileName(GrayPath);
    vtkNew<stmSeparatingFunction> gray;
    gray->SetInputConnection(tessellate->GetOutputPort());
    gray->SetGrayImageConnection(grayReader->GetOutputPort());
    gray->SetMode(stmSeparatingFunction::GRAY_IMAGE);
    gray->SetThreshold(60.0);
    vtkNew<stmMarchingSimplices> grayCut;
    grayCut->SetInputConnection(gray->GetOutputPort());
    grayCut->Update();
    auto* grayMesh = vtkUnstructuredGrid::SafeDownCast(grayCut->GetOutputDataObject(0));
    ASSERT_NE(grayMesh, nullptr);
    const stm::MeshInvariantReport grayReport = stmTest::CheckMesh<3>(grayMesh, Axes3, 1e-9);
    EXPECT_TRUE(grayReport.IsValid()) << grayReport.Summary();
    EXPECT_NEAR(grayReport.TotalVolume, before.TotalVolume, 1e-9 * before.TotalVolume);
    EXPECT_GT(grayCut->GetNumberOfSplitCells(), 0);
  }
}

/// A uniform mesh of the unit box (n^3 voxels of edge 1/n) cut by the sphere of radius r.
double BallVolume(int n, double radius, double* worstCondition)
{
  const int dims[3] = { n, n, n };
  const double h = 1.0 / n;
  const double spacing[3] = { h, h, h }, origin[3] = { h / 2, h / 2, h / 2 };
  auto image = stmTest::MakeLabelImage(dims, spacing, origin, [](int, int, int) { return 1; });
  vtkNew<stmImageToSpacetree> tree;
  tree->SetInputData(image);
  tree->SetMaxCellSize(1);
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetInputConnection(tree->GetOutputPort());
  tessellate->SetSeparatingFunction(stmSpacetreeTessellate::NO_FUNCTION);
  vtkNew<vtkSphere> sphere;
  sphere->SetCenter(0.5, 0.5, 0.5);
  sphere->SetRadius(radius);
  vtkNew<stmSeparatingFunction> function;
  function->SetInputConnection(tessellate->GetOutputPort());
  function->SetImplicitFunction(sphere);
  vtkNew<stmMarchingSimplices> cut;
  cut->SetInputConnection(function->GetOutputPort());
  cut->SetKeepSide(stmMarchingSimplices::INSIDE);
  cut->Update();
  auto* mesh = vtkUnstructuredGrid::SafeDownCast(cut->GetOutputDataObject(0));
  const stm::MeshInvariantReport report = stmTest::CheckMesh<3>(mesh, Axes3, 1e-12);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  if (worstCondition)
  {
    *worstCondition = stmTest::MeasureVerdictQuality(mesh).WorstCondition;
  }
  return report.TotalVolume;
}

// The paper's analytic ball: the volume converges to 4/3 pi r^3 at second order in h.
TEST(MarchingSimplicesFilter, AnalyticBallConvergesAtSecondOrder)
{
  const double radius = 0.35;
  const double exact = 4.0 / 3.0 * 3.14159265358979323846 * radius * radius * radius;
  double previousError = 0.0;
  std::cout << "| n | tetrahedra volume | relative error | order | worst condition |\n"
            << "|---|---|---|---|---|\n";
  for (int n : { 10, 20, 40, 80 })
  {
    double condition = 0.0;
    const double volume = BallVolume(n, radius, &condition);
    const double error = std::abs(volume - exact) / exact;
    const double order = previousError > 0 ? std::log2(previousError / error) : 0.0;
    std::cout << "| " << n << " | " << volume << " | " << error << " | "
              << (previousError > 0 ? std::to_string(order) : std::string("-")) << " | "
              << condition << " |\n";
    if (previousError > 0)
    {
      EXPECT_GT(order, 1.7) << "n = " << n;
    }
    previousError = error;
  }
  EXPECT_LT(previousError, 2e-3);
}

// 2D: a disk of labels cut by the default function gives a valid triangle mesh with a closed
// boundary curve; Keep Side Inside keeps only the inside, without unused points.
TEST(MarchingSimplicesFilter, TwoDimensionalDiskAndOneSide)
{
  const int dims[3] = { 30, 26, 1 };
  const double spacing[3] = { 0.5, 0.5, 1 }, origin[3] = { 0, 0, 0 };
  auto image = stmTest::MakeLabelImage(dims, spacing, origin,
    [](int i, int j, int) { return (i - 14) * (i - 14) + (j - 12) * (j - 12) < 64 ? 3 : 0; });
  vtkNew<stmImageToSpacetree> tree;
  tree->SetInputData(image);
  vtkNew<stmSpacetreeBalance> balance;
  balance->SetInputConnection(tree->GetOutputPort());
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetInputConnection(balance->GetOutputPort());
  vtkNew<stmMarchingSimplices> cut;
  cut->SetInputConnection(tessellate->GetOutputPort());
  cut->SetInsideMaterial(3);
  cut->Update();
  auto* mesh = vtkUnstructuredGrid::SafeDownCast(cut->GetOutputDataObject(0));
  ASSERT_NE(mesh, nullptr);
  const stm::MeshInvariantReport before =
    stmTest::CheckMesh<2>(tessellate->GetOutput(), Axes2, 1e-9);
  const stm::MeshInvariantReport report = stmTest::CheckMesh<2>(mesh, Axes2, 1e-9);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_NEAR(report.TotalVolume, before.TotalVolume, 1e-9 * before.TotalVolume);
  EXPECT_GT(cut->GetNumberOfSplitCells(), 0);
  const std::set<double> materials = [&]
  {
    std::set<double> values;
    vtkDataArray* material = mesh->GetCellData()->GetArray("Material");
    for (vtkIdType c = 0; c < mesh->GetNumberOfCells(); ++c)
    {
      values.insert(material->GetComponent(c, 0));
    }
    return values;
  }();
  EXPECT_EQ(materials, (std::set<double>{ 0, 3 }));
  const double inside = VolumeOfMaterial(report, 3);

  cut->SetKeepSide(stmMarchingSimplices::INSIDE);
  cut->Update();
  mesh = vtkUnstructuredGrid::SafeDownCast(cut->GetOutputDataObject(0));
  const stm::MeshInvariantReport insideReport = stmTest::CheckMesh<2>(mesh, Axes2, 1e-9);
  EXPECT_TRUE(insideReport.IsValid()) << insideReport.Summary(); // no unreferenced point
  EXPECT_NEAR(insideReport.TotalVolume, inside, 1e-12 * inside);
  EXPECT_EQ(mesh->GetCellData()->GetArray("Material")->GetRange()[0], 3);

  cut->SetOutputMode(stmMarchingSimplices::SURFACE);
  cut->Update();
  auto* curve = vtkPolyData::SafeDownCast(cut->GetOutputDataObject(0));
  ASSERT_NE(curve, nullptr);
  const EdgeSharing sharing = ShareEdges(curve, true);
  EXPECT_EQ(sharing.Open, 0);
  EXPECT_EQ(sharing.NonManifold, 0);
  EXPECT_EQ(sharing.Edges, curve->GetNumberOfLines()); // a closed curve: as many points as segments
}

/// The cut mesh of the chain ImageToSpacetree, SpacetreeBalance, SpacetreeTessellate and
/// MarchingSimplices, every filter at its defaults but the thin-part mode.
vtkSmartPointer<vtkUnstructuredGrid> CutByTheDefaultChain(vtkImageData* image, int thinParts)
{
  vtkNew<stmImageToSpacetree> tree;
  tree->SetInputData(image);
  tree->SetThinPartRefinement(thinParts);
  vtkNew<stmSpacetreeBalance> balance;
  balance->SetInputConnection(tree->GetOutputPort());
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetInputConnection(balance->GetOutputPort());
  vtkNew<stmMarchingSimplices> cut;
  cut->SetInputConnection(tessellate->GetOutputPort());
  cut->Update();
  vtkSmartPointer<vtkUnstructuredGrid> mesh =
    vtkUnstructuredGrid::SafeDownCast(cut->GetOutputDataObject(0));
  return mesh;
}

/// The volume of the tetrahedra of material 1 whose centroid lies in the box [low, high].
double BodyVolumeIn(vtkUnstructuredGrid* mesh, const double low[3], const double high[3])
{
  vtkDataArray* material = mesh->GetCellData()->GetArray("Material");
  double volume = 0.0;
  vtkNew<vtkIdList> ids;
  for (vtkIdType c = 0; c < mesh->GetNumberOfCells(); ++c)
  {
    mesh->GetCellPoints(c, ids);
    if (material->GetComponent(c, 0) != 1 || ids->GetNumberOfIds() != 4)
    {
      continue;
    }
    double p[4][3], centroid[3] = { 0, 0, 0 };
    for (int corner = 0; corner < 4; ++corner)
    {
      mesh->GetPoint(ids->GetId(corner), p[corner]);
      for (int axis = 0; axis < 3; ++axis)
      {
        centroid[axis] += p[corner][axis] / 4;
      }
    }
    bool inBox = true;
    for (int axis = 0; axis < 3; ++axis)
    {
      inBox = inBox && centroid[axis] >= low[axis] && centroid[axis] <= high[axis];
    }
    volume += inBox ? std::abs(vtkTetra::ComputeVolume(p[0], p[1], p[2], p[3])) : 0.0;
  }
  return volume;
}

// The filters' defaults keep what a cut at the labels function would lose: an 8^3 block in a
// corner of a 16^3 image (a coarse leaf there interpolates the corner's minority over its whole
// size), and, in a 12^3 image, a single voxel and a plate one voxel thick. The same chain without
// thin-part refinement loses them, which is why Thin Body Parts is ImageToSpacetree's default.
TEST(MarchingSimplicesFilter, DefaultChainKeepsCornerBlocksSpecksAndThinPlates)
{
  EXPECT_EQ(
    vtkNew<stmImageToSpacetree>()->GetThinPartRefinement(), stmImageToSpacetree::THIN_BODY_PARTS);
  const double spacing[3] = { 1, 1, 1 }, origin[3] = { 0, 0, 0 };
  const int blockDims[3] = { 16, 16, 16 };
  auto block = stmTest::MakeLabelImage(
    blockDims, spacing, origin, [](int i, int j, int k) { return i < 8 && j < 8 && k < 8; });
  const int thinDims[3] = { 12, 12, 12 };
  auto thin = stmTest::MakeLabelImage(thinDims, spacing, origin,
    [](int i, int j, int k)
    { return (i == 3 && j == 3 && k == 3) || (k == 8 && i > 1 && i < 10); });
  const double speckLow[3] = { 2, 2, 2 }, speckHigh[3] = { 4, 4, 4 };
  const double plateLow[3] = { 1, -1, 7 }, plateHigh[3] = { 10, 12, 9 };

  for (int thinParts : { stmImageToSpacetree::THIN_BODY_PARTS, stmImageToSpacetree::NO_THIN_PARTS })
  {
    const bool refined = thinParts != stmImageToSpacetree::NO_THIN_PARTS;
    auto blockMesh = CutByTheDefaultChain(block, thinParts);
    auto thinMesh = CutByTheDefaultChain(thin, thinParts);
    const stm::MeshInvariantReport blockReport = stmTest::CheckMesh<3>(blockMesh, Axes3, 1e-9);
    EXPECT_TRUE(blockReport.IsValid()) << blockReport.Summary();
    const stm::MeshInvariantReport thinReport = stmTest::CheckMesh<3>(thinMesh, Axes3, 1e-9);
    EXPECT_TRUE(thinReport.IsValid()) << thinReport.Summary();
    const auto blockBody = blockReport.VolumePerMaterial.find(1);
    const double blockVolume =
      blockBody == blockReport.VolumePerMaterial.end() ? 0.0 : blockBody->second;
    const double speck = BodyVolumeIn(thinMesh, speckLow, speckHigh);
    const double plate = BodyVolumeIn(thinMesh, plateLow, plateHigh);
    std::cout << (refined ? "thin body parts" : "no thin parts") << ": corner block " << blockVolume
              << " of 512, speck " << speck << " of 1, plate " << plate << " of 96\n";
    if (refined)
    {
      EXPECT_GT(blockVolume, 0.9 * 512);
      EXPECT_GT(speck, 0.1);
      EXPECT_GT(plate, 0.9 * 96);
    }
    else // what the default prevents: the block and the speck are gone
    {
      EXPECT_EQ(blockVolume, 0.0);
      EXPECT_EQ(speck, 0.0);
      EXPECT_LT(plate, 0.7 * 96);
    }
  }
}

// Each piece carries its parent cell's data and the input points keep theirs, whether the
// arrays are gathered on the threads (numbers) or by VTK (a string array among them).
TEST(MarchingSimplicesFilter, CellAndPointDataComeFromTheParents)
{
  stmTest::ExpectParentArraysThrough<stmMarchingSimplices>(stmTest::BadInputTree(0), 0.0);
}

TEST(MarchingSimplicesFilter, BadInputGetsClearErrors)
{
  const auto check = stmTest::ExpectErrorAndEmptyOutput;
  auto tree = stmTest::BadInputTree(0);
  vtkNew<stmSpacetreeTessellate> hybrid;
  hybrid->SetInputConnection(tree->GetOutputPort());
  hybrid->SetOutputType(stmSpacetreeTessellate::HYBRID);
  hybrid->Update();
  { // hexahedra and pyramids
    vtkNew<stmMarchingSimplices> cut;
    cut->SetInputData(hybrid->GetOutput());
    check(cut, "only tetrahedra or only triangles");
  }
  vtkNew<stmSpacetreeTessellate> staircase;
  staircase->SetInputConnection(tree->GetOutputPort());
  staircase->SetSeparatingFunction(stmSpacetreeTessellate::NO_FUNCTION);
  staircase->Update();
  { // no separating function
    vtkNew<stmMarchingSimplices> cut;
    cut->SetInputData(staircase->GetOutput());
    check(cut, "no point array 'SeparatingFunction'");
  }
  vtkNew<vtkUnstructuredGrid> mesh;
  mesh->ShallowCopy(staircase->GetOutput());
  { // a vector, and NaN values
    vtkNew<vtkDoubleArray> vector;
    vector->SetName("SeparatingFunction");
    vector->SetNumberOfComponents(3);
    vector->SetNumberOfTuples(mesh->GetNumberOfPoints());
    vector->FillValue(1.0);
    mesh->GetPointData()->AddArray(vector);
    vtkNew<stmMarchingSimplices> cut;
    cut->SetInputData(mesh);
    check(cut, "it must be a scalar");
    vtkNew<vtkFloatArray> nan;
    nan->SetName("SeparatingFunction");
    nan->SetNumberOfTuples(mesh->GetNumberOfPoints());
    nan->FillValue(1.0f);
    nan->SetValue(3, std::nanf(""));
    mesh->GetPointData()->AddArray(nan);
    cut->Modified();
    check(cut, "NaN");
  }
  { // an empty mesh
    vtkNew<vtkUnstructuredGrid> empty;
    vtkNew<stmMarchingSimplices> cut;
    cut->SetInputData(empty);
    check(cut, "no cells");
  }
  { // no implicit function, no gray image
    vtkNew<stmSeparatingFunction> function;
    function->SetInputData(mesh);
    check(function, "no implicit function");
    function->SetMode(stmSeparatingFunction::GRAY_IMAGE);
    check(function, "no gray image");
  }
  { // parameters are clamped
    vtkNew<stmMarchingSimplices> cut;
    cut->SetZeroTolerance(-1);
    EXPECT_EQ(cut->GetZeroTolerance(), 0.0);
    cut->SetOutputMode(7);
    EXPECT_EQ(cut->GetOutputMode(), stmMarchingSimplices::SURFACE);
    cut->SetKeepSide(-2);
    EXPECT_EQ(cut->GetKeepSide(), stmMarchingSimplices::BOTH);
  }
}
} // namespace
