// SPDX-License-Identifier: BSD-3-Clause
// stmBoundarySmooth through the VTK pipeline: the analytic ball (Taubin keeps the inside
// volume, Laplacian shrinks it, no inverted cell, no worse element, the box fixed), projection
// onto the sphere, a 2D disk, the AAL brain mask through the default pipeline, and bad input.

#include "stmFilterTestUtilities.h"
#include "stmVerdictQuality.h"

#include "stmBoundarySmooth.h"
#include "stmImageToSpacetree.h"
#include "stmMarchingSimplices.h"
#include "stmSeparatingFunction.h"
#include "stmSpacetreeBalance.h"
#include "stmSpacetreeTessellate.h"
#include "stmVertexSnap.h"

#include "vtkCellData.h"
#include "vtkCellType.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkImageData.h"
#include "vtkImageThreshold.h"
#include "vtkIntArray.h"
#include "vtkLookupTable.h"
#include "vtkMath.h"
#include "vtkNIFTIImageReader.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkSphere.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>

namespace
{
const int Axes3[3] = { 0, 1, 2 };
const int Axes2[2] = { 0, 1 };

double VolumeOfMaterial(const stm::MeshInvariantReport& report, int material)
{
  const auto found = report.VolumePerMaterial.find(material);
  return found == report.VolumePerMaterial.end() ? 0.0 : found->second;
}

/// The unit box, n^3 voxels, 5 tetrahedra each, cut by the sphere (both sides kept).
struct BallPipeline
{
  stmTest::UniformBallFunction Ball;
  vtkNew<stmMarchingSimplices> Cut;

  BallPipeline(int n, double radius)
    : Ball(n, radius)
  {
    this->Cut->SetInputConnection(this->Ball.GetOutputPort());
    this->Cut->Update();
  }
  vtkUnstructuredGrid* Mesh() { return vtkUnstructuredGrid::SafeDownCast(this->Cut->GetOutput()); }
};

// The analytic ball after 20 iterations: Taubin keeps the inside volume within 0.5%, Laplacian
// shrinks it by more than 1%; both leave a valid mesh (every cell positive), the worst element
// no worse, the box's points unchanged, and the cells and arrays of the input.
TEST(BoundarySmoothFilter, AnalyticBallTaubinKeepsTheVolumeLaplacianShrinksIt)
{
  BallPipeline ball(20, 0.35);
  vtkUnstructuredGrid* input = ball.Mesh();
  const stm::MeshInvariantReport before = stmTest::CheckMesh<3>(input, Axes3, 1e-12);
  ASSERT_TRUE(before.IsValid()) << before.Summary();
  const double inside = VolumeOfMaterial(before, 1);
  const stmTest::VerdictQualityRange qualityBefore = stmTest::MeasureVerdictQuality(input);
  double changes[2] = { 0, 0 };
  for (const int method : { stmBoundarySmooth::TAUBIN, stmBoundarySmooth::LAPLACIAN })
  {
    vtkNew<stmBoundarySmooth> smooth;
    smooth->SetInputConnection(ball.Cut->GetOutputPort());
    smooth->SetMethod(method);
    smooth->Update();
    vtkUnstructuredGrid* mesh = smooth->GetOutput();
    ASSERT_EQ(mesh->GetNumberOfCells(), input->GetNumberOfCells());
    ASSERT_EQ(mesh->GetNumberOfPoints(), input->GetNumberOfPoints());
    const stm::MeshInvariantReport report = stmTest::CheckMesh<3>(mesh, Axes3, 1e-12);
    EXPECT_TRUE(report.IsValid()) << report.Summary();
    EXPECT_NEAR(report.TotalVolume, before.TotalVolume, 1e-9 * before.TotalVolume);
    const stmTest::VerdictQualityRange quality = stmTest::MeasureVerdictQuality(mesh);
    EXPECT_LE(quality.WorstCondition, qualityBefore.WorstCondition * (1 + 1e-9));
    EXPECT_GE(quality.SmallestAngle, qualityBefore.SmallestAngle * (1 - 1e-9));
    changes[method] = (VolumeOfMaterial(report, 1) - inside) / inside;
    EXPECT_GT(smooth->GetNumberOfMovedPoints(), 1000);
    ASSERT_NE(mesh->GetPointData()->GetArray("SmoothingDisplacement"), nullptr);
    ASSERT_NE(mesh->GetPointData()->GetArray("SeparatingFunction"), nullptr);
    ASSERT_NE(mesh->GetCellData()->GetArray("OriginalMaterial"), nullptr);
    EXPECT_EQ(mesh->GetPoints()->GetDataType(), input->GetPoints()->GetDataType());
    vtkIdType boxPoints = 0;
    double bounds[6];
    input->GetBounds(bounds);
    for (vtkIdType p = 0; p < mesh->GetNumberOfPoints(); ++p)
    {
      double x[3], y[3];
      input->GetPoint(p, x);
      bool onBox = false;
      for (int axis = 0; axis < 3; ++axis)
      {
        onBox = onBox || x[axis] == bounds[2 * axis] || x[axis] == bounds[2 * axis + 1];
      }
      if (onBox)
      {
        ++boxPoints;
        mesh->GetPoint(p, y);
        EXPECT_TRUE(x[0] == y[0] && x[1] == y[1] && x[2] == y[2]) << "box point " << p;
      }
    }
    EXPECT_EQ(boxPoints, 21 * 21 * 21 - 19 * 19 * 19);
    std::cout << (method == stmBoundarySmooth::TAUBIN ? "Taubin" : "Laplacian")
              << ", analytic ball n = 20, 20 iterations: inside volume " << inside << " -> "
              << VolumeOfMaterial(report, 1) << " (" << 100 * changes[method] << " %), "
              << smooth->GetNumberOfMovedPoints() << " moved, "
              << smooth->GetNumberOfRejectedMoves() << " rejected, worst condition "
              << qualityBefore.WorstCondition << " -> " << quality.WorstCondition
              << ", smallest dihedral " << qualityBefore.SmallestAngle << " -> "
              << quality.SmallestAngle << "\n";
  }
  EXPECT_LT(std::abs(changes[stmBoundarySmooth::TAUBIN]), 0.005);
  EXPECT_LT(changes[stmBoundarySmooth::LAPLACIAN], -0.01);
}

// Projection onto the sphere: every moved surface point lies on it (the points of split interior
// edges, appended after the input's, lie inside); MaxDisplacement holds.
TEST(BoundarySmoothFilter, ProjectionAndMaxDisplacement)
{
  BallPipeline ball(16, 0.35);
  vtkUnstructuredGrid* input = ball.Mesh();
  vtkNew<stmBoundarySmooth> smooth;
  smooth->SetInputConnection(ball.Cut->GetOutputPort());
  smooth->SetImplicitFunction(ball.Ball.Sphere);
  smooth->ProjectToFunctionOn();
  smooth->SetNumberOfInteriorLayers(0);
  smooth->Update();
  vtkUnstructuredGrid* mesh = smooth->GetOutput();
  EXPECT_TRUE(stmTest::CheckMesh<3>(mesh, Axes3, 1e-12).IsValid());
  vtkIdType moved = 0;
  ASSERT_GE(mesh->GetNumberOfPoints(), input->GetNumberOfPoints());
  for (vtkIdType p = 0; p < input->GetNumberOfPoints(); ++p)
  {
    double x[3], y[3];
    input->GetPoint(p, x);
    mesh->GetPoint(p, y);
    if (x[0] != y[0] || x[1] != y[1] || x[2] != y[2])
    {
      ++moved;
      EXPECT_NEAR(
        std::sqrt(vtkMath::Distance2BetweenPoints(y, ball.Ball.Sphere->GetCenter())), 0.35, 1e-6);
    }
  }
  EXPECT_EQ(moved, smooth->GetNumberOfMovedPoints());
  EXPECT_GT(moved, 500);

  smooth->ProjectToFunctionOff();
  smooth->SetMethod(stmBoundarySmooth::LAPLACIAN);
  smooth->SetMaxDisplacement(0.002);
  smooth->Update();
  vtkDataArray* displacement =
    smooth->GetOutput()->GetPointData()->GetArray("SmoothingDisplacement");
  ASSERT_NE(displacement, nullptr);
  double largest = 0.0;
  for (vtkIdType p = 0; p < displacement->GetNumberOfTuples(); ++p)
  {
    largest = std::max(largest, vtkMath::Norm(displacement->GetTuple3(p)));
  }
  EXPECT_LE(largest, 0.002 * (1 + 1e-9));
  EXPECT_GT(largest, 0.0015);
}

// 2D: a disk of labels cut by the default function stays a valid triangle mesh with no worse
// triangle, the pixel frame (background) fixed.
TEST(BoundarySmoothFilter, TwoDimensionalDisk)
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
  vtkNew<stmBoundarySmooth> smooth;
  smooth->SetInputConnection(cut->GetOutputPort());
  smooth->Update();
  vtkUnstructuredGrid* input = vtkUnstructuredGrid::SafeDownCast(cut->GetOutput());
  const stm::MeshInvariantReport before = stmTest::CheckMesh<2>(input, Axes2, 1e-9);
  const stm::MeshInvariantReport after = stmTest::CheckMesh<2>(smooth->GetOutput(), Axes2, 1e-9);
  EXPECT_TRUE(after.IsValid()) << after.Summary();
  EXPECT_NEAR(after.TotalVolume, before.TotalVolume, 1e-9 * before.TotalVolume);
  EXPECT_NEAR(
    VolumeOfMaterial(after, 3), VolumeOfMaterial(before, 3), 0.01 * VolumeOfMaterial(before, 3));
  EXPECT_GT(smooth->GetNumberOfMovedPoints(), 20);
  EXPECT_LE(stmTest::MeasureVerdictQuality(smooth->GetOutput()).WorstCondition,
    stmTest::MeasureVerdictQuality(input).WorstCondition * (1 + 1e-9));
}

/// Runs only the interior edge splits on `mesh` (no smoothing, no improvement, condition bound
/// 2), expects one split edge and the given sizes, and returns the new (last) point.
std::array<double, 3> SplitOnly(
  vtkUnstructuredGrid* mesh, stmBoundarySmooth* smooth, vtkIdType points, vtkIdType cells)
{
  smooth->SetInputData(mesh);
  smooth->SetNumberOfIterations(0);
  smooth->SetNumberOfImprovementSweeps(0);
  smooth->SetMaxConditionNumber(2.0);
  smooth->Update();
  vtkUnstructuredGrid* output = smooth->GetOutput();
  EXPECT_EQ(smooth->GetNumberOfSplitEdges(), 1);
  EXPECT_EQ(output->GetNumberOfPoints(), points);
  EXPECT_EQ(output->GetNumberOfCells(), cells);
  std::array<double, 3> x{};
  if (output->GetNumberOfPoints() == points)
  {
    output->GetPoint(points - 1, x.data());
  }
  return x;
}

// SplitInteriorEdges through the filter: six needle tetrahedra of Material 4 around the edge
// from (0, 0, -1) to (0, 0, 1) and a hexagon of radius 0.35 (condition number 2.57, bound set to
// 2, no smoothing or improvement). The edge is split at its midpoint: one point appended with
// its point data interpolated (a "Tag" of 10 and 20 at the ends gives 15) and a zero
// SmoothingDisplacement, six cells appended with their parents' cell data, a valid mesh with
// the same volume and a worst condition number of 1.86. With the option off nothing changes, and
// neither does it when a ghost cell (a piece's) holds the edge's ends.
TEST(BoundarySmoothFilter, SplitInteriorEdgesOfNeedles)
{
  vtkNew<vtkUnstructuredGrid> star;
  vtkNew<vtkPoints> points;
  points->InsertNextPoint(0.0, 0.0, -1.0);
  points->InsertNextPoint(0.0, 0.0, 1.0);
  vtkNew<vtkDoubleArray> tag;
  tag->SetName("Tag");
  tag->InsertNextValue(10.0);
  tag->InsertNextValue(20.0);
  for (int k = 0; k < 6; ++k)
  {
    const double angle = k * vtkMath::Pi() / 3.0;
    points->InsertNextPoint(0.35 * std::cos(angle), 0.35 * std::sin(angle), 0.0);
    tag->InsertNextValue(0.0);
  }
  // What a deep copy keeps, the extended copies of the split keep too.
  tag->SetComponentName(0, "Level");
  tag->CreateDefaultLookupTable();
  star->SetPoints(points);
  star->GetPointData()->AddArray(tag);
  vtkNew<vtkIntArray> material;
  material->SetName("Material");
  for (int k = 0; k < 6; ++k)
  {
    // Corners ordered for VTK's (positive) orientation: the hexagon runs counter-clockwise.
    const vtkIdType ids[4] = { 0, 1, 2 + k, 2 + (k + 1) % 6 };
    star->InsertNextCell(VTK_TETRA, 4, ids);
    material->InsertNextValue(4);
  }
  star->GetCellData()->AddArray(material);
  const stm::MeshInvariantReport before = stmTest::CheckMesh<3>(star, Axes3, 1e-9);
  ASSERT_TRUE(before.IsValid()) << before.Summary();

  vtkNew<stmBoundarySmooth> smooth;
  const std::array<double, 3> added = SplitOnly(star, smooth, 9, 12);
  EXPECT_EQ(added, (std::array<double, 3>{ 0.0, 0.0, 0.0 }));
  vtkUnstructuredGrid* output = smooth->GetOutput();
  ASSERT_EQ(output->GetNumberOfPoints(), 9);
  vtkDataArray* splitTag = output->GetPointData()->GetArray("Tag");
  ASSERT_NE(splitTag, nullptr);
  EXPECT_EQ(splitTag->GetTuple1(0), 10.0);
  EXPECT_EQ(splitTag->GetTuple1(1), 20.0);
  EXPECT_EQ(splitTag->GetTuple1(8), 15.0);
  ASSERT_NE(splitTag->GetComponentName(0), nullptr);
  EXPECT_STREQ(splitTag->GetComponentName(0), "Level");
  ASSERT_NE(splitTag->GetLookupTable(), nullptr);
  EXPECT_NE(splitTag->GetLookupTable(), tag->GetLookupTable());
  EXPECT_EQ(splitTag->GetLookupTable()->GetNumberOfTableValues(),
    tag->GetLookupTable()->GetNumberOfTableValues());
  vtkDataArray* displacement = output->GetPointData()->GetArray("SmoothingDisplacement");
  ASSERT_NE(displacement, nullptr);
  EXPECT_EQ(vtkMath::Norm(displacement->GetTuple3(8)), 0.0);
  vtkDataArray* materials = output->GetCellData()->GetArray("Material");
  ASSERT_NE(materials, nullptr);
  for (vtkIdType c = 0; c < 12; ++c)
  {
    EXPECT_EQ(materials->GetTuple1(c), 4.0);
  }
  const stm::MeshInvariantReport after = stmTest::CheckMesh<3>(output, Axes3, 1e-9);
  EXPECT_TRUE(after.IsValid()) << after.Summary();
  EXPECT_NEAR(after.TotalVolume, before.TotalVolume, 1e-14);
  EXPECT_EQ(after.BoundaryFacets, before.BoundaryFacets);
  EXPECT_NEAR(stmTest::MeasureVerdictQuality(star).WorstCondition, 2.57477, 1e-5);
  EXPECT_NEAR(stmTest::MeasureVerdictQuality(output).WorstCondition, 1.86476, 1e-5);

  smooth->SplitInteriorEdgesOff();
  smooth->Update();
  EXPECT_EQ(smooth->GetNumberOfSplitEdges(), 0);
  EXPECT_EQ(smooth->GetOutput()->GetNumberOfPoints(), 8);
  EXPECT_EQ(smooth->GetOutput()->GetNumberOfCells(), 6);

  // In a piece the points of its ghost cells are held, and an edge with a held end is not
  // split: here one ghost cell holds both ends of the star's edge.
  vtkNew<vtkUnsignedCharArray> ghosts;
  ghosts->SetName(vtkDataSetAttributes::GhostArrayName());
  ghosts->SetNumberOfValues(6);
  ghosts->FillValue(0);
  ghosts->SetValue(3, vtkDataSetAttributes::DUPLICATECELL);
  star->GetCellData()->AddArray(ghosts);
  smooth->SplitInteriorEdgesOn();
  smooth->Update();
  EXPECT_EQ(smooth->GetNumberOfSplitEdges(), 0);
  EXPECT_EQ(smooth->GetOutput()->GetNumberOfPoints(), 8);
  EXPECT_EQ(smooth->GetOutput()->GetNumberOfCells(), 6);
}

// The same in 2D, in the plane z = 2.5: the edge from (-1, 0) to (1, 0) between triangles to
// (0, 0.3) and (0, -0.3) (condition number 2.97, bound 2) is split at (0, 0, 2.5).
TEST(BoundarySmoothFilter, SplitInteriorEdgesInAPlane)
{
  vtkNew<vtkUnstructuredGrid> pair;
  vtkNew<vtkPoints> points;
  points->InsertNextPoint(-1.0, 0.0, 2.5);
  points->InsertNextPoint(1.0, 0.0, 2.5);
  points->InsertNextPoint(0.0, 0.3, 2.5);
  points->InsertNextPoint(0.0, -0.3, 2.5);
  pair->SetPoints(points);
  const vtkIdType upper[3] = { 0, 1, 2 }, lower[3] = { 1, 0, 3 };
  pair->InsertNextCell(VTK_TRIANGLE, 3, upper);
  pair->InsertNextCell(VTK_TRIANGLE, 3, lower);
  vtkNew<stmBoundarySmooth> smooth;
  const std::array<double, 3> added = SplitOnly(pair, smooth, 5, 4);
  EXPECT_EQ(added, (std::array<double, 3>{ 0.0, 0.0, 2.5 }));
  vtkUnstructuredGrid* output = smooth->GetOutput();
  const stm::MeshInvariantReport before = stmTest::CheckMesh<2>(pair, Axes2, 1e-9);
  const stm::MeshInvariantReport after = stmTest::CheckMesh<2>(output, Axes2, 1e-9);
  EXPECT_TRUE(after.IsValid()) << after.Summary();
  EXPECT_NEAR(after.TotalVolume, before.TotalVolume, 1e-14);
  EXPECT_NEAR(stmTest::MeasureVerdictQuality(output).WorstCondition, 2.09771, 1e-5);
}

// The AAL brain mask through the default pipeline (labels function, quality-driven snapping,
// cut, 20 Taubin iterations), the acceptance check: a valid mesh, no inverted cell, the
// worst condition number at most 3.5 and the smallest dihedral angle at least 15 degrees (the
// true one, from the core's measure: vtkMeshQuality's tetrahedron minimum angle in VTK 9.2 is
// not), the inside volume within 1% of the voxels', and nothing worse than before smoothing.
TEST(BoundarySmoothFilter, AalBrainMask)
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
  vtkNew<stmVertexSnap> snap;
  snap->SetInputConnection(tessellate->GetOutputPort());
  vtkNew<stmMarchingSimplices> cut;
  cut->SetInputConnection(snap->GetOutputPort());
  cut->Update();
  vtkUnstructuredGrid* input = vtkUnstructuredGrid::SafeDownCast(cut->GetOutput());
  const stm::MeshInvariantReport before = stmTest::CheckMesh<3>(input, Axes3, 1e-9);
  const stmTest::TetrahedronShapes shapeBefore = stmTest::MeasureTetrahedronShapes(input);

  vtkNew<stmBoundarySmooth> smooth;
  smooth->SetInputConnection(cut->GetOutputPort());
  const auto start = std::chrono::steady_clock::now();
  smooth->Update();
  const double seconds =
    std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  vtkUnstructuredGrid* mesh = smooth->GetOutput();
  const stm::MeshInvariantReport report = stmTest::CheckMesh<3>(mesh, Axes3, 1e-9);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_NEAR(report.TotalVolume, before.TotalVolume, 1e-9 * before.TotalVolume);
  const double inside = VolumeOfMaterial(report, 1);
  EXPECT_NEAR(inside, voxelVolume, 0.01 * voxelVolume);
  const stmTest::TetrahedronShapes shape = stmTest::MeasureTetrahedronShapes(mesh);
  EXPECT_EQ(shape.NonPositive, 0);
  EXPECT_LE(shape.WorstCondition, 3.5);
  EXPECT_GE(shape.SmallestDihedral, 15.0);
  EXPECT_LE(shape.WorstCondition, shapeBefore.WorstCondition * (1 + 1e-9));
  EXPECT_GE(shape.SmallestDihedral, shapeBefore.SmallestDihedral * (1 - 1e-9));
  std::cout << "AAL brain mask, default pipeline (quality-driven snap, cut, Taubin 20): "
            << mesh->GetNumberOfCells() << " tetrahedra, " << snap->GetNumberOfSnappedPoints()
            << " points snapped, " << smooth->GetNumberOfMovedPoints() << " points moved, "
            << smooth->GetNumberOfRejectedMoves() << " moves rejected; inside volume "
            << VolumeOfMaterial(before, 1) << " -> " << inside << " mm3 (voxels " << voxelVolume
            << ", " << 100 * (inside - voxelVolume) / voxelVolume << " %); worst condition "
            << shapeBefore.WorstCondition << " -> " << shape.WorstCondition
            << ", smallest dihedral " << shapeBefore.SmallestDihedral << " -> "
            << shape.SmallestDihedral << " degrees; smoothing " << seconds << " s\n";
}

TEST(BoundarySmoothFilter, BadInputGetsClearErrors)
{
  const auto check = stmTest::ExpectErrorAndEmptyOutput;
  auto tree = stmTest::BadInputTree(0);
  tree->Update();
  { // hexahedra
    vtkNew<stmBoundarySmooth> smooth;
    smooth->SetInputData(tree->GetOutput());
    check(smooth, "only tetrahedra or only triangles");
  }
  { // no cells
    vtkNew<vtkUnstructuredGrid> empty;
    vtkNew<stmBoundarySmooth> smooth;
    smooth->SetInputData(empty);
    check(smooth, "no cells");
  }
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetInputConnection(tree->GetOutputPort());
  { // the tessellation has Material, but neither OriginalMaterial nor OriginalMaterialVolumes
    vtkNew<stmBoundarySmooth> restore;
    restore->SetInputConnection(tessellate->GetOutputPort());
    restore->RestoreOriginalVolumesOn();
    check(restore, "RestoreOriginalVolumes needs the cell array Material, and the field array");
  }
  vtkNew<stmMarchingSimplices> cut;
  cut->SetInputConnection(tessellate->GetOutputPort());
  cut->Update();
  vtkNew<stmBoundarySmooth> smooth;
  smooth->SetInputConnection(cut->GetOutputPort());
  smooth->SetRelaxationFactor(0.0);
  check(smooth, "RelaxationFactor must be in (0, 1]");
  smooth->SetRelaxationFactor(0.5);
  smooth->SetPassBand(1.5);
  check(smooth, "PassBand must be in (0, 1)");
  smooth->SetPassBand(0.1);
  smooth->SetMaxConditionNumber(0.5);
  check(smooth, "MaxConditionNumber must be >= 1");
  smooth->SetMaxConditionNumber(3.5);
  smooth->SetMinDihedralAngle(-1);
  check(smooth, "MinDihedralAngle must be in [0, 180)");
  smooth->SetMinDihedralAngle(15);
  smooth->SetNumberOfImprovementSweeps(-3); // clamped to [0, 100]
  EXPECT_EQ(smooth->GetNumberOfImprovementSweeps(), 0);
  smooth->SetNumberOfImprovementSweeps(1000);
  EXPECT_EQ(smooth->GetNumberOfImprovementSweeps(), 100);
  smooth->SetNumberOfImprovementSweeps(10);
  smooth->ProjectToFunctionOn();
  check(smooth, "no ImplicitFunction");
  smooth->ProjectToFunctionOff();
  smooth->SetNumberOfIterations(100000); // clamped
  EXPECT_EQ(smooth->GetNumberOfIterations(), 1000);
  smooth->SetNumberOfIterations(2);
  smooth->Update();
  EXPECT_GT(smooth->GetOutput()->GetNumberOfCells(), 0);
  // Without Material every cell is one body: the outer boundary is the surface.
  vtkNew<vtkUnstructuredGrid> unlabelled;
  unlabelled->ShallowCopy(cut->GetOutput());
  unlabelled->GetCellData()->RemoveArray("Material");
  vtkNew<stmBoundarySmooth> plain;
  plain->SetInputData(unlabelled);
  plain->Update();
  EXPECT_TRUE(stmTest::CheckMesh<3>(plain->GetOutput(), Axes3, 1e-9).IsValid());
  EXPECT_GT(plain->GetNumberOfMovedPoints(), 0);
}

} // namespace
