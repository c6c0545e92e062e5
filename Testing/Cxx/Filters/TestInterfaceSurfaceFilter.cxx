// SPDX-License-Identifier: BSD-3-Clause
// stmInterfaceSurface through the VTK pipeline: nested ellipsoids (3D and a 2D slice) give
// facets whose BoundaryLabels and CellId match the input cells they were taken from, with the
// input's point data, and whose area per material pair is the area of the voxel faces between
// the labels; bad input gets clear errors.

#include "stmFilterTestUtilities.h"

#include "stmImageToSpacetree.h"
#include "stmInterfaceSurface.h"
#include "stmSpacetreeBalance.h"
#include "stmSpacetreeTessellate.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkIdTypeArray.h"
#include "vtkImageData.h"
#include "vtkIntArray.h"
#include "vtkMath.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkTriangle.h"
#include "vtkUnstructuredGrid.h"

#include <gtest/gtest.h>

#include <map>
#include <utility>

namespace
{
using Pair = std::pair<long long, long long>;

/// Voxel faces per label pair (smaller first; a label against background or the image border:
/// the label, then -1), times the face area.
std::map<Pair, double> VoxelFaceAreas(vtkImageData* image)
{
  int dims[3];
  image->GetDimensions(dims);
  const double* spacing = image->GetSpacing();
  vtkDataArray* labels = image->GetPointData()->GetScalars();
  auto at = [&](int i, int j, int k) -> long long
  {
    if (i < 0 || j < 0 || k < 0 || i >= dims[0] || j >= dims[1] || k >= dims[2])
    {
      return 0;
    }
    return static_cast<long long>(labels->GetTuple1(i + dims[0] * (j + dims[1] * k)));
  };
  const bool flat = dims[2] == 1;
  std::map<Pair, double> areas;
  for (int k = -1; k < dims[2]; ++k)
  {
    for (int j = -1; j < dims[1]; ++j)
    {
      for (int i = -1; i < dims[0]; ++i)
      {
        for (int axis = 0; axis < (flat ? 2 : 3); ++axis)
        {
          if ((flat && k != 0) || (axis != 0 && i < 0) || (axis != 1 && j < 0) ||
            (axis != 2 && k < 0))
          {
            continue;
          }
          const long long a = at(i, j, k);
          const long long b = at(i + (axis == 0), j + (axis == 1), k + (axis == 2));
          if (a == b)
          {
            continue;
          }
          const Pair key = a == 0 ? Pair{ b, -1 }
            : b == 0              ? Pair{ a, -1 }
                                  : Pair{ std::min(a, b), std::max(a, b) };
          const double face =
            flat ? spacing[1 - axis] : spacing[(axis + 1) % 3] * spacing[(axis + 2) % 3];
          areas[key] += face;
        }
      }
    }
  }
  return areas;
}

void CheckAgainstImage(vtkImageData* image, int dimension)
{
  vtkNew<stmImageToSpacetree> tree;
  tree->SetInputData(image);
  vtkNew<stmSpacetreeBalance> balance;
  balance->SetInputConnection(tree->GetOutputPort());
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetInputConnection(balance->GetOutputPort());
  tessellate->SetSeparatingFunction(stmSpacetreeTessellate::LABELS);
  vtkNew<stmInterfaceSurface> interfaces;
  interfaces->SetInputConnection(tessellate->GetOutputPort());
  interfaces->Update();
  auto* mesh = vtkUnstructuredGrid::SafeDownCast(tessellate->GetOutput());
  vtkPolyData* surface = interfaces->GetOutput();
  ASSERT_GT(surface->GetNumberOfCells(), 0);
  EXPECT_EQ(dimension == 3 ? surface->GetNumberOfPolys() : surface->GetNumberOfLines(),
    surface->GetNumberOfCells());
  auto* pairLabels = vtkIntArray::SafeDownCast(surface->GetCellData()->GetArray("BoundaryLabels"));
  auto* cellIds = vtkIdTypeArray::SafeDownCast(surface->GetCellData()->GetArray("CellId"));
  ASSERT_NE(pairLabels, nullptr);
  ASSERT_NE(cellIds, nullptr);
  ASSERT_EQ(pairLabels->GetNumberOfComponents(), 2);
  vtkDataArray* material = mesh->GetCellData()->GetArray("Material");
  vtkDataArray* function = mesh->GetPointData()->GetArray("SeparatingFunction");
  vtkDataArray* copiedFunction = surface->GetPointData()->GetArray("SeparatingFunction");
  ASSERT_NE(function, nullptr);
  ASSERT_NE(copiedFunction, nullptr);
  std::map<Pair, double> measured;
  vtkNew<vtkIdList> facet, cell;
  for (vtkIdType f = 0; f < surface->GetNumberOfCells(); ++f)
  {
    surface->GetCellPoints(f, facet);
    const vtkIdType source = cellIds->GetValue(f);
    mesh->GetCellPoints(source, cell);
    const long long first = pairLabels->GetTypedComponent(f, 0);
    const long long second = pairLabels->GetTypedComponent(f, 1);
    EXPECT_EQ(first, static_cast<long long>(material->GetTuple1(source)));
    // Every facet point is a point of its cell, with that point's data.
    for (vtkIdType k = 0; k < facet->GetNumberOfIds(); ++k)
    {
      double x[3];
      surface->GetPoint(facet->GetId(k), x);
      bool found = false;
      for (vtkIdType c = 0; c < cell->GetNumberOfIds() && !found; ++c)
      {
        double y[3];
        mesh->GetPoint(cell->GetId(c), y);
        found = vtkMath::Distance2BetweenPoints(x, y) == 0.0 &&
          copiedFunction->GetTuple1(facet->GetId(k)) == function->GetTuple1(cell->GetId(c));
      }
      EXPECT_TRUE(found) << "facet " << f;
    }
    double a[3], b[3], c[3];
    surface->GetPoint(facet->GetId(0), a);
    surface->GetPoint(facet->GetId(1), b);
    double size = std::sqrt(vtkMath::Distance2BetweenPoints(a, b));
    if (dimension == 3)
    {
      surface->GetPoint(facet->GetId(2), c);
      size = vtkTriangle::TriangleArea(a, b, c);
    }
    // The tessellation's background layer (Material 0) stands for the outside of the image.
    EXPECT_TRUE(second == -1 ? first != 0 : first < second) << "facet " << f;
    measured[second == -1 ? Pair{ first, -1 }
        : first == 0      ? Pair{ second, -1 }
                          : Pair{ first, second }] += size;
  }
  const std::map<Pair, double> expected = VoxelFaceAreas(image);
  ASSERT_EQ(measured.size(), expected.size());
  for (const auto& entry : expected)
  {
    EXPECT_NEAR(measured[entry.first], entry.second, 1e-9 * entry.second)
      << "pair " << entry.first.first << ", " << entry.first.second;
  }
}

TEST(InterfaceSurfaceFilter, NestedEllipsoidsMatchTheVoxelFaces)
{
  const int dims[3] = { 24, 20, 18 };
  const double spacing[3] = { 1.0, 0.8, 1.2 }, origin[3] = { 0, 0, 0 };
  auto image = stmTest::MakeLabelImage(dims, spacing, origin,
    [&](int i, int j, int k) { return stmTest::NestedEllipsoids(i, j, k, dims); });
  CheckAgainstImage(image, 3);
}

TEST(InterfaceSurfaceFilter, TwoDimensionalSliceGivesLines)
{
  const int dims[3] = { 40, 32, 1 };
  const double spacing[3] = { 0.5, 0.5, 1.0 }, origin[3] = { 0, 0, 0 };
  auto image = stmTest::MakeLabelImage(dims, spacing, origin,
    [&](int i, int j, int k) { return stmTest::NestedEllipsoids(i, j, k, dims); });
  CheckAgainstImage(image, 2);
}

TEST(InterfaceSurfaceFilter, BadInputGetsClearErrors)
{
  const auto check = stmTest::ExpectErrorAndEmptyOutput;
  auto tree = stmTest::BadInputTree(2);
  tree->Update();
  { // hexahedra
    vtkNew<stmInterfaceSurface> interfaces;
    interfaces->SetInputData(tree->GetOutput());
    check(interfaces, "only tetrahedra or only triangles");
  }
  { // no cells
    vtkNew<vtkUnstructuredGrid> empty;
    vtkNew<stmInterfaceSurface> interfaces;
    interfaces->SetInputData(empty);
    check(interfaces, "no cells");
  }
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetInputConnection(tree->GetOutputPort());
  tessellate->Update();
  { // a Material of two components
    vtkNew<vtkUnstructuredGrid> mesh;
    mesh->ShallowCopy(tessellate->GetOutput());
    vtkNew<vtkDoubleArray> pairs;
    pairs->SetName("Material");
    pairs->SetNumberOfComponents(2);
    pairs->SetNumberOfTuples(mesh->GetNumberOfCells());
    pairs->FillValue(1.0);
    mesh->GetCellData()->AddArray(pairs);
    vtkNew<stmInterfaceSurface> interfaces;
    interfaces->SetInputData(mesh);
    check(interfaces, "Material must have one component");
  }
  { // without Material: the outer boundary alone, labelled (1, -1)
    vtkNew<vtkUnstructuredGrid> mesh;
    mesh->ShallowCopy(tessellate->GetOutput());
    mesh->GetCellData()->RemoveArray("Material");
    vtkNew<stmInterfaceSurface> interfaces;
    interfaces->SetInputData(mesh);
    interfaces->Update();
    auto* pairLabels =
      vtkIntArray::SafeDownCast(interfaces->GetOutput()->GetCellData()->GetArray("BoundaryLabels"));
    ASSERT_NE(pairLabels, nullptr);
    double area = 0.0;
    vtkPolyData* surface = interfaces->GetOutput();
    vtkNew<vtkIdList> ids;
    for (vtkIdType f = 0; f < surface->GetNumberOfCells(); ++f)
    {
      EXPECT_EQ(pairLabels->GetTypedComponent(f, 0), 1);
      EXPECT_EQ(pairLabels->GetTypedComponent(f, 1), -1);
      surface->GetCellPoints(f, ids);
      double a[3], b[3], c[3];
      surface->GetPoint(ids->GetId(0), a);
      surface->GetPoint(ids->GetId(1), b);
      surface->GetPoint(ids->GetId(2), c);
      area += vtkTriangle::TriangleArea(a, b, c);
    }
    EXPECT_NEAR(area, 6.0 * 8 * 8, 1e-9); // the box of 8^3 voxels
  }
}
} // namespace
