// SPDX-License-Identifier: BSD-3-Clause
// Helpers shared by the filter tests: synthetic label images, the pipeline, and the conversion
// of a VTK mesh into the core's invariant checker.

#ifndef stmFilterTestUtilities_h
#define stmFilterTestUtilities_h

#include "stmImageToSpacetree.h"
#include "stmSeparatingFunction.h"
#include "stmSpacetreeBalance.h"
#include "stmSpacetreeTessellate.h"

#include "Check/MeshInvariants.h"
#include "Check/SimplexQuality.h"

#include <gtest/gtest.h>

#include "vtkAlgorithm.h"
#include "vtkCallbackCommand.h"
#include "vtkCellData.h"
#include "vtkCellTypes.h"
#include "vtkCommand.h"
#include "vtkDataArray.h"
#include "vtkDataSet.h"
#include "vtkDoubleArray.h"
#include "vtkFloatArray.h"
#include "vtkIdList.h"
#include "vtkImageData.h"
#include "vtkImageThreshold.h"
#include "vtkIntArray.h"
#include "vtkNIFTIImageReader.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkSmartPointer.h"
#include "vtkSphere.h"
#include "vtkStringArray.h"
#include "vtkUnsignedShortArray.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace stmTest
{

/// Collects error messages of an algorithm instead of printing them.
class ErrorRecorder
{
public:
  explicit ErrorRecorder(vtkObject* object)
  {
    this->Callback->SetClientData(this);
    this->Callback->SetCallback([](vtkObject*, unsigned long, void* self, void* message)
      { static_cast<ErrorRecorder*>(self)->Messages += static_cast<const char*>(message); });
    object->AddObserver(vtkCommand::ErrorEvent, this->Callback);
  }
  std::string Messages;

private:
  vtkNew<vtkCallbackCommand> Callback;
};

/// Updates the algorithm and expects an error containing `expected` and an empty output.
inline void ExpectErrorAndEmptyOutput(vtkAlgorithm* algorithm, const std::string& expected)
{
  ErrorRecorder errors(algorithm);
  algorithm->Update();
  EXPECT_NE(errors.Messages.find(expected), std::string::npos)
    << "expected \"" << expected << "\" in: " << errors.Messages;
  auto* output = vtkDataSet::SafeDownCast(algorithm->GetOutputDataObject(0));
  EXPECT_TRUE(output == nullptr || output->GetNumberOfCells() == 0);
}

/// A point-data label image: label(i, j, k) for every voxel.
inline vtkSmartPointer<vtkImageData> MakeLabelImage(const int dims[3], const double spacing[3],
  const double origin[3], const std::function<int(int, int, int)>& label)
{
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(dims[0], dims[1], dims[2]);
  image->SetSpacing(spacing[0], spacing[1], spacing[2]);
  image->SetOrigin(origin[0], origin[1], origin[2]);
  vtkNew<vtkUnsignedShortArray> labels;
  labels->SetName("labels");
  labels->SetNumberOfValues(static_cast<vtkIdType>(dims[0]) * dims[1] * dims[2]);
  vtkIdType id = 0;
  for (int k = 0; k < dims[2]; ++k)
  {
    for (int j = 0; j < dims[1]; ++j)
    {
      for (int i = 0; i < dims[0]; ++i)
      {
        labels->SetValue(id++, static_cast<unsigned short>(label(i, j, k)));
      }
    }
  }
  image->GetPointData()->SetScalars(labels);
  return image;
}

/// The spacetree (not updated) of the bad-input tests' image: 8^3 voxels of 1 mm, a box of label 1
/// in `outside` (0: the background; another label: two materials).
inline vtkSmartPointer<stmImageToSpacetree> BadInputTree(int outside)
{
  const int dims[3] = { 8, 8, 8 };
  const double spacing[3] = { 1, 1, 1 }, origin[3] = { 0, 0, 0 };
  auto image = MakeLabelImage(dims, spacing, origin,
    [outside](int i, int j, int k) { return i > 2 && j > 2 && k > 3 ? 1 : outside; });
  auto tree = vtkSmartPointer<stmImageToSpacetree>::New();
  tree->SetInputData(image);
  return tree;
}

/// Nested ellipsoids: 2 inside 1 inside background, plus a small separate ball of label 5.
inline int NestedEllipsoids(int i, int j, int k, const int dims[3])
{
  const double x = (i + 0.5) / dims[0] - 0.5, y = (j + 0.5) / dims[1] - 0.5,
               z = dims[2] > 1 ? (k + 0.5) / dims[2] - 0.5 : 0.0;
  const double outer = x * x / 0.16 + y * y / 0.1 + z * z / 0.12;
  const double inner = (x - 0.05) * (x - 0.05) / 0.03 + y * y / 0.05 + z * z / 0.02;
  const double small = (x - 0.38) * (x - 0.38) + (y - 0.38) * (y - 0.38) + z * z;
  return inner < 1.0 ? 2 : outer < 1.0 ? 1 : small < 0.006 ? 5 : 0;
}

/// Voxel count per label of a point-data label image.
inline std::map<long long, long long> CountLabels(vtkImageData* image)
{
  std::map<long long, long long> counts;
  vtkDataArray* labels = image->GetPointData()->GetScalars();
  for (vtkIdType v = 0; v < labels->GetNumberOfTuples(); ++v)
  {
    ++counts[static_cast<long long>(labels->GetComponent(v, 0))];
  }
  return counts;
}

/// Debian's mricron-data atlas: 116 labels, 181 x 217 x 181 voxels of 1 mm.
constexpr const char* AalAtlasPath = "/usr/share/mricron/templates/aal.nii.gz";

/// The AAL brain mask: every non-zero label of the atlas becomes label 1, and the voxel volume
/// of the body is what a mesh of it should enclose.
struct AalBrainMask
{
  vtkNew<vtkNIFTIImageReader> Reader;
  vtkNew<vtkImageThreshold> Mask;
  double VoxelVolume = 0.0;

  AalBrainMask()
  {
    this->Reader->SetFileName(AalAtlasPath);
    this->Mask->SetInputConnection(this->Reader->GetOutputPort());
    this->Mask->ThresholdByUpper(1); // integer labels: a fractional threshold would round to 0
    this->Mask->SetInValue(1);
    this->Mask->SetOutValue(0);
    this->Mask->ReplaceInOn();
    this->Mask->ReplaceOutOn();
    this->Mask->SetOutputScalarTypeToUnsignedChar();
    this->Mask->Update();
    const long long bodyVoxels = CountLabels(this->Mask->GetOutput())[1];
    const double* spacing = this->Mask->GetOutput()->GetSpacing();
    this->VoxelVolume = static_cast<double>(bodyVoxels) * spacing[0] * spacing[1] * spacing[2];
  }
  vtkAlgorithmOutput* GetOutputPort() { return this->Mask->GetOutputPort(); }
};

/// The unit box as n^3 voxels of edge 1/n, tessellated (5 tetrahedra per voxel, no function),
/// with the function of the sphere of the given radius around the box's centre (vtkSphere, by
/// stmSeparatingFunction): the analytic ball of the paper's Tables 1 and 2.
struct UniformBallFunction
{
  vtkNew<stmImageToSpacetree> Tree;
  vtkNew<stmSpacetreeTessellate> Tessellate;
  vtkNew<vtkSphere> Sphere;
  vtkNew<stmSeparatingFunction> Function;

  UniformBallFunction(int n, double radius)
  {
    const int dims[3] = { n, n, n };
    const double h = 1.0 / n;
    const double spacing[3] = { h, h, h }, origin[3] = { h / 2, h / 2, h / 2 };
    auto image = MakeLabelImage(dims, spacing, origin, [](int, int, int) { return 1; });
    this->Tree->SetInputData(image);
    this->Tree->SetMaxCellSize(1);
    this->Tessellate->SetInputConnection(this->Tree->GetOutputPort());
    this->Tessellate->SetSeparatingFunction(stmSpacetreeTessellate::NO_FUNCTION);
    this->Sphere->SetCenter(0.5, 0.5, 0.5);
    this->Sphere->SetRadius(radius);
    this->Function->SetInputConnection(this->Tessellate->GetOutputPort());
    this->Function->SetImplicitFunction(this->Sphere);
  }
  vtkAlgorithmOutput* GetOutputPort() { return this->Function->GetOutputPort(); }
};

struct Pipeline
{
  vtkNew<stmImageToSpacetree> Tree;
  vtkNew<stmSpacetreeBalance> Balance;
  vtkNew<stmSpacetreeTessellate> Tessellate;

  /// balanceLevel 0: no balancing.
  vtkUnstructuredGrid* Run(vtkImageData* image, int balanceLevel, int cellTemplate = 0)
  {
    this->Tree->SetInputData(image);
    // A staircase mesh keeps every voxel without the refinement a cut needs.
    this->Tree->SetThinPartRefinement(stmImageToSpacetree::NO_THIN_PARTS);
    this->Balance->SetInputConnection(this->Tree->GetOutputPort());
    this->Balance->SetBalanceLevel(std::max(1, balanceLevel));
    this->Tessellate->SetCellTemplate(cellTemplate);
    // The staircase mesh of the voxels: these tests compare it with the voxel model exactly.
    this->Tessellate->SetSeparatingFunction(stmSpacetreeTessellate::NO_FUNCTION);
    if (balanceLevel > 0)
    {
      this->Tessellate->SetInputConnection(this->Balance->GetOutputPort());
    }
    else
    {
      this->Tessellate->SetInputConnection(this->Tree->GetOutputPort());
    }
    this->Tessellate->Update();
    return this->Tessellate->GetOutput();
  }
};

/// Shape (1 simplex .. Dim cube, see stm::CheckCellMesh) of a VTK cell type in dimension Dim,
/// and the order in which its VTK points give the checker's connectivity: apexes first, then
/// the cube corners in code order. Shape 0 for a cell type that does not belong there.
/// The worst condition number and the true smallest dihedral angle (degrees) of a tetrahedral
/// mesh by the core's measure (vtkMeshQuality's tetrahedron minimum angle in VTK 9.2 is not the
/// smallest dihedral angle), and its cells that are not positive (left out of the two figures).
struct TetrahedronShapes
{
  double WorstCondition = 0.0;
  double SmallestDihedral = 180.0;
  vtkIdType NonPositive = 0;
};

inline TetrahedronShapes MeasureTetrahedronShapes(vtkUnstructuredGrid* mesh)
{
  TetrahedronShapes range;
  vtkPoints* points = mesh->GetPoints();
  for (vtkIdType cell = 0; cell < mesh->GetNumberOfCells(); ++cell)
  {
    vtkIdType count = 0;
    const vtkIdType* ids = nullptr;
    mesh->GetCellPoints(cell, count, ids);
    double coordinates[4][3];
    const double* corners[4];
    for (int k = 0; k < 4; ++k)
    {
      points->GetPoint(ids[k], coordinates[k]);
      corners[k] = coordinates[k];
    }
    const stm::SimplexShape<3> shape = stm::MeasureSimplex<3>(corners);
    if (!(shape.Determinant > 0))
    {
      ++range.NonPositive;
      continue;
    }
    range.WorstCondition = std::max(range.WorstCondition, shape.Condition);
    range.SmallestDihedral = std::min(range.SmallestDihedral, shape.MinDihedralDegrees);
  }
  return range;
}

template <int Dim>
int CellShape(int cellType, std::vector<int>& order)
{
  order.clear();
  if (Dim == 2 && cellType == VTK_TRIANGLE)
  {
    order = { 0, 1, 2 };
    return 1;
  }
  if (Dim == 2 && cellType == VTK_QUAD)
  {
    order = { 0, 1, 3, 2 };
    return 2;
  }
  if (Dim == 3 && cellType == VTK_TETRA)
  {
    order = { 0, 1, 2, 3 };
    return 1;
  }
  if (Dim == 3 && cellType == VTK_PYRAMID)
  {
    order = { 4, 0, 1, 3, 2 };
    return 2;
  }
  if (Dim == 3 && cellType == VTK_HEXAHEDRON)
  {
    order = { 0, 1, 3, 2, 4, 5, 7, 6 };
    return 3;
  }
  return 0;
}

/// Runs the core invariant checks on a VTK mesh of simplices, cubes (quads, hexahedra) and
/// pyramids. Coordinates are projected on the given axes (for 2D meshes, the plane's axes).
/// A mesh of simplices only goes through CheckSimplicialMesh (less memory), any other through
/// CheckCellMesh; a cell of another type counts as invalid.
template <int Dim>
stm::MeshInvariantReport CheckMesh(vtkUnstructuredGrid* mesh, const int axes[Dim], double tolerance)
{
  std::vector<double> points(static_cast<std::size_t>(mesh->GetNumberOfPoints()) * Dim);
  for (vtkIdType p = 0; p < mesh->GetNumberOfPoints(); ++p)
  {
    double x[3];
    mesh->GetPoint(p, x);
    for (int a = 0; a < Dim; ++a)
    {
      points[p * Dim + a] = x[axes[a]];
    }
  }
  std::vector<std::int64_t> cells;
  cells.reserve(static_cast<std::size_t>(mesh->GetNumberOfCells()) * (Dim + 1));
  std::vector<std::uint8_t> shapes;
  shapes.reserve(static_cast<std::size_t>(mesh->GetNumberOfCells()));
  std::vector<std::int64_t> materials;
  materials.reserve(static_cast<std::size_t>(mesh->GetNumberOfCells()));
  vtkDataArray* material = mesh->GetCellData()->GetArray("Material");
  vtkNew<vtkIdList> ids;
  std::vector<int> order;
  bool simplicial = true;
  for (vtkIdType c = 0; c < mesh->GetNumberOfCells(); ++c)
  {
    mesh->GetCellPoints(c, ids);
    int shape = CellShape<Dim>(mesh->GetCellType(c), order);
    if (shape > 0 && static_cast<vtkIdType>(order.size()) != ids->GetNumberOfIds())
    {
      shape = 0;
    }
    simplicial = simplicial && shape == 1;
    shapes.push_back(static_cast<std::uint8_t>(shape));
    for (std::size_t v = 0; shape > 0 && v < order.size(); ++v)
    {
      cells.push_back(ids->GetId(order[v]));
    }
    materials.push_back(material ? static_cast<std::int64_t>(material->GetComponent(c, 0)) : 0);
  }
  if (simplicial)
  {
    return stm::CheckSimplicialMesh<Dim>(points, cells, &materials, tolerance);
  }
  return stm::CheckCellMesh<Dim>(points, cells, shapes, &materials, tolerance);
}

/// Arrays that say where a cut's cells and points come from: ParentCell (the cell's id, a
/// double), CellTriple (c, 2c, -c as floats) and, with `withStrings`, CellName (the id as a
/// string, which the filters' typed copy does not take: VTK's copy then does it all); PointPair
/// (p, 3p as ints) per point.
inline void AddParentArrays(vtkUnstructuredGrid* mesh, bool withStrings)
{
  vtkNew<vtkDoubleArray> parent;
  parent->SetName("ParentCell");
  vtkNew<vtkFloatArray> triple;
  triple->SetName("CellTriple");
  triple->SetNumberOfComponents(3);
  vtkNew<vtkStringArray> names;
  names->SetName("CellName");
  for (vtkIdType c = 0; c < mesh->GetNumberOfCells(); ++c)
  {
    parent->InsertNextValue(static_cast<double>(c));
    triple->InsertNextTuple3(c, 2.0 * c, -1.0 * c);
    names->InsertNextValue(std::to_string(c));
  }
  mesh->GetCellData()->AddArray(parent);
  mesh->GetCellData()->AddArray(triple);
  if (withStrings)
  {
    mesh->GetCellData()->AddArray(names);
  }
  vtkNew<vtkIntArray> pair;
  pair->SetName("PointPair");
  pair->SetNumberOfComponents(2);
  for (vtkIdType p = 0; p < mesh->GetNumberOfPoints(); ++p)
  {
    pair->InsertNextTuple2(static_cast<double>(p), 3.0 * p);
  }
  mesh->GetPointData()->AddArray(pair);
}

/// Every cell of `cut` carries its parent's arrays (AddParentArrays on `input`) and its centroid
/// lies in its parent's bounds, grown on every side by `growth` times their largest side
/// (where snapping moved points); the first `inputPoints` points carry their own.
inline void ExpectParentArrays(vtkUnstructuredGrid* input, vtkUnstructuredGrid* cut,
  bool withStrings, double growth, vtkIdType inputPoints)
{
  vtkDataArray* parent = cut->GetCellData()->GetArray("ParentCell");
  vtkDataArray* triple = cut->GetCellData()->GetArray("CellTriple");
  auto* names = vtkStringArray::SafeDownCast(cut->GetCellData()->GetAbstractArray("CellName"));
  ASSERT_NE(parent, nullptr);
  ASSERT_NE(triple, nullptr);
  ASSERT_EQ(parent->GetNumberOfTuples(), cut->GetNumberOfCells());
  ASSERT_EQ(triple->GetNumberOfTuples(), cut->GetNumberOfCells());
  ASSERT_EQ(names != nullptr, withStrings);
  vtkIdType misplaced = 0;
  for (vtkIdType c = 0; c < cut->GetNumberOfCells(); ++c)
  {
    const double id = parent->GetComponent(c, 0);
    ASSERT_TRUE(id >= 0 && id < input->GetNumberOfCells() && id == std::floor(id)) << c;
    EXPECT_EQ(triple->GetComponent(c, 0), id) << c;
    EXPECT_EQ(triple->GetComponent(c, 1), 2.0 * id) << c;
    EXPECT_EQ(triple->GetComponent(c, 2), -id) << c;
    if (names)
    {
      EXPECT_EQ(names->GetValue(c), std::to_string(static_cast<long long>(id))) << c;
    }
    double bounds[6], centroid[3] = { 0, 0, 0 }, x[3];
    input->GetCellBounds(static_cast<vtkIdType>(id), bounds);
    const double side =
      std::max({ bounds[1] - bounds[0], bounds[3] - bounds[2], bounds[5] - bounds[4] });
    const double margin = 1e-9 + growth * side;
    vtkIdList* ids = cut->GetCell(c)->GetPointIds();
    for (vtkIdType k = 0; k < ids->GetNumberOfIds(); ++k)
    {
      cut->GetPoint(ids->GetId(k), x);
      for (int a = 0; a < 3; ++a)
      {
        centroid[a] += x[a] / ids->GetNumberOfIds();
      }
    }
    for (int a = 0; a < 3; ++a)
    {
      misplaced += centroid[a] < bounds[2 * a] - margin || centroid[a] > bounds[2 * a + 1] + margin;
    }
  }
  EXPECT_EQ(misplaced, 0);
  vtkDataArray* pair = cut->GetPointData()->GetArray("PointPair");
  ASSERT_NE(pair, nullptr);
  ASSERT_EQ(pair->GetNumberOfTuples(), cut->GetNumberOfPoints());
  for (vtkIdType p = 0; p < inputPoints; ++p)
  {
    EXPECT_EQ(pair->GetComponent(p, 0), static_cast<double>(p)) << p;
    EXPECT_EQ(pair->GetComponent(p, 1), 3.0 * p) << p;
  }
}

/// Cuts the tessellation of `tree` with AddParentArrays' arrays by a new Cut filter, without and
/// with the string array, and checks ExpectParentArrays.
template <class Cut>
void ExpectParentArraysThrough(vtkAlgorithm* tree, double growth)
{
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetInputConnection(tree->GetOutputPort());
  tessellate->Update();
  for (const bool withStrings : { false, true })
  {
    vtkNew<vtkUnstructuredGrid> mesh;
    mesh->ShallowCopy(tessellate->GetOutput());
    AddParentArrays(mesh, withStrings);
    vtkNew<Cut> cut;
    cut->SetInputData(mesh);
    cut->Update();
    auto* output = vtkUnstructuredGrid::SafeDownCast(cut->GetOutputDataObject(0));
    ASSERT_NE(output, nullptr);
    ASSERT_GT(cut->GetNumberOfSplitCells(), 0);
    ASSERT_GT(output->GetNumberOfCells(), mesh->GetNumberOfCells());
    ExpectParentArrays(mesh, output, withStrings, growth, mesh->GetNumberOfPoints());
  }
}

} // namespace stmTest

#endif
