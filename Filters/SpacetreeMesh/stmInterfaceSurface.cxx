// SPDX-License-Identifier: BSD-3-Clause
#include "stmInterfaceSurface.h"

#include "stmCutInput.h"
#include "stmPieces.h"
#include "stmPlaneFrame.h"
#include "stmSMPExecutor.h"

#include "Surface/InterfaceFacets.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkIdTypeArray.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkSMPTools.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnstructuredGrid.h"

#include <limits>
#include <string>
#include <vector>

vtkStandardNewMacro(stmInterfaceSurface);

namespace
{
template <int Dim, class IdType>
stm::Status Extract(stmInterfaceSurface* filter, vtkUnstructuredGrid* input,
  const stmPlaneFrame& frame, const IdType* connectivity, const stm::InterfaceFacetOptions& options,
  vtkPolyData* output)
{
  const vtkIdType points = input->GetNumberOfPoints();
  const vtkIdType cells = input->GetNumberOfCells();
  vtkPoints* inputPoints = input->GetPoints();
  std::vector<double> local = frame.CoreCoordinates<Dim>(inputPoints);
  const std::vector<std::int64_t> materials = stmCutInput::CellMaterials(input);
  stmSMPExecutor executor(filter);
  executor.SetProgressRange(0.05, 0.8);
  stm::InterfaceFacets<Dim> facets;
  const stm::Status status = stm::ExtractInterfaceFacets<Dim>(local.data(), points, connectivity,
    cells, materials.empty() ? nullptr : materials.data(), options, executor, facets);
  if (!status.IsOk())
  {
    return status;
  }

  // The points used by a facet, in input order, with their point data.
  std::vector<vtkIdType> newId(static_cast<std::size_t>(points), -1);
  for (const std::int64_t id : facets.Connectivity)
  {
    newId[id] = 0;
  }
  vtkNew<vtkIdList> kept;
  for (vtkIdType p = 0; p < points; ++p)
  {
    if (newId[p] == 0)
    {
      newId[p] = kept->GetNumberOfIds();
      kept->InsertNextId(p);
    }
  }
  vtkNew<vtkPoints> outputPoints;
  outputPoints->SetDataType(inputPoints->GetDataType());
  outputPoints->SetNumberOfPoints(kept->GetNumberOfIds());
  inputPoints->GetPoints(kept, outputPoints);
  output->SetPoints(outputPoints);
  vtkNew<vtkIdList> places;
  places->SetNumberOfIds(kept->GetNumberOfIds());
  for (vtkIdType p = 0; p < kept->GetNumberOfIds(); ++p)
  {
    places->SetId(p, p);
  }
  output->GetPointData()->CopyAllocate(input->GetPointData(), kept->GetNumberOfIds());
  output->GetPointData()->CopyData(input->GetPointData(), kept, places);
  filter->UpdateProgress(0.9);
  // An abort requested at this event stops here, before the facets are copied into the output.
  if (filter->CheckAbort())
  {
    return stm::Status::Aborted();
  }

  const vtkIdType count = facets.GetNumberOfFacets();
  vtkNew<vtkIdTypeArray> offsets, ids;
  offsets->SetNumberOfValues(count + 1);
  ids->SetNumberOfValues(count * Dim);
  vtkNew<vtkIntArray> labels;
  labels->SetName("BoundaryLabels");
  labels->SetNumberOfComponents(2);
  labels->SetNumberOfTuples(count);
  vtkNew<vtkIdTypeArray> cellIds;
  cellIds->SetName("CellId");
  cellIds->SetNumberOfValues(count);
  for (vtkIdType f = 0; f < count; ++f)
  {
    offsets->SetValue(f, f * Dim);
    for (int k = 0; k < Dim; ++k)
    {
      ids->SetValue(f * Dim + k, newId[facets.Connectivity[f * Dim + k]]);
    }
    labels->SetTypedComponent(f, 0, static_cast<int>(facets.Labels[2 * f]));
    labels->SetTypedComponent(f, 1, static_cast<int>(facets.Labels[2 * f + 1]));
    cellIds->SetValue(f, static_cast<vtkIdType>(facets.Cells[f]));
  }
  offsets->SetValue(count, count * Dim);
  vtkNew<vtkCellArray> polygons;
  polygons->SetData(offsets, ids);
  if (Dim == 3)
  {
    output->SetPolys(polygons);
  }
  else
  {
    output->SetLines(polygons);
  }
  output->GetCellData()->AddArray(labels);
  output->GetCellData()->AddArray(cellIds);
  stmPieces::AddFacetGhosts(input, facets.Cells.data(), count, output);
  stmPieces::PassPieceMarker(input, output);
  return stm::Status::Ok();
}
} // namespace

void stmInterfaceSurface::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "IncludeOuterBoundary: " << (this->IncludeOuterBoundary ? "On" : "Off") << "\n";
  os << indent << "BackgroundMaterial: " << this->BackgroundMaterial << "\n";
  os << indent << "OuterLabel: " << this->OuterLabel << "\n";
}

int stmInterfaceSurface::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkUnstructuredGrid");
  return 1;
}

int stmInterfaceSurface::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkUnstructuredGrid* input = vtkUnstructuredGrid::GetData(inputVector[0], 0);
  vtkPolyData* output = vtkPolyData::GetData(outputVector, 0);
  output->Initialize();
  auto fail = [&](const std::string& message)
  {
    output->Initialize();
    vtkErrorMacro(<< "InterfaceSurface failed: " << message);
    return 0;
  };
  std::string problem;
  const int dimension = stmCutInput::Preflight(inputVector[0], input,
    "tessellate with Output Type Simplicial, cut with Marching Simplices or tetrahedralize first",
    problem);
  if (dimension < 0)
  {
    return 1; // an upstream filter was aborted: an empty output, quietly
  }
  if (dimension == 0)
  {
    return fail(problem);
  }
  vtkDataArray* material = input->GetCellData()->GetArray("Material");
  if (material && material->GetNumberOfComponents() != 1)
  {
    return fail("the cell array Material must have one component, it has " +
      std::to_string(material->GetNumberOfComponents()));
  }
  stmPlaneFrame frame;
  if (!frame.Build(input, dimension,
        "only planar triangle meshes and tetrahedral meshes have "
        "interfaces this filter can extract",
        problem))
  {
    return fail(problem);
  }
  stm::InterfaceFacetOptions options;
  options.IncludeOuterBoundary = this->IncludeOuterBoundary != 0;
  options.BackgroundMaterial = this->BackgroundMaterial;
  options.OuterLabel = this->OuterLabel;
  this->UpdateProgress(0.05);

  vtkCellArray* cells = input->GetCells();
  const stm::Status status = stmCutInput::DispatchSimplices(cells, dimension,
    [&](auto dim, const auto* ids)
    { return Extract<decltype(dim)::value>(this, input, frame, ids, options, output); });
  if (!status.IsOk())
  {
    output->Initialize();
    if (this->GetAbortExecute() || status.GetCode() == stm::Status::Code::Aborted)
    {
      return 1;
    }
    return fail(status.GetMessage());
  }
  this->UpdateProgress(1.0);
  return 1;
}
