// SPDX-License-Identifier: BSD-3-Clause
// The refinement options of the filters on synthetic images: patterns and the level table in the
// field data, given root cells, per-label sizes, a region refined below the voxel size, a sizing
// array, grading, per-label and regional balance levels; every mesh checked by the core's
// invariant checker with exact volumes per label; and a clear error for every bad parameter.

#include "stmFilterTestUtilities.h"

#include "vtkBox.h"
#include "vtkCallbackCommand.h"
#include "vtkCellData.h"
#include "vtkCommand.h"
#include "vtkDoubleArray.h"
#include "vtkExecutive.h"
#include "vtkFieldData.h"
#include "vtkPlane.h"
#include "vtkPointData.h"
#include "vtkSphere.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace
{
const int Dims[3] = { 40, 36, 24 };
const double UnitSpacing[3] = { 1, 1, 1 };
const double Origin[3] = { 0, 0, 0 };

vtkSmartPointer<vtkImageData> Ellipsoids(const double spacing[3] = UnitSpacing)
{
  return stmTest::MakeLabelImage(Dims, spacing, Origin,
    [](int i, int j, int k) { return stmTest::NestedEllipsoids(i, j, k, Dims); });
}

std::vector<int> FieldInts(vtkDataObject* data, const char* name)
{
  std::vector<int> values;
  vtkDataArray* array = data->GetFieldData()->GetArray(name);
  for (vtkIdType i = 0; array && i < array->GetNumberOfTuples(); ++i)
  {
    values.push_back(static_cast<int>(array->GetComponent(i, 0)));
  }
  return values;
}

/// Valid mesh whose label volumes equal the voxel counts times the voxel volume.
void ExpectExactMesh(vtkUnstructuredGrid* mesh, vtkImageData* image)
{
  const int axes[3] = { 0, 1, 2 };
  const stm::MeshInvariantReport report = stmTest::CheckMesh<3>(mesh, axes, 1e-9);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  double spacing[3];
  image->GetSpacing(spacing);
  const double voxel = spacing[0] * spacing[1] * spacing[2];
  for (const auto& [label, count] : stmTest::CountLabels(image))
  {
    if (label != 0)
    {
      ASSERT_EQ(report.VolumePerMaterial.count(label), 1u) << "label " << label;
      EXPECT_NEAR(report.VolumePerMaterial.at(label), count * voxel, 1e-9 * count * voxel)
        << "label " << label;
    }
  }
}

/// Runs a filter expecting failure; returns the error text.
std::string ExpectFailure(vtkAlgorithm* filter)
{
  std::string messages;
  vtkNew<vtkCallbackCommand> callback;
  callback->SetClientData(&messages);
  callback->SetCallback([](vtkObject*, unsigned long, void* text, void* message)
    { *static_cast<std::string*>(text) += static_cast<const char*>(message); });
  filter->AddObserver(vtkCommand::ErrorEvent, callback);
  filter->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, callback);
  filter->Update();
  filter->RemoveObservers(vtkCommand::ErrorEvent);
  filter->GetExecutive()->RemoveObservers(vtkCommand::ErrorEvent);
  EXPECT_FALSE(messages.empty()) << "no error reported";
  return messages;
}

TEST(RefinementCriteria, PatternsLandInTheLevelTableAndMeshExactly)
{
  auto image = Ellipsoids();
  struct Expected
  {
    const char* Pattern;
    std::vector<int> CellSizes;
  };
  for (const Expected& expected : { Expected{ "3x3x3", { 27, 27, 27, 9, 9, 9, 3, 3, 3, 1, 1, 1 } },
         Expected{ "2x2x1,2x2x2", { 16, 16, 8, 8, 8, 4, 4, 4, 2, 2, 2, 1, 1, 1, 1 } },
         Expected{ "2X2x2", { 16, 16, 16, 8, 8, 8, 4, 4, 4, 2, 2, 2, 1, 1, 1 } } })
  {
    SCOPED_TRACE(expected.Pattern);
    stmTest::Pipeline pipeline;
    pipeline.Tree->SetRefinementPattern(expected.Pattern);
    pipeline.Tree->SetMaxCellSize(27);
    vtkUnstructuredGrid* mesh = pipeline.Run(image, 1);
    EXPECT_EQ(FieldInts(pipeline.Tree->GetOutput(), "SpacetreeCellSizes"), expected.CellSizes);
    EXPECT_EQ(FieldInts(pipeline.Balance->GetOutput(), "SpacetreeCellSizes"), expected.CellSizes);
    ExpectExactMesh(mesh, image);
  }
}

TEST(RefinementCriteria, AutomaticPatternFollowsTheVoxelShape)
{
  const double spacing[3] = { 0.5, 0.5, 1.0 };
  auto image = Ellipsoids(spacing);
  stmTest::Pipeline pipeline;
  vtkUnstructuredGrid* mesh = pipeline.Run(image, 1);
  EXPECT_EQ(FieldInts(pipeline.Tree->GetOutput(), "SpacetreeCellSizes"),
    (std::vector<int>{ 16, 16, 8, 8, 8, 4, 4, 4, 2, 2, 2, 1, 1, 1, 1 }));
  ExpectExactMesh(mesh, image);
}

TEST(RefinementCriteria, GivenRootCellSize)
{
  auto image = Ellipsoids();
  stmTest::Pipeline pipeline;
  pipeline.Tree->SetRootCellSize(8, 8, 4);
  vtkUnstructuredGrid* mesh = pipeline.Run(image, 1);
  EXPECT_EQ(FieldInts(pipeline.Tree->GetOutput(), "SpacetreeCellSizes"),
    (std::vector<int>{ 8, 8, 4, 4, 4, 4, 2, 2, 2, 1, 1, 1 })); // cubes first, then x and y alone
  EXPECT_EQ(FieldInts(pipeline.Tree->GetOutput(), "SpacetreeRootGridDimensions"),
    (std::vector<int>{ 5, 5, 6 }));
  ExpectExactMesh(mesh, image);
}

TEST(RefinementCriteria, LabelSizeLimitsOnlyThatLabel)
{
  auto image = Ellipsoids();
  stmTest::Pipeline plain, limited;
  plain.Run(image, 0);
  limited.Tree->SetLabelMaxCellSize(1, 2);
  vtkUnstructuredGrid* mesh = limited.Run(image, 0);
  vtkUnstructuredGrid* before = plain.Tree->GetOutput();
  vtkUnstructuredGrid* after = limited.Tree->GetOutput();
  EXPECT_GT(after->GetNumberOfCells(), before->GetNumberOfCells());
  auto largestLeaf = [](vtkUnstructuredGrid* tree, int label)
  {
    double largest = 0;
    for (vtkIdType c = 0; c < tree->GetNumberOfCells(); ++c)
    {
      if (tree->GetCellData()->GetArray("Material")->GetComponent(c, 0) == label)
      {
        double bounds[6];
        tree->GetCellBounds(c, bounds);
        largest = std::max(largest, bounds[1] - bounds[0]);
      }
    }
    return largest;
  };
  EXPECT_EQ(largestLeaf(after, 1), 2.0);
  EXPECT_EQ(largestLeaf(after, 2), largestLeaf(before, 2));
  ExpectExactMesh(mesh, image);
}

TEST(RefinementCriteria, RegionRefinesBelowTheVoxelInsideOnly)
{
  auto image = Ellipsoids();
  vtkNew<vtkBox> box;
  box->SetBounds(10, 20, 10, 20, 8, 16);
  stmTest::Pipeline pipeline;
  pipeline.Tree->SetRefinementRegion(box);
  pipeline.Tree->SetRegionMaxCellSize(0.5);
  vtkUnstructuredGrid* mesh = pipeline.Run(image, 1);
  vtkUnstructuredGrid* tree = pipeline.Tree->GetOutput();
  EXPECT_EQ(FieldInts(tree, "SpacetreeVoxelSubdivision"), (std::vector<int>{ 2, 2, 2 }));
  // Point-data voxels are centred on their points: voxel i spans [i - 0.5, i + 0.5]. Voxels with
  // centres in [10, 20] x [10, 20] x [8, 16] are refined to half voxels; no other voxel is.
  vtkIdType halfLeaves = 0, halfOutside = 0;
  for (vtkIdType c = 0; c < tree->GetNumberOfCells(); ++c)
  {
    double bounds[6];
    tree->GetCellBounds(c, bounds);
    if (bounds[1] - bounds[0] == 0.5)
    {
      ++halfLeaves;
      const double centre[3] = { 0.5 * (bounds[0] + bounds[1]), 0.5 * (bounds[2] + bounds[3]),
        0.5 * (bounds[4] + bounds[5]) };
      halfOutside += !(centre[0] > 9.5 && centre[0] < 20.5 && centre[1] > 9.5 && centre[1] < 20.5 &&
        centre[2] > 7.5 && centre[2] < 16.5);
    }
  }
  EXPECT_EQ(halfLeaves, 11 * 11 * 9 * 8);
  EXPECT_EQ(halfOutside, 0);
  ExpectExactMesh(mesh, image);
}

TEST(RefinementCriteria, PlaneSlabRegionRefinesABand)
{
  auto image = Ellipsoids();
  vtkNew<vtkPlane> plane;
  plane->SetOrigin(20, 0, 0);
  plane->SetNormal(1, 0, 0);
  stmTest::Pipeline pipeline;
  pipeline.Tree->SetRefinementRegion(plane);
  pipeline.Tree->SetRegionMaxCellSize(0.5);
  pipeline.Tree->SetRegionBandWidth(3);
  vtkUnstructuredGrid* mesh = pipeline.Run(image, 1);
  vtkUnstructuredGrid* tree = pipeline.Tree->GetOutput();
  vtkIdType halfLeaves = 0;
  for (vtkIdType c = 0; c < tree->GetNumberOfCells(); ++c)
  {
    double bounds[6];
    tree->GetCellBounds(c, bounds);
    halfLeaves += bounds[1] - bounds[0] == 0.5;
  }
  // Voxel centres 19, 20, 21 lie within 1.5 of x = 20: three full voxel slices.
  EXPECT_EQ(halfLeaves, 3 * Dims[1] * Dims[2] * 8);
  ExpectExactMesh(mesh, image);
}

TEST(RefinementCriteria, SizingArrayAndGrading)
{
  auto image = Ellipsoids();
  vtkNew<vtkDoubleArray> sizing;
  sizing->SetName("sizing");
  sizing->SetNumberOfValues(image->GetNumberOfPoints());
  for (vtkIdType v = 0; v < image->GetNumberOfPoints(); ++v)
  {
    sizing->SetValue(v, v % Dims[0] < 20 ? 2.0 : 100.0); // at most 2 in the lower half of x
  }
  image->GetPointData()->AddArray(sizing);
  stmTest::Pipeline plain, sized, graded;
  plain.Run(image, 1);
  sized.Tree->SetInputArrayToProcess(1, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, "sizing");
  sized.Tree->UseSizingArrayOn();
  vtkUnstructuredGrid* sizedMesh = sized.Run(image, 1);
  graded.Tree->SetGrading(2);
  vtkUnstructuredGrid* gradedMesh = graded.Run(image, 1);
  EXPECT_GT(
    sized.Tree->GetOutput()->GetNumberOfCells(), plain.Tree->GetOutput()->GetNumberOfCells());
  EXPECT_GT(
    graded.Tree->GetOutput()->GetNumberOfCells(), plain.Tree->GetOutput()->GetNumberOfCells());
  vtkUnstructuredGrid* tree = sized.Tree->GetOutput();
  vtkIdType tooLarge = 0;
  for (vtkIdType c = 0; c < tree->GetNumberOfCells(); ++c)
  {
    double bounds[6];
    tree->GetCellBounds(c, bounds);
    // Leaves over voxels with sizing 2 (x < 20; not the padding beyond the image in y, z).
    const bool sized = bounds[0] < 19.5 && bounds[3] < Dims[1] && bounds[5] < Dims[2];
    tooLarge += sized && bounds[1] - bounds[0] > 2.0;
  }
  EXPECT_EQ(tooLarge, 0);
  ExpectExactMesh(sizedMesh, image);
  ExpectExactMesh(gradedMesh, image);
}

TEST(RefinementCriteria, LocalBalanceLevels)
{
  auto image = Ellipsoids();
  auto balancedLeaves = [&](const std::function<void(stmSpacetreeBalance*)>& configure)
  {
    stmTest::Pipeline pipeline;
    pipeline.Balance->SetBalanceLevel(3);
    configure(pipeline.Balance);
    pipeline.Tree->SetInputData(image);
    pipeline.Balance->SetInputConnection(pipeline.Tree->GetOutputPort());
    pipeline.Tessellate->SetInputConnection(pipeline.Balance->GetOutputPort());
    pipeline.Tessellate->Update();
    ExpectExactMesh(pipeline.Tessellate->GetOutput(), image);
    return pipeline.Balance->GetOutput()->GetNumberOfCells();
  };
  const vtkIdType loose = balancedLeaves([](stmSpacetreeBalance*) {});
  const vtkIdType tight = balancedLeaves([](stmSpacetreeBalance* b) { b->SetBalanceLevel(1); });
  const vtkIdType perLabel =
    balancedLeaves([](stmSpacetreeBalance* b) { b->SetLabelBalanceLevel(1, 1); });
  vtkNew<vtkSphere> sphere;
  sphere->SetCenter(20, 18, 12);
  sphere->SetRadius(8);
  const vtkIdType regional = balancedLeaves(
    [&](stmSpacetreeBalance* b)
    {
      b->SetBalanceRegion(sphere);
      b->SetRegionBalanceLevel(1);
    });
  EXPECT_LT(loose, perLabel);
  EXPECT_LE(perLabel, tight);
  EXPECT_LT(loose, regional);
  EXPECT_LT(regional, tight);
}

TEST(RefinementCriteria, BadParametersGetClearErrors)
{
  auto image = Ellipsoids();
  auto treeError = [&](const std::function<void(stmImageToSpacetree*)>& configure)
  {
    vtkNew<stmImageToSpacetree> filter;
    filter->SetInputData(image);
    configure(filter);
    const std::string message = ExpectFailure(filter);
    EXPECT_EQ(filter->GetOutput()->GetNumberOfCells(), 0);
    return message;
  };
  auto contains = [](const std::string& text, const char* part)
  { return text.find(part) != std::string::npos; };
  EXPECT_TRUE(contains(treeError([](stmImageToSpacetree* f) { f->SetRefinementPattern("2x0x2"); }),
    "split counts must be between 1 and 8"));
  EXPECT_TRUE(contains(treeError([](stmImageToSpacetree* f) { f->SetRefinementPattern("-2x2x2"); }),
    "split counts must be between 1 and 8"));
  EXPECT_TRUE(contains(
    treeError([](stmImageToSpacetree* f) { f->SetRefinementPattern("1x1x1"); }), "splits no axis"));
  EXPECT_TRUE(contains(treeError([](stmImageToSpacetree* f) { f->SetRefinementPattern("2x2"); }),
    "has 2 split counts"));
  EXPECT_TRUE(contains(
    treeError([](stmImageToSpacetree* f) { f->SetRefinementPattern("cubes"); }), "not a list"));
  EXPECT_TRUE(contains(treeError([](stmImageToSpacetree* f) { f->SetRootCellSize(64, 8, 8); }),
    "larger than the image"));
  EXPECT_TRUE(contains(treeError([](stmImageToSpacetree* f) { f->SetRootCellSize(8, 0, 8); }),
    "RootCellSize must be positive"));
  EXPECT_TRUE(contains(treeError(
                         [](stmImageToSpacetree* f)
                         {
                           f->SetRefinementPattern("3x3x3");
                           f->SetRootCellSize(8, 8, 8);
                         }),
    "not reachable"));
  EXPECT_TRUE(contains(
    treeError([](stmImageToSpacetree* f) { f->SetLabelMaxCellSize(1, 0); }), "at least 1 voxel"));
  EXPECT_TRUE(contains(
    treeError([](stmImageToSpacetree* f) { f->SetLabelMaxCellSize(9, 2); }), "not in the body"));
  EXPECT_TRUE(contains(treeError([](stmImageToSpacetree* f) { f->SetRegionMaxCellSize(-1); }),
    "RegionMaxCellSize must be positive"));
  EXPECT_TRUE(contains(
    treeError([](stmImageToSpacetree* f) { f->SetRegionMaxCellSize(1); }), "no RefinementRegion"));
  vtkNew<vtkBox> outside;
  outside->SetBounds(100, 110, 100, 110, 100, 110);
  EXPECT_TRUE(contains(treeError(
                         [&](stmImageToSpacetree* f)
                         {
                           f->SetRefinementRegion(outside);
                           f->SetRegionMaxCellSize(0.5);
                         }),
    "contains no voxel centre"));
  vtkNew<vtkBox> inside;
  inside->SetBounds(0, 10, 0, 10, 0, 10);
  EXPECT_TRUE(contains(treeError(
                         [&](stmImageToSpacetree* f)
                         {
                           f->SetRefinementRegion(inside);
                           f->SetRegionMaxCellSize(1e-4);
                         }),
    "1/256 of a voxel"));
  EXPECT_TRUE(
    contains(treeError([](stmImageToSpacetree* f) { f->SetGrading(1.2); }), "Grading must be"));
  EXPECT_TRUE(
    contains(treeError([](stmImageToSpacetree* f) { f->UseSizingArrayOn(); }), "input array 1"));
  vtkNew<vtkDoubleArray> zeros;
  zeros->SetName("zeros");
  zeros->SetNumberOfValues(image->GetNumberOfPoints());
  zeros->Fill(0);
  image->GetPointData()->AddArray(zeros);
  EXPECT_TRUE(contains(treeError(
                         [](stmImageToSpacetree* f)
                         {
                           f->SetInputArrayToProcess(
                             1, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, "zeros");
                           f->UseSizingArrayOn();
                         }),
    "not positive and finite"));

  vtkNew<stmImageToSpacetree> tree;
  tree->SetInputData(image);
  vtkNew<stmSpacetreeBalance> balance;
  balance->SetInputConnection(tree->GetOutputPort());
  balance->SetLabelBalanceLevel(9, 1);
  EXPECT_TRUE(contains(ExpectFailure(balance), "not a body label"));
}
} // namespace
