// SPDX-License-Identifier: BSD-3-Clause
#include "stmSpacetreeTessellate.h"

#include "stmPieces.h"
#include "stmSMPExecutor.h"
#include "stmSpacetreeData.h"

#include "Cut/SeparatingFunction.h"
#include "Spacetree/RootPieces.h"
#include "Tessellate/SpacetreeTessellation.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCellType.h"
#include "vtkDoubleArray.h"
#include "vtkFloatArray.h"
#include "vtkImageData.h"
#include "vtkImageGaussianSmooth.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkMath.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkSMPTools.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <cmath>
#include <functional>
#include <limits>

vtkStandardNewMacro(stmSpacetreeTessellate);

namespace
{
/// VTK's point order of the cells of shape j (see stm::CellPointCount): the cube corners in
/// cyclic order, the apex of a pyramid last.
template <int Dim>
void ToVTKOrder(std::uint8_t shape, vtkIdType* ids)
{
  if (shape < 2)
  {
    return; // simplices: VTK takes the stored order
  }
  vtkIdType* corners = ids + (Dim - shape);
  if (shape == Dim - 1)
  {
    // Pyramid: the base first, then the apex.
    const vtkIdType apex = ids[0];
    std::copy(corners, corners + 4, ids);
    ids[4] = apex;
    corners = ids;
  }
  for (int first = 0; first < (1 << shape); first += 4)
  {
    std::swap(corners[first + 2], corners[first + 3]);
  }
}

/// Mirrors a 3D cell in VTK order: its orientation flips.
void MirrorVTKCell(unsigned char type, vtkIdType* ids)
{
  switch (type)
  {
    case VTK_TETRA:
      std::swap(ids[0], ids[1]);
      break;
    case VTK_PYRAMID:
      std::swap(ids[1], ids[3]);
      break;
    case VTK_HEXAHEDRON:
      std::swap(ids[1], ids[3]);
      std::swap(ids[5], ids[7]);
      break;
    default:
      break;
  }
}

template <int Dim>
unsigned char CellTypeOfShape(std::uint8_t shape)
{
  if (Dim == 3)
  {
    return shape == 1 ? VTK_TETRA : shape == 2 ? VTK_PYRAMID : VTK_HEXAHEDRON;
  }
  return shape == 1 ? VTK_TRIANGLE : VTK_QUAD;
}

/// Fills the connectivity straight into a vtkCellArray of the given storage type.
template <class StorageArray, class IdType, int Dim>
vtkSmartPointer<vtkCellArray> WriteCells(stm::SpacetreeTessellator<Dim>& tessellator,
  std::vector<stm::MaterialIndex>& materialIndices, std::vector<std::uint8_t>& shapes,
  bool mirrored, stmSMPExecutor& executor)
{
  const std::int64_t cells = tessellator.GetNumberOfCells();
  const bool simplicial = tessellator.IsSimplicial();
  vtkNew<StorageArray> offsets;
  vtkNew<StorageArray> connectivity;
  offsets->SetNumberOfValues(cells + 1);
  connectivity->SetNumberOfValues(tessellator.GetConnectivitySize());
  IdType* ids = connectivity->GetPointer(0);
  shapes.assign(simplicial ? 0 : static_cast<std::size_t>(cells), 1);
  if (!tessellator
         .WriteCells(ids, simplicial ? nullptr : shapes.data(), materialIndices.data(), executor)
         .IsOk())
  {
    return nullptr;
  }
  IdType* offsetValues = offsets->GetPointer(0);
  if (simplicial)
  {
    vtkSMPTools::For(0, cells + 1,
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType i = begin; i < end; ++i)
        {
          offsetValues[i] = static_cast<IdType>(i * (Dim + 1));
        }
      });
  }
  else
  {
    IdType offset = 0;
    for (std::int64_t c = 0; c < cells; ++c)
    {
      offsetValues[c] = offset;
      offset += static_cast<IdType>(stm::CellPointCount(Dim, shapes[c]));
    }
    offsetValues[cells] = offset;
  }
  if (!simplicial || mirrored)
  {
    // The core orders cube corners by code and orients in lattice coordinates; VTK orders
    // them cyclically, and a mirroring image direction flips every cell.
    vtkSMPTools::For(0, cells,
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType c = begin; c < end; ++c)
        {
          const std::uint8_t shape = simplicial ? 1 : shapes[c];
          vtkIdType cellIds[1 << Dim];
          const int count = stm::CellPointCount(Dim, shape);
          std::copy(ids + offsetValues[c], ids + offsetValues[c] + count, cellIds);
          ToVTKOrder<Dim>(shape, cellIds);
          if (mirrored)
          {
            MirrorVTKCell(CellTypeOfShape<Dim>(shape), cellIds);
          }
          std::copy(cellIds, cellIds + count, ids + offsetValues[c]);
        }
      });
  }
  vtkNew<vtkCellArray> cellArray;
  cellArray->SetData(offsets, connectivity);
  return cellArray;
}

/// Physical edge of a voxel along each spacetree axis.
template <int Dim>
std::array<double, Dim> VoxelEdges(
  const stm::Spacetree<Dim>& tree, const stmSpacetreeGeometry& geometry)
{
  std::array<double, Dim> edges{};
  for (int axis = 0; axis < Dim; ++axis)
  {
    const double* vector = geometry.AxisVectors[geometry.ImageAxes[axis]];
    edges[axis] = static_cast<double>(tree.VoxelSubdivision[axis]) *
      std::sqrt(vector[0] * vector[0] + vector[1] * vector[1] + vector[2] * vector[2]);
  }
  return edges;
}

/// The voxel-centred values of the separating function and their sampler: the body indicator,
/// smoothed by a Gaussian of sigma (physical units) when sigma > 0. The smoothed image is padded
/// with outside voxels far enough for the kernel (3 sigma), so the image border is no wall.
template <int Dim>
struct VoxelFunction
{
  std::vector<std::int8_t> Indicator;
  vtkSmartPointer<vtkFloatArray> Smoothed;
  stm::LatticeIndex<Dim> Padding{};
  std::function<double(const double*)> Sample;

  template <class Executor>
  stm::Status Build(const stm::Spacetree<Dim>& tree, const std::array<double, Dim>& voxelEdges,
    double sigma, Executor& executor)
  {
    stm::Status status = stm::BodyIndicator<Dim>(tree, this->Indicator, executor);
    if (!status.IsOk())
    {
      return status;
    }
    if (sigma <= 0)
    {
      stm::VoxelField<Dim, std::int8_t> field{ tree.ImageDimensions, this->Indicator.data(), 1.0 };
      this->Sample = [field](const double* position) { return field.Sample(position); };
      return stm::Status::Ok();
    }
    int dims[3] = { 1, 1, 1 };
    double deviations[3] = { 0, 0, 0 };
    stm::LatticeIndex<Dim> padded;
    std::int64_t total = 1;
    for (int axis = 0; axis < Dim; ++axis)
    {
      deviations[axis] = sigma / voxelEdges[axis];
      this->Padding[axis] = static_cast<std::int64_t>(std::ceil(3.0 * deviations[axis])) + 1;
      padded[axis] = tree.ImageDimensions[axis] + 2 * this->Padding[axis];
      dims[axis] = static_cast<int>(padded[axis]);
      total *= padded[axis];
    }
    if (total > (std::int64_t{ 1 } << 31))
    {
      return stm::Status::OutOfRange("the smoothed indicator would need " + std::to_string(total) +
        " voxels; use a smaller SmoothingSigma");
    }
    vtkNew<vtkImageData> image;
    image->SetDimensions(dims);
    vtkNew<vtkFloatArray> values;
    values->SetNumberOfValues(total);
    values->FillValue(1.0f);
    stm::ForEachLatticePoint<Dim>(stm::LatticeIndex<Dim>{}, tree.ImageDimensions,
      [&](const stm::LatticeIndex<Dim>& voxel)
      {
        std::int64_t source = 0, target = 0;
        for (int axis = Dim - 1; axis >= 0; --axis)
        {
          source = source * tree.ImageDimensions[axis] + voxel[axis];
          target = target * padded[axis] + voxel[axis] + this->Padding[axis];
        }
        values->SetValue(target, static_cast<float>(this->Indicator[source]));
      });
    image->GetPointData()->SetScalars(values);
    vtkNew<vtkImageGaussianSmooth> smooth;
    smooth->SetDimensionality(Dim);
    smooth->SetStandardDeviations(deviations);
    smooth->SetRadiusFactors(3.0, 3.0, 3.0);
    smooth->SetInputData(image);
    smooth->Update();
    this->Smoothed = vtkFloatArray::SafeDownCast(smooth->GetOutput()->GetPointData()->GetScalars());
    if (!this->Smoothed)
    {
      return stm::Status::Invalid("the Gaussian smoothing of the indicator failed");
    }
    std::vector<std::int8_t>().swap(this->Indicator);
    stm::VoxelField<Dim, float> field{ padded, this->Smoothed->GetPointer(0), 1.0 };
    const stm::LatticeIndex<Dim> padding = this->Padding;
    this->Sample = [field, padding](const double* position)
    {
      double shifted[Dim];
      for (int axis = 0; axis < Dim; ++axis)
      {
        shifted[axis] = position[axis] + static_cast<double>(padding[axis]);
      }
      return field.Sample(shifted);
    };
    return stm::Status::Ok();
  }
};

/// Background layers that keep the separating function's zero set inside the mesh.
template <int Dim>
int RequiredBoundaryLayers(int function, double sigma, const std::array<double, Dim>& voxelEdges)
{
  if (function == stmSpacetreeTessellate::LABELS)
  {
    return 1;
  }
  if (function == stmSpacetreeTessellate::SMOOTHED_LABELS)
  {
    const double smallest = *std::min_element(voxelEdges.begin(), voxelEdges.end());
    return static_cast<int>(std::min(100.0, 1.0 + std::ceil(3.0 * sigma / smallest)));
  }
  return 0;
}

template <int Dim>
bool Tessellate(vtkUnstructuredGrid* input, const stmSpacetreeGeometry& geometry,
  stm::SpacetreeTessellationOptions options, int separatingFunction, double sigma,
  stmSMPExecutor& executor, vtkUnstructuredGrid* output, vtkIdType& insertedPoints,
  int& boundaryLayers, std::string& error)
{
  stm::Spacetree<Dim> tree;
  if (!stmSpacetreeData::ReadSpacetree<Dim>(input, tree, error))
  {
    return false;
  }
  if (geometry.IsPiece)
  {
    // The leaves of the outer ghost root layer give no cells: they are there to make the
    // inner layers' leaves the whole tree's (stm::GhostRootLayersFor), and their cells would only
    // cost memory and time in every later stage.
    stm::LatticeIndex<Dim> rootVoxels;
    for (int axis = 0; axis < Dim; ++axis)
    {
      rootVoxels[axis] = tree.CellSizes[0][axis] / tree.VoxelSubdivision[axis];
    }
    options.HiddenLeaves.assign(static_cast<std::size_t>(tree.GetNumberOfLeaves()), 0);
    stmSpacetreeData::MarkLeavesOutsideOwnedBox<Dim>(
      tree, geometry, stm::GhostRootLayersFor<Dim>(rootVoxels) - 1, 1, options.HiddenLeaves.data());
  }
  const std::array<double, Dim> voxelEdges = VoxelEdges<Dim>(tree, geometry);
  if (!options.IncludeBackground)
  {
    options.BoundaryLayers = std::max(
      options.BoundaryLayers, RequiredBoundaryLayers<Dim>(separatingFunction, sigma, voxelEdges));
  }
  boundaryLayers = options.IncludeBackground ? 0 : options.BoundaryLayers;
  VoxelFunction<Dim> voxelFunction;
  vtkSmartPointer<vtkDoubleArray> functionArray;
  double* functionValues = nullptr;
  if (separatingFunction != stmSpacetreeTessellate::NO_FUNCTION)
  {
    executor.SetProgressRange(0.0, 0.1);
    const stm::Status built = voxelFunction.Build(tree, voxelEdges,
      separatingFunction == stmSpacetreeTessellate::SMOOTHED_LABELS ? sigma : 0.0, executor);
    if (!built.IsOk())
    {
      error = built.GetMessage();
      return false;
    }
  }
  stm::SpacetreeTessellator<Dim> tessellator;
  executor.SetProgressRange(0.1, 0.95);
  stm::Status status = tessellator.Prepare(tree, options, executor);
  if (!status.IsOk())
  {
    error = status.GetMessage();
    return false;
  }
  const std::int64_t cells = tessellator.GetNumberOfCells();
  const std::int64_t numberOfPoints = tessellator.GetNumberOfPoints();
  insertedPoints = tessellator.CountInsertedPoints(executor);

  // Points.
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(numberOfPoints);
  double* xyz = vtkDoubleArray::SafeDownCast(points->GetData())->GetPointer(0);
  if (voxelFunction.Sample)
  {
    functionArray = vtkSmartPointer<vtkDoubleArray>::New();
    functionArray->SetName("SeparatingFunction");
    functionArray->SetNumberOfValues(numberOfPoints);
    functionValues = functionArray->GetPointer(0);
  }
  vtkSmartPointer<vtkUnsignedCharArray> hangingNodes;
  unsigned char* hanging = nullptr;
  if (options.Output == stm::TessellationOutput::Leaves)
  {
    hangingNodes = vtkSmartPointer<vtkUnsignedCharArray>::New();
    hangingNodes->SetName("HangingNode");
    hangingNodes->SetNumberOfValues(numberOfPoints);
    hanging = hangingNodes->GetPointer(0);
  }
  auto place = [&](std::int64_t id, const stm::LatticeIndex<Dim>& halfUnits)
  {
    if (hanging)
    {
      hanging[id] = tessellator.IsHangingNode(halfUnits) ? 1 : 0;
    }
    double lattice[3];
    for (int axis = 0; axis < Dim; ++axis)
    {
      lattice[axis] = 0.5 * static_cast<double>(halfUnits[axis]);
    }
    geometry.ToPhysical(lattice, xyz + 3 * id);
    if (functionValues)
    {
      double voxel[Dim];
      for (int axis = 0; axis < Dim; ++axis)
      {
        voxel[axis] = lattice[axis] / static_cast<double>(tree.VoxelSubdivision[axis]);
      }
      functionValues[id] = voxelFunction.Sample(voxel);
    }
  };
  status = tessellator.VisitPoints(place, executor);
  if (!status.IsOk())
  {
    error = status.GetMessage();
    return false;
  }

  // A 3D lattice-to-physical map with negative determinant turns positive cells inside out.
  bool mirrored = false;
  if (Dim == 3)
  {
    mirrored = vtkMath::Determinant3x3(geometry.AxisVectors) < 0;
  }

  // Cells, 32-bit connectivity whenever the sizes allow.
  std::vector<stm::MaterialIndex> materialIndices(static_cast<std::size_t>(cells));
  std::vector<std::uint8_t> shapes;
  const bool fits32 =
    tessellator.GetConnectivitySize() < std::numeric_limits<std::int32_t>::max() &&
    numberOfPoints < std::numeric_limits<std::int32_t>::max();
  vtkSmartPointer<vtkCellArray> cellArray = fits32
    ? WriteCells<vtkTypeInt32Array, vtkTypeInt32, Dim>(
        tessellator, materialIndices, shapes, mirrored, executor)
    : WriteCells<vtkTypeInt64Array, vtkTypeInt64, Dim>(
        tessellator, materialIndices, shapes, mirrored, executor);
  if (!cellArray)
  {
    error = "execution aborted";
    return false;
  }
  vtkNew<vtkUnsignedCharArray> types;
  types->SetNumberOfValues(cells);
  if (shapes.empty())
  {
    types->FillValue(CellTypeOfShape<Dim>(1));
  }
  else
  {
    unsigned char* typeValues = types->GetPointer(0);
    vtkSMPTools::For(0, cells,
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType c = begin; c < end; ++c)
        {
          typeValues[c] = CellTypeOfShape<Dim>(shapes[c]);
        }
      });
  }

  vtkNew<vtkIntArray> materials;
  materials->SetName("Material");
  materials->SetNumberOfValues(cells);
  int* materialValues = materials->GetPointer(0);
  vtkSMPTools::For(0, cells,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType c = begin; c < end; ++c)
      {
        materialValues[c] = static_cast<int>(tree.MaterialLabels[materialIndices[c]]);
      }
    });

  output->SetPoints(points);
  output->SetCells(types, cellArray);
  output->GetCellData()->AddArray(materials);
  output->GetCellData()->SetActiveScalars("Material");
  const std::vector<std::int64_t>& leafCells = tessellator.GetLeafCellOffsets();
  {
    // The colour of each cell's root cell in the whole grid, by which the smoothing orders its
    // moves alike in every piece (stm::RootColouring). A piece's lattice starts at its ghost
    // box, a root cell's corner.
    stm::LatticeIndex<Dim> rootOffset{};
    for (int axis = 0; axis < Dim; ++axis)
    {
      rootOffset[axis] = std::llround(geometry.LatticeOffset[axis]) / tree.GetRootCellSize()[axis];
    }
    vtkNew<vtkUnsignedCharArray> colours;
    colours->SetName(stmPieces::RootColourName);
    colours->SetNumberOfValues(cells);
    unsigned char* colourValues = colours->GetPointer(0);
    vtkSMPTools::For(0, tree.GetNumberOfLeaves(),
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType leaf = begin; leaf < end; ++leaf)
        {
          std::fill(colourValues + leafCells[leaf], colourValues + leafCells[leaf + 1],
            stm::RootColouring<Dim>::LeafColour(tree, leaf, rootOffset));
        }
      });
    output->GetCellData()->AddArray(colours);
  }
  if (geometry.IsPiece)
  {
    // A cell is a ghost where its leaf is.
    std::vector<std::uint8_t> ghostLeaves(static_cast<std::size_t>(tree.GetNumberOfLeaves()));
    stmSpacetreeData::MarkLeavesOutsideOwnedBox<Dim>(
      tree, geometry, 0, vtkDataSetAttributes::DUPLICATECELL, ghostLeaves.data());
    vtkSmartPointer<vtkUnsignedCharArray> ghosts = stmPieces::NewGhostArray(cells);
    unsigned char* ghostValues = ghosts->GetPointer(0);
    vtkSMPTools::For(0, tree.GetNumberOfLeaves(),
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType leaf = begin; leaf < end; ++leaf)
        {
          std::fill(
            ghostValues + leafCells[leaf], ghostValues + leafCells[leaf + 1], ghostLeaves[leaf]);
        }
      });
    output->GetCellData()->AddArray(ghosts);
  }
  if (hangingNodes)
  {
    output->GetPointData()->AddArray(hangingNodes);
  }
  if (functionArray)
  {
    output->GetPointData()->SetScalars(functionArray);
  }
  return true;
}
} // namespace

stmSpacetreeTessellate::stmSpacetreeTessellate() = default;
stmSpacetreeTessellate::~stmSpacetreeTessellate() = default;

void stmSpacetreeTessellate::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  static const char* const outputTypes[] = { "Simplicial", "Hybrid", "Leaves" };
  static const char* const templateRules[] = { "MidpointEverywhere", "RegularFaces", "Extended" };
  os << indent << "OutputType: " << outputTypes[this->OutputType] << "\n";
  os << indent << "TemplateRule: " << templateRules[this->TemplateRule] << "\n";
  os << indent << "CellTemplate: " << (this->CellTemplate == CHECKERBOARD ? "Checkerboard" : "Kuhn")
     << "\n";
  os << indent << "IncludeBackground: " << (this->IncludeBackground ? "On" : "Off") << "\n";
  os << indent << "BoundaryLayers: " << this->BoundaryLayers << "\n";
  static const char* const functions[] = { "NoFunction", "Labels", "SmoothedLabels" };
  os << indent << "SeparatingFunction: " << functions[this->SeparatingFunction] << "\n";
  os << indent << "SmoothingSigma: " << this->SmoothingSigma << "\n";
  os << indent << "NumberOfInsertedPoints: " << this->NumberOfInsertedPoints << "\n";
  os << indent << "NumberOfBoundaryLayers: " << this->NumberOfBoundaryLayers << "\n";
}

int stmSpacetreeTessellate::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkUnstructuredGrid* output = vtkUnstructuredGrid::GetData(outputVector, 0);
  vtkUnstructuredGrid* input = nullptr;
  stmSpacetreeGeometry geometry;
  int requestResult = 0;
  if (!stmSpacetreeData::BeginRequest(this, inputVector[0], output, input, geometry, requestResult))
  {
    return requestResult;
  }
  std::string error;
  stm::SpacetreeTessellationOptions options;
  options.Template =
    this->CellTemplate == KUHN ? stm::CellTemplate::Kuhn : stm::CellTemplate::Checkerboard;
  options.IncludeBackground = this->IncludeBackground;
  options.Output = static_cast<stm::TessellationOutput>(this->OutputType);
  options.Templates = static_cast<stm::TemplateRule>(this->TemplateRule);
  options.BoundaryLayers = this->BoundaryLayers;
  stmSMPExecutor executor(this);
  this->NumberOfInsertedPoints = 0;
  this->NumberOfBoundaryLayers = 0;
  const bool done = geometry.Dimension == 3
    ? Tessellate<3>(input, geometry, options, this->SeparatingFunction, this->SmoothingSigma,
        executor, output, this->NumberOfInsertedPoints, this->NumberOfBoundaryLayers, error)
    : Tessellate<2>(input, geometry, options, this->SeparatingFunction, this->SmoothingSigma,
        executor, output, this->NumberOfInsertedPoints, this->NumberOfBoundaryLayers, error);
  if (done)
  {
    // The executive passes the input's field data on; the spacetree's do not describe a mesh.
    stmSpacetreeData::RemoveSpacetreeFieldData(output->GetFieldData());
  }
  return stmSpacetreeData::EndRequest(this, done, error, output);
}
