// SPDX-License-Identifier: BSD-3-Clause
#include "stmSpacetreeTessellate.h"

#include "stmSMPExecutor.h"
#include "stmSpacetreeData.h"

#include "Tessellate/SpacetreeTessellation.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCellType.h"
#include "vtkDoubleArray.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPoints.h"
#include "vtkSMPTools.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <limits>

vtkStandardNewMacro(stmSpacetreeTessellate);

namespace
{
/// Fills the connectivity straight into a vtkCellArray of the given storage type.
template <class StorageArray, class IdType, int Dim>
vtkSmartPointer<vtkCellArray> WriteCells(stm::SpacetreeTessellator<Dim>& tessellator,
  std::vector<stm::MaterialIndex>& materialIndices, bool mirrored, stmSMPExecutor& executor)
{
  const std::int64_t cells = tessellator.GetNumberOfSimplices();
  vtkNew<StorageArray> offsets;
  vtkNew<StorageArray> connectivity;
  offsets->SetNumberOfValues(cells + 1);
  connectivity->SetNumberOfValues(cells * (Dim + 1));
  IdType* offsetValues = offsets->GetPointer(0);
  vtkSMPTools::For(0, cells + 1,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType i = begin; i < end; ++i)
      {
        offsetValues[i] = static_cast<IdType>(i * (Dim + 1));
      }
    });
  IdType* ids = connectivity->GetPointer(0);
  if (!tessellator.WriteSimplices(ids, materialIndices.data(), executor).IsOk())
  {
    return nullptr;
  }
  if (mirrored)
  {
    // The core orients in lattice coordinates; a mirroring image direction flips every cell.
    vtkSMPTools::For(0, cells,
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType c = begin; c < end; ++c)
        {
          std::swap(ids[c * (Dim + 1)], ids[c * (Dim + 1) + 1]);
        }
      });
  }
  vtkNew<vtkCellArray> cellArray;
  cellArray->SetData(offsets, connectivity);
  return cellArray;
}

template <int Dim>
bool Tessellate(vtkUnstructuredGrid* input, const stmSpacetreeGeometry& geometry,
  const stm::SpacetreeTessellationOptions& options, stmSMPExecutor& executor,
  vtkUnstructuredGrid* output, std::string& error)
{
  stm::Spacetree<Dim> tree;
  if (!stmSpacetreeData::ReadSpacetree<Dim>(input, tree, error))
  {
    return false;
  }
  stm::SpacetreeTessellator<Dim> tessellator;
  executor.SetProgressRange(0.1, 0.95);
  stm::Status status = tessellator.Prepare(tree, options, executor);
  if (!status.IsOk())
  {
    error = status.GetMessage();
    return false;
  }
  const std::int64_t cells = tessellator.GetNumberOfSimplices();
  const std::int64_t numberOfPoints = tessellator.GetNumberOfPoints();

  // Points.
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(numberOfPoints);
  double* xyz = vtkDoubleArray::SafeDownCast(points->GetData())->GetPointer(0);
  auto place = [&](std::int64_t id, const stm::LatticeIndex<Dim>& halfUnits)
  {
    double lattice[3];
    for (int axis = 0; axis < Dim; ++axis)
    {
      lattice[axis] = 0.5 * static_cast<double>(halfUnits[axis]);
    }
    geometry.ToPhysical(lattice, xyz + 3 * id);
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
    const double(*a)[3] = geometry.AxisVectors;
    const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
      a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
      a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    mirrored = det < 0;
  }

  // Cells, 32-bit connectivity whenever the sizes allow.
  std::vector<stm::MaterialIndex> materialIndices(static_cast<std::size_t>(cells));
  const bool fits32 = cells * (Dim + 1) < std::numeric_limits<std::int32_t>::max() &&
    numberOfPoints < std::numeric_limits<std::int32_t>::max();
  vtkSmartPointer<vtkCellArray> cellArray = fits32
    ? WriteCells<vtkTypeInt32Array, vtkTypeInt32, Dim>(
        tessellator, materialIndices, mirrored, executor)
    : WriteCells<vtkTypeInt64Array, vtkTypeInt64, Dim>(
        tessellator, materialIndices, mirrored, executor);
  if (!cellArray)
  {
    error = "execution aborted";
    return false;
  }
  vtkNew<vtkUnsignedCharArray> types;
  types->SetNumberOfValues(cells);
  types->FillValue(static_cast<unsigned char>(Dim == 3 ? VTK_TETRA : VTK_TRIANGLE));

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
  return true;
}
} // namespace

stmSpacetreeTessellate::stmSpacetreeTessellate() = default;
stmSpacetreeTessellate::~stmSpacetreeTessellate() = default;

void stmSpacetreeTessellate::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "CellTemplate: " << (this->CellTemplate == CHECKERBOARD ? "Checkerboard" : "Kuhn")
     << "\n";
  os << indent << "IncludeBackground: " << (this->IncludeBackground ? "On" : "Off") << "\n";
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
  stmSMPExecutor executor(this);
  const bool done = geometry.Dimension == 3
    ? Tessellate<3>(input, geometry, options, executor, output, error)
    : Tessellate<2>(input, geometry, options, executor, output, error);
  if (done)
  {
    // The executive passes the input's field data on; the spacetree's do not describe a mesh.
    stmSpacetreeData::RemoveSpacetreeFieldData(output->GetFieldData());
  }
  return stmSpacetreeData::EndRequest(this, done, error, output);
}
