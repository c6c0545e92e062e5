// SPDX-License-Identifier: BSD-3-Clause
#include "stmSpacetreeData.h"

#include "stmPieces.h"

#include "Common/LatticeBitset.h"
#include "Spacetree/RootPieces.h"
#include "Spacetree/SpacetreeValidate.h"

#include "vtkAlgorithm.h"
#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkIdTypeArray.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkNew.h"
#include "vtkPoints.h"
#include "vtkSMPTools.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace
{
// Field data array names; part of the file format of a saved spacetree.
constexpr const char* DimensionName = "SpacetreeDimension";
constexpr const char* ImageAxesName = "SpacetreeImageAxes";
constexpr const char* RootGridName = "SpacetreeRootGridDimensions";
constexpr const char* MaxLevelName = "SpacetreeMaxLevel";
constexpr const char* ImageDimensionsName = "SpacetreeImageDimensions";
constexpr const char* BackgroundLabelName = "SpacetreeBackgroundLabel";
constexpr const char* BodyLabelsName = "SpacetreeBodyLabels";
constexpr const char* BalanceLevelName = "SpacetreeBalanceLevel";
constexpr const char* FaceBalanceOnlyName = "SpacetreeFaceBalanceOnly";
constexpr const char* OriginName = "SpacetreeLatticeOrigin";
constexpr const char* AxisVectorsName = "SpacetreeLatticeAxes";
constexpr const char* CellSizesName = "SpacetreeCellSizes";
constexpr const char* VoxelSubdivisionName = "SpacetreeVoxelSubdivision";
constexpr const char* OwnedRootsName = "SpacetreeOwnedRoots";
constexpr const char* LatticeOffsetName = "SpacetreeLatticeOffset";

void AddIntArray(vtkFieldData* fd, const char* name, const std::vector<int>& values)
{
  vtkNew<vtkIntArray> array;
  array->SetName(name);
  array->SetNumberOfValues(static_cast<vtkIdType>(values.size()));
  for (std::size_t i = 0; i < values.size(); ++i)
  {
    array->SetValue(static_cast<vtkIdType>(i), values[i]);
  }
  fd->AddArray(array);
}

void AddDoubleArray(vtkFieldData* fd, const char* name, const double* values, int count)
{
  vtkNew<vtkDoubleArray> array;
  array->SetName(name);
  array->SetNumberOfValues(count);
  for (int i = 0; i < count; ++i)
  {
    array->SetValue(i, values[i]);
  }
  fd->AddArray(array);
}

/// Reads an integer field array of exactly `count` values (count < 0: any count >= 0).
bool GetInts(
  vtkFieldData* fd, const char* name, int count, std::vector<long long>& values, std::string& error)
{
  vtkDataArray* array = fd ? fd->GetArray(name) : nullptr;
  if (!array || array->GetNumberOfComponents() != 1 ||
    (count >= 0 && array->GetNumberOfTuples() != count))
  {
    error = std::string("the spacetree's field data lack a valid array \"") + name +
      "\"; is the input the output of ImageToSpacetree?";
    return false;
  }
  values.resize(static_cast<std::size_t>(array->GetNumberOfTuples()));
  for (vtkIdType i = 0; i < array->GetNumberOfTuples(); ++i)
  {
    const double v = array->GetComponent(i, 0);
    if (!std::isfinite(v) || v != std::floor(v) || std::abs(v) > 2147483647.0)
    {
      error = std::string("the spacetree's field array \"") + name + "\" holds a non-integer";
      return false;
    }
    values[i] = static_cast<long long>(v);
  }
  return true;
}

bool GetDoubles(vtkFieldData* fd, const char* name, int count, double* values, std::string& error)
{
  vtkDataArray* array = fd ? fd->GetArray(name) : nullptr;
  if (!array || array->GetNumberOfComponents() != 1 || array->GetNumberOfTuples() != count)
  {
    error = std::string("the spacetree's field data lack a valid array \"") + name + "\"";
    return false;
  }
  for (int i = 0; i < count; ++i)
  {
    values[i] = array->GetComponent(i, 0);
    if (!std::isfinite(values[i]))
    {
      error = std::string("the spacetree's field array \"") + name + "\" is not finite";
      return false;
    }
  }
  return true;
}
/// Reads the geometry (and so the dimension) from the field data of a spacetree dataset.
bool ReadGeometry(vtkFieldData* fd, stmSpacetreeGeometry& geometry, std::string& error)
{
  std::vector<long long> ints;
  if (!GetInts(fd, DimensionName, 1, ints, error))
  {
    return false;
  }
  if (ints[0] != 2 && ints[0] != 3)
  {
    error = "the spacetree's dimension must be 2 or 3, got " + std::to_string(ints[0]);
    return false;
  }
  geometry.Dimension = static_cast<int>(ints[0]);
  if (!GetInts(fd, ImageAxesName, geometry.Dimension, ints, error))
  {
    return false;
  }
  for (int i = 0; i < geometry.Dimension; ++i)
  {
    if (ints[i] < 0 || ints[i] > 2 || (i > 0 && ints[i] <= ints[i - 1]))
    {
      error = "the spacetree's image axes must be increasing and within 0..2";
      return false;
    }
    geometry.ImageAxes[i] = static_cast<int>(ints[i]);
  }
  double axes[9];
  if (!GetDoubles(fd, OriginName, 3, geometry.Origin, error) ||
    !GetDoubles(fd, AxisVectorsName, 9, axes, error))
  {
    return false;
  }
  for (int i = 0; i < 9; ++i)
  {
    geometry.AxisVectors[i / 3][i % 3] = axes[i];
  }
  // The spanned axes must be independent, or every element would be flat.
  const double* u = geometry.AxisVectors[geometry.ImageAxes[0]];
  const double* v = geometry.AxisVectors[geometry.ImageAxes[1]];
  const double cross[3] = { u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
    u[0] * v[1] - u[1] * v[0] };
  double measure = std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]);
  double scale = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) *
    std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (geometry.Dimension == 3)
  {
    const double* w = geometry.AxisVectors[geometry.ImageAxes[2]];
    measure = std::abs(cross[0] * w[0] + cross[1] * w[1] + cross[2] * w[2]);
    scale *= std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  }
  if (!(measure > 1e-12 * scale) || !(scale > 0))
  {
    error = "the spacetree's lattice axes are degenerate (zero or parallel voxel edges)";
    return false;
  }
  geometry.IsPiece = fd->GetArray(OwnedRootsName) != nullptr;
  if (geometry.IsPiece)
  {
    if (!GetDoubles(fd, LatticeOffsetName, geometry.Dimension, geometry.LatticeOffset, error))
    {
      return false;
    }
    if (!GetInts(fd, OwnedRootsName, 2 * geometry.Dimension, ints, error))
    {
      return false;
    }
    for (int i = 0; i < geometry.Dimension; ++i)
    {
      geometry.OwnedRootLower[i] = ints[i];
      geometry.OwnedRootUpper[i] = ints[geometry.Dimension + i];
      if (ints[i] < 0 || ints[geometry.Dimension + i] <= ints[i])
      {
        error = "the spacetree's owned root cells are an empty box";
        return false;
      }
    }
  }
  return true;
}

} // namespace

namespace stmSpacetreeData
{

bool BeginRequest(vtkAlgorithm* filter, vtkInformationVector* inputPort,
  vtkUnstructuredGrid* output, vtkUnstructuredGrid*& input, stmSpacetreeGeometry& geometry,
  int& requestResult)
{
  vtkInformation* info = inputPort->GetInformationObject(0);
  input = vtkUnstructuredGrid::GetData(inputPort, 0);
  std::string error;
  if (info && info->Get(vtkAlgorithm::ABORTED()))
  {
    // An upstream filter was aborted: produce an empty output quietly.
    output->Initialize();
    requestResult = 1;
    return false;
  }
  if (stmPieces::SkipsPiece(info, input, error))
  {
    if (error.empty())
    {
      output->Initialize(); // another piece holds the spacetree
      requestResult = 1;
      return false;
    }
  }
  else if (!input)
  {
    error = "the input must be the vtkUnstructuredGrid output of ImageToSpacetree";
  }
  else if (ReadGeometry(input->GetFieldData(), geometry, error))
  {
    return true;
  }
  output->Initialize();
  vtkErrorWithObjectMacro(filter, << filter->GetClassName() << ": " << error);
  requestResult = 0;
  return false;
}

int EndRequest(
  vtkAlgorithm* filter, bool succeeded, const std::string& error, vtkUnstructuredGrid* output)
{
  if (succeeded)
  {
    filter->UpdateProgress(1.0);
    return 1;
  }
  output->Initialize();
  if (filter->GetAbortExecute())
  {
    return 1;
  }
  vtkErrorWithObjectMacro(filter, << filter->GetClassName() << " failed: " << error);
  return 0;
}

void RemoveSpacetreeFieldData(vtkFieldData* fieldData)
{
  for (const char* name :
    { DimensionName, ImageAxesName, RootGridName, MaxLevelName, ImageDimensionsName,
      BackgroundLabelName, BodyLabelsName, BalanceLevelName, FaceBalanceOnlyName, OriginName,
      AxisVectorsName, CellSizesName, VoxelSubdivisionName, OwnedRootsName, LatticeOffsetName })
  {
    fieldData->RemoveArray(name);
  }
}

namespace
{
/// Level, material and lattice index of every leaf, through typed pointers when the arrays
/// have the types this module writes, and through the generic vtkDataArray API otherwise.
template <int Dim>
bool ReadLeaves(vtkDataArray* levels, vtkDataArray* materials, vtkDataArray* indices,
  const std::vector<std::pair<long long, stm::MaterialIndex>>& sortedLabels,
  stm::Spacetree<Dim>& tree, std::string& error)
{
  const vtkIdType leaves = levels->GetNumberOfTuples();
  tree.LeafLevels.resize(static_cast<std::size_t>(leaves));
  tree.LeafAnchors.resize(static_cast<std::size_t>(leaves));
  tree.LeafMaterials.resize(static_cast<std::size_t>(leaves));
  auto* typedLevels = vtkUnsignedCharArray::SafeDownCast(levels);
  auto* typedMaterials = vtkIntArray::SafeDownCast(materials);
  auto* typedIndices = vtkIntArray::SafeDownCast(indices);
  std::atomic<vtkIdType> firstBadLeaf{ leaves };
  vtkSMPTools::For(0, leaves,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType leaf = begin; leaf < end; ++leaf)
      {
        const double level =
          typedLevels ? typedLevels->GetValue(leaf) : levels->GetComponent(leaf, 0);
        const double label =
          typedMaterials ? typedMaterials->GetValue(leaf) : materials->GetComponent(leaf, 0);
        const auto found = std::lower_bound(sortedLabels.begin(), sortedLabels.end(),
          std::make_pair(static_cast<long long>(label), stm::MaterialIndex{ 0 }));
        bool good = level >= 0 && level <= tree.MaxLevel && level == std::floor(level) &&
          found != sortedLabels.end() && static_cast<double>(found->first) == label;
        stm::LatticeIndex<Dim> anchor{};
        if (good)
        {
          const stm::LatticeIndex<Dim> size = tree.GetCellSize(static_cast<int>(level));
          for (int axis = 0; axis < Dim; ++axis)
          {
            const double index = typedIndices ? typedIndices->GetTypedComponent(leaf, axis)
                                              : indices->GetComponent(leaf, axis);
            good = good && index >= 0 && index < 2147483648.0 && index == std::floor(index);
            anchor[axis] = good ? static_cast<std::int64_t>(index) * size[axis] : 0;
          }
        }
        if (!good)
        {
          vtkIdType expected = firstBadLeaf.load();
          while (leaf < expected && !firstBadLeaf.compare_exchange_weak(expected, leaf))
          {
          }
          continue;
        }
        tree.LeafLevels[leaf] = static_cast<std::uint8_t>(level);
        tree.LeafAnchors[leaf] = anchor;
        tree.LeafMaterials[leaf] = found->second;
      }
    });
  if (firstBadLeaf.load() < leaves)
  {
    error = "leaf " + std::to_string(firstBadLeaf.load()) +
      " has an invalid level, lattice index or material (not in the material table)";
    return false;
  }
  return true;
}
} // namespace

template <int Dim>
void MarkLeavesOutsideOwnedBox(const stm::Spacetree<Dim>& tree,
  const stmSpacetreeGeometry& geometry, int grownBy, std::uint8_t mark, std::uint8_t* marks)
{
  stm::RootBox<Dim> owned;
  for (int axis = 0; axis < Dim; ++axis)
  {
    owned.Lower[axis] = geometry.OwnedRootLower[axis];
    owned.Upper[axis] = geometry.OwnedRootUpper[axis];
  }
  const stm::RootBox<Dim> kept = owned.Grown(grownBy);
  vtkSMPTools::For(0, tree.GetNumberOfLeaves(), 8192,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType leaf = begin; leaf < end; ++leaf)
      {
        marks[leaf] = stm::LeafInRootBox<Dim>(tree, leaf, kept) ? 0 : mark;
      }
    });
}

template <int Dim>
bool ReadSpacetree(vtkUnstructuredGrid* input, stm::Spacetree<Dim>& tree, std::string& error)
{
  vtkFieldData* fd = input->GetFieldData();
  std::vector<long long> ints;
  tree = stm::Spacetree<Dim>();
  if (!GetInts(fd, RootGridName, Dim, ints, error))
  {
    return false;
  }
  for (int axis = 0; axis < Dim; ++axis)
  {
    tree.RootGridDimensions[axis] = ints[axis];
  }
  if (!GetInts(fd, ImageDimensionsName, Dim, ints, error))
  {
    return false;
  }
  for (int axis = 0; axis < Dim; ++axis)
  {
    tree.ImageDimensions[axis] = ints[axis];
  }
  if (!GetInts(fd, MaxLevelName, 1, ints, error))
  {
    return false;
  }
  tree.MaxLevel = static_cast<int>(ints[0]);
  if (tree.MaxLevel < 0 || tree.MaxLevel > stm::MaximumSupportedLevel)
  {
    error = "the spacetree's MaxLevel must be between 0 and " +
      std::to_string(stm::MaximumSupportedLevel);
    return false;
  }
  // The level table; a spacetree without one (written before refinement patterns existed) has
  // 2^d refinement at voxel resolution.
  tree.SetUniformRefinement(tree.MaxLevel);
  if (fd->GetArray(CellSizesName) || fd->GetArray(VoxelSubdivisionName))
  {
    if (!GetInts(fd, CellSizesName, (tree.MaxLevel + 1) * Dim, ints, error))
    {
      return false;
    }
    for (int level = 0; level <= tree.MaxLevel; ++level)
    {
      for (int axis = 0; axis < Dim; ++axis)
      {
        tree.CellSizes[level][axis] = ints[level * Dim + axis];
      }
    }
    if (!GetInts(fd, VoxelSubdivisionName, Dim, ints, error))
    {
      return false;
    }
    for (int axis = 0; axis < Dim; ++axis)
    {
      tree.VoxelSubdivision[axis] = ints[axis];
    }
  }
  if (!GetInts(fd, BalanceLevelName, 1, ints, error))
  {
    return false;
  }
  tree.BalanceLevel = static_cast<int>(ints[0]);
  if (tree.BalanceLevel != -1 && (tree.BalanceLevel < 1 || tree.BalanceLevel > 20))
  {
    error = "the spacetree's balance level must be -1 (unbalanced) or between 1 and 20";
    return false;
  }
  if (!GetInts(fd, FaceBalanceOnlyName, 1, ints, error))
  {
    return false;
  }
  tree.FaceBalanceOnly = ints[0] != 0;
  if (!GetInts(fd, BackgroundLabelName, 1, ints, error))
  {
    return false;
  }
  tree.MaterialLabels.push_back(ints[0]);
  if (!GetInts(fd, BodyLabelsName, -1, ints, error))
  {
    return false;
  }
  tree.MaterialLabels.insert(tree.MaterialLabels.end(), ints.begin(), ints.end());
  if (tree.MaterialLabels.size() > 65536)
  {
    error = "the spacetree has more than 65535 body labels";
    return false;
  }
  std::vector<std::pair<long long, stm::MaterialIndex>> sortedLabels;
  for (std::size_t i = 0; i < tree.MaterialLabels.size(); ++i)
  {
    sortedLabels.emplace_back(tree.MaterialLabels[i], static_cast<stm::MaterialIndex>(i));
  }
  std::sort(sortedLabels.begin(), sortedLabels.end());
  for (std::size_t i = 1; i < sortedLabels.size(); ++i)
  {
    if (sortedLabels[i].first == sortedLabels[i - 1].first)
    {
      error = "the spacetree's material labels are not distinct";
      return false;
    }
  }

  vtkCellData* cd = input->GetCellData();
  vtkDataArray* levels = cd->GetArray("Level");
  vtkDataArray* materials = cd->GetArray("Material");
  vtkDataArray* indices = cd->GetArray("LatticeIndex");
  const vtkIdType leaves = input->GetNumberOfCells();
  if (!levels || !materials || !indices || levels->GetNumberOfComponents() != 1 ||
    materials->GetNumberOfComponents() != 1 || indices->GetNumberOfComponents() != Dim ||
    levels->GetNumberOfTuples() != leaves || materials->GetNumberOfTuples() != leaves ||
    indices->GetNumberOfTuples() != leaves)
  {
    error = "the spacetree lacks valid cell arrays Level, Material and LatticeIndex (" +
      std::to_string(Dim) + " components)";
    return false;
  }
  if (leaves == 0)
  {
    error = "the spacetree has no leaves";
    return false;
  }
  if (!ReadLeaves<Dim>(levels, materials, indices, sortedLabels, tree, error))
  {
    return false;
  }
  const stm::Status status = stm::ValidateSpacetree(tree);
  if (!status.IsOk())
  {
    error = "invalid spacetree: " + status.GetMessage();
    return false;
  }
  return true;
}

template <int Dim>
void WriteSpacetree(const stm::Spacetree<Dim>& tree, const stmSpacetreeGeometry& geometry,
  vtkUnstructuredGrid* output)
{
  constexpr int n = stm::CubeInfo<Dim>::VerticesPerCell;
  const vtkIdType leaves = tree.GetNumberOfLeaves();
  auto cornerOf = [&tree](vtkIdType leaf, int c)
  {
    stm::LatticeIndex<Dim> corner = tree.LeafAnchors[leaf];
    const stm::LatticeIndex<Dim> size = tree.GetCellSize(tree.LeafLevels[leaf]);
    for (int axis = 0; axis < Dim; ++axis)
    {
      corner[axis] += ((c >> axis) & 1) * size[axis];
    }
    return corner;
  };

  // Points: the leaf corners, numbered in lattice order.
  stm::LatticeIndex<Dim> vertexDims = tree.GetLatticeDimensions();
  for (int axis = 0; axis < Dim; ++axis)
  {
    ++vertexDims[axis];
  }
  stm::LatticeBitset<Dim> corners(vertexDims);
  vtkSMPTools::For(0, leaves,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType leaf = begin; leaf < end; ++leaf)
      {
        for (int c = 0; c < n; ++c)
        {
          corners.Set(cornerOf(leaf, c));
        }
      }
    });
  const std::int64_t numberOfPoints = corners.BuildRank();
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(numberOfPoints);
  double* xyz = vtkDoubleArray::SafeDownCast(points->GetData())->GetPointer(0);
  vtkSMPTools::For(0, corners.GetNumberOfWords(), 4096,
    [&](vtkIdType begin, vtkIdType end)
    {
      corners.VisitSetBits(begin, end,
        [&](std::int64_t id, const stm::LatticeIndex<Dim>& p)
        {
          double lattice[3];
          for (int axis = 0; axis < Dim; ++axis)
          {
            lattice[axis] = static_cast<double>(p[axis]);
          }
          geometry.ToPhysical(lattice, xyz + 3 * id);
        });
    });
  output->SetPoints(points);

  // Cells: VTK hexahedron / quad corner order from the binary corner codes.
  static constexpr int hexOrder[8] = { 0, 1, 3, 2, 4, 5, 7, 6 };
  vtkNew<vtkIdTypeArray> offsets;
  vtkNew<vtkIdTypeArray> connectivity;
  offsets->SetNumberOfValues(leaves + 1);
  connectivity->SetNumberOfValues(leaves * n);
  vtkNew<vtkUnsignedCharArray> levels;
  levels->SetName("Level");
  levels->SetNumberOfValues(leaves);
  vtkNew<vtkIntArray> materials;
  materials->SetName("Material");
  materials->SetNumberOfValues(leaves);
  vtkNew<vtkIntArray> indices;
  indices->SetName("LatticeIndex");
  indices->SetNumberOfComponents(Dim);
  indices->SetNumberOfTuples(leaves);
  vtkIdType* offsetValues = offsets->GetPointer(0);
  vtkIdType* ids = connectivity->GetPointer(0);
  unsigned char* levelValues = levels->GetPointer(0);
  int* materialValues = materials->GetPointer(0);
  int* indexValues = indices->GetPointer(0);
  vtkSMPTools::For(0, leaves,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType leaf = begin; leaf < end; ++leaf)
      {
        offsetValues[leaf] = leaf * n;
        for (int v = 0; v < n; ++v)
        {
          ids[leaf * n + v] = corners.Rank(cornerOf(leaf, hexOrder[v]));
        }
        const int level = tree.LeafLevels[leaf];
        levelValues[leaf] = static_cast<unsigned char>(level);
        materialValues[leaf] = static_cast<int>(tree.MaterialLabels[tree.LeafMaterials[leaf]]);
        for (int axis = 0; axis < Dim; ++axis)
        {
          indexValues[leaf * Dim + axis] =
            static_cast<int>(tree.LeafAnchors[leaf][axis] / tree.GetCellSize(level)[axis]);
        }
      }
    });
  offsetValues[leaves] = leaves * n;
  vtkNew<vtkCellArray> cells;
  cells->SetData(offsets, connectivity);
  output->SetCells(Dim == 3 ? VTK_HEXAHEDRON : VTK_QUAD, cells);
  output->GetCellData()->AddArray(materials);
  output->GetCellData()->AddArray(levels);
  output->GetCellData()->AddArray(indices);
  output->GetCellData()->SetActiveScalars("Material");

  vtkFieldData* fd = output->GetFieldData();
  AddIntArray(fd, DimensionName, { Dim });
  std::vector<int> axes, root, image, body;
  for (int axis = 0; axis < Dim; ++axis)
  {
    axes.push_back(geometry.ImageAxes[axis]);
    root.push_back(static_cast<int>(tree.RootGridDimensions[axis]));
    image.push_back(static_cast<int>(tree.ImageDimensions[axis]));
  }
  for (std::size_t m = 1; m < tree.MaterialLabels.size(); ++m)
  {
    body.push_back(static_cast<int>(tree.MaterialLabels[m]));
  }
  AddIntArray(fd, ImageAxesName, axes);
  AddIntArray(fd, RootGridName, root);
  AddIntArray(fd, MaxLevelName, { tree.MaxLevel });
  std::vector<int> sizes, subdivision;
  for (const auto& size : tree.CellSizes)
  {
    sizes.insert(sizes.end(), size.begin(), size.end());
  }
  subdivision.assign(tree.VoxelSubdivision.begin(), tree.VoxelSubdivision.end());
  AddIntArray(fd, CellSizesName, sizes);
  AddIntArray(fd, VoxelSubdivisionName, subdivision);
  AddIntArray(fd, ImageDimensionsName, image);
  AddIntArray(fd, BackgroundLabelName, { static_cast<int>(tree.MaterialLabels[0]) });
  AddIntArray(fd, BodyLabelsName, body);
  AddIntArray(fd, BalanceLevelName, { tree.BalanceLevel });
  AddIntArray(fd, FaceBalanceOnlyName, { tree.FaceBalanceOnly ? 1 : 0 });
  AddDoubleArray(fd, OriginName, geometry.Origin, 3);
  double vectors[9];
  for (int i = 0; i < 9; ++i)
  {
    vectors[i] = geometry.AxisVectors[i / 3][i % 3];
  }
  AddDoubleArray(fd, AxisVectorsName, vectors, 9);
  if (geometry.IsPiece)
  {
    std::vector<int> owned(2 * Dim);
    for (int axis = 0; axis < Dim; ++axis)
    {
      owned[axis] = static_cast<int>(geometry.OwnedRootLower[axis]);
      owned[Dim + axis] = static_cast<int>(geometry.OwnedRootUpper[axis]);
    }
    AddIntArray(fd, OwnedRootsName, owned);
    AddDoubleArray(fd, LatticeOffsetName, geometry.LatticeOffset, Dim);
    stmPieces::MarkPiece(fd);
    vtkSmartPointer<vtkUnsignedCharArray> ghosts = stmPieces::NewGhostArray(leaves);
    MarkLeavesOutsideOwnedBox<Dim>(
      tree, geometry, 0, vtkDataSetAttributes::DUPLICATECELL, ghosts->GetPointer(0));
    output->GetCellData()->AddArray(ghosts);
  }
}

template void MarkLeavesOutsideOwnedBox<2>(
  const stm::Spacetree<2>&, const stmSpacetreeGeometry&, int, std::uint8_t, std::uint8_t*);
template void MarkLeavesOutsideOwnedBox<3>(
  const stm::Spacetree<3>&, const stmSpacetreeGeometry&, int, std::uint8_t, std::uint8_t*);
template bool ReadSpacetree<2>(vtkUnstructuredGrid*, stm::Spacetree<2>&, std::string&);
template bool ReadSpacetree<3>(vtkUnstructuredGrid*, stm::Spacetree<3>&, std::string&);
template void WriteSpacetree<2>(
  const stm::Spacetree<2>&, const stmSpacetreeGeometry&, vtkUnstructuredGrid*);
template void WriteSpacetree<3>(
  const stm::Spacetree<3>&, const stmSpacetreeGeometry&, vtkUnstructuredGrid*);
} // namespace stmSpacetreeData
