// SPDX-License-Identifier: BSD-3-Clause
#include "stmMarchingSimplices.h"

#include "stmCutInput.h"
#include "stmFunctionValues.h"
#include "stmPieces.h"
#include "stmSMPExecutor.h"

#include "Cut/MarchingSimplices.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCellType.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkIdList.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkMath.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkSMPTools.h"
#include "vtkTriangle.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <cmath>
#include <limits>
#include <numeric>
#include <string>
#include <type_traits>
#include <vector>

vtkStandardNewMacro(stmMarchingSimplices);

namespace
{
/// The points of the output: kept input points, then kept cut points, in that order.
struct PointSelection
{
  std::vector<vtkIdType> InputPoints; // input ids of the kept input points
  std::vector<vtkIdType> CutEdges;    // indices into the cut edge list of the kept cut points
  std::vector<vtkIdType> NewIds;      // per cutter point id (input, then cut): output id or -1
};

/// Keeps every point (used when the whole volume is output).
PointSelection AllPoints(vtkIdType inputPoints, vtkIdType cutPoints)
{
  PointSelection selection;
  selection.InputPoints.resize(inputPoints);
  std::iota(selection.InputPoints.begin(), selection.InputPoints.end(), 0);
  selection.CutEdges.resize(cutPoints);
  std::iota(selection.CutEdges.begin(), selection.CutEdges.end(), 0);
  selection.NewIds.resize(inputPoints + cutPoints);
  std::iota(selection.NewIds.begin(), selection.NewIds.end(), 0);
  return selection;
}

/// Keeps the points that the ids use, in id order.
template <class IdType>
PointSelection UsedPoints(
  vtkIdType inputPoints, vtkIdType cutPoints, const IdType* ids, vtkIdType count)
{
  std::vector<unsigned char> used(static_cast<std::size_t>(inputPoints + cutPoints), 0);
  for (vtkIdType i = 0; i < count; ++i)
  {
    used[ids[i]] = 1;
  }
  PointSelection selection;
  selection.NewIds.assign(used.size(), -1);
  vtkIdType next = 0;
  for (vtkIdType p = 0; p < inputPoints + cutPoints; ++p)
  {
    if (used[p])
    {
      selection.NewIds[p] = next++;
      if (p < inputPoints)
      {
        selection.InputPoints.push_back(p);
      }
      else
      {
        selection.CutEdges.push_back(p - inputPoints);
      }
    }
  }
  return selection;
}

/// Builds the output points and point data: kept input points copied, cut points interpolated
/// along their edges; the separating function is exactly the iso-value at cut points.
void AssemblePoints(vtkPointSet* input, const std::vector<stm::CutEdge>& edges,
  const PointSelection& selection, const std::string& functionName, double isoValue,
  vtkPointSet* output)
{
  const vtkIdType kept = static_cast<vtkIdType>(selection.InputPoints.size());
  const vtkIdType total = kept + static_cast<vtkIdType>(selection.CutEdges.size());
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(total);
  vtkPoints* inputPoints = input->GetPoints();
  double* xyz = vtkDoubleArray::SafeDownCast(points->GetData())->GetPointer(0);
  vtkSMPTools::For(0, total,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType p = begin; p < end; ++p)
      {
        if (p < kept)
        {
          inputPoints->GetPoint(selection.InputPoints[p], xyz + 3 * p);
          continue;
        }
        const stm::CutEdge& edge = edges[selection.CutEdges[p - kept]];
        double a[3], b[3];
        inputPoints->GetPoint(edge.A, a);
        inputPoints->GetPoint(edge.B, b);
        for (int c = 0; c < 3; ++c)
        {
          xyz[3 * p + c] = (1.0 - edge.T) * a[c] + edge.T * b[c];
        }
      }
    });
  output->SetPoints(points);

  vtkPointData* inPD = input->GetPointData();
  vtkPointData* outPD = output->GetPointData();
  outPD->InterpolateAllocate(inPD, total);
  stmCutInput::GatherTuples(inPD, outPD, selection.InputPoints.data(), kept, 0);
  for (vtkIdType p = kept; p < total; ++p)
  {
    const stm::CutEdge& edge = edges[selection.CutEdges[p - kept]];
    outPD->InterpolateEdge(inPD, p, edge.A, edge.B, edge.T);
  }
  if (vtkDataArray* function = outPD->GetArray(functionName.c_str()))
  {
    for (vtkIdType p = kept; p < total; ++p)
    {
      function->SetComponent(p, 0, isoValue);
    }
  }
}

struct CutRequest
{
  stmMarchingSimplices* Filter;
  vtkUnstructuredGrid* Input;
  const double* Values;
  std::string FunctionName;
  stm::MarchingSimplicesOptions Options;
  int OutputMode;
  int InsideMaterial;
  int OutsideMaterial;
  vtkIdType SplitCells = 0;
  vtkIdType CutPoints = 0;
};

template <int Dim, class IdType>
stm::Status CutVolume(CutRequest& request, stm::MarchingSimplices<Dim>& cutter,
  const IdType* connectivity, vtkUnstructuredGrid* output, stmSMPExecutor& executor)
{
  vtkUnstructuredGrid* input = request.Input;
  const vtkIdType cells = cutter.GetNumberOfCells();
  const vtkIdType inputPoints = input->GetNumberOfPoints();
  const auto cutPoints = static_cast<vtkIdType>(cutter.GetCutEdges().size());
  std::vector<std::int64_t> parents(static_cast<std::size_t>(cells));
  std::vector<std::uint8_t> sides(static_cast<std::size_t>(cells));
  const bool fits32 = (inputPoints + cutPoints) < std::numeric_limits<std::int32_t>::max() &&
    cells * (Dim + 1) < std::numeric_limits<std::int32_t>::max();
  const bool compact = request.Options.Keep != stm::KeptSides::Both;
  // The cells go straight into the output's connectivity array: a copy of it was the cut's
  // peak (AAL upsampled 2.5x: 800 MB).
  PointSelection selection;
  vtkSmartPointer<vtkCellArray> cellArray;
  auto writeInto = [&](auto* storage)
  {
    using Value = typename std::remove_pointer_t<decltype(storage)>::ValueType;
    const vtkIdType count = cells * (Dim + 1);
    storage->SetNumberOfValues(count);
    Value* ids = storage->GetPointer(0);
    const stm::Status written =
      cutter.WriteCells(connectivity, ids, parents.data(), sides.data(), executor);
    if (!written.IsOk())
    {
      return written;
    }
    if (!compact)
    {
      selection = AllPoints(inputPoints, cutPoints);
    }
    else
    {
      selection = UsedPoints(inputPoints, cutPoints, ids, count);
      vtkSMPTools::For(0, count,
        [&](vtkIdType begin, vtkIdType end)
        {
          for (vtkIdType i = begin; i < end; ++i)
          {
            ids[i] = static_cast<Value>(selection.NewIds[ids[i]]);
          }
        });
    }
    cellArray = stmCutInput::FixedSizeCellsSharing(storage, Dim + 1);
    return stm::Status::Ok();
  };
  stm::Status status;
  if (fits32)
  {
    vtkNew<vtkTypeInt32Array> ids;
    status = writeInto(ids.GetPointer());
  }
  else
  {
    vtkNew<vtkTypeInt64Array> ids;
    status = writeInto(ids.GetPointer());
  }
  if (!status.IsOk())
  {
    return status;
  }
  AssemblePoints(
    input, cutter.GetCutEdges(), selection, request.FunctionName, request.Options.IsoValue, output);
  selection = PointSelection();
  // The output assembly takes a third of the run on the AAL brain mask: give the GUI a chance to
  // abort in the middle of it.
  request.Filter->UpdateProgress(0.9);
  if (request.Filter->CheckAbort())
  {
    return stm::Status::Aborted();
  }
  output->SetCells(Dim == 3 ? VTK_TETRA : VTK_TRIANGLE, cellArray);

  // Cell data from the parents; Material becomes the side's label.
  vtkCellData* inCD = input->GetCellData();
  vtkCellData* outCD = output->GetCellData();
  outCD->CopyAllocate(inCD, cells);
  stmCutInput::GatherTuples(inCD, outCD, parents.data(), cells, 0);
  std::vector<std::int64_t>().swap(parents);
  if (vtkAbstractArray* original = outCD->GetAbstractArray("Material"))
  {
    original->SetName("OriginalMaterial");
  }
  vtkNew<vtkIntArray> materials;
  materials->SetName("Material");
  materials->SetNumberOfValues(cells);
  int* materialValues = materials->GetPointer(0);
  for (vtkIdType c = 0; c < cells; ++c)
  {
    materialValues[c] = sides[c] == static_cast<std::uint8_t>(stm::CutSide::Inside)
      ? request.InsideMaterial
      : request.OutsideMaterial;
  }
  outCD->AddArray(materials);
  outCD->SetActiveScalars("Material");
  return stm::Status::Ok();
}

template <int Dim, class IdType>
stm::Status CutSurface(CutRequest& request, stm::MarchingSimplices<Dim>& cutter,
  const IdType* connectivity, vtkPolyData* output, stmSMPExecutor& executor)
{
  vtkUnstructuredGrid* input = request.Input;
  std::vector<std::int64_t> facets, insideParents;
  stm::Status status = cutter.ExtractSurface(connectivity, facets, insideParents, executor);
  if (!status.IsOk())
  {
    return status;
  }
  const vtkIdType inputPoints = input->GetNumberOfPoints();
  const auto cutPoints = static_cast<vtkIdType>(cutter.GetCutEdges().size());
  const auto facetCount = static_cast<vtkIdType>(insideParents.size());
  if (Dim == 3)
  {
    // Outward relative to the parent's orientation: flip where the parent is inverted in space.
    vtkPoints* points = input->GetPoints();
    for (vtkIdType f = 0; f < facetCount; ++f)
    {
      const IdType* ids = connectivity + insideParents[f] * (Dim + 1);
      double x[4][3];
      for (int v = 0; v < 4; ++v)
      {
        points->GetPoint(ids[v], x[v]);
      }
      double u[3][3];
      for (int r = 0; r < 3; ++r)
      {
        for (int c = 0; c < 3; ++c)
        {
          u[r][c] = x[r + 1][c] - x[0][c];
        }
      }
      const double det = vtkMath::Determinant3x3(u);
      if (det < 0)
      {
        std::swap(facets[f * Dim], facets[f * Dim + 1]);
      }
    }
  }
  const PointSelection selection =
    UsedPoints(inputPoints, cutPoints, facets.data(), static_cast<vtkIdType>(facets.size()));
  for (std::int64_t& id : facets)
  {
    id = selection.NewIds[id];
  }
  AssemblePoints(
    input, cutter.GetCutEdges(), selection, request.FunctionName, request.Options.IsoValue, output);
  vtkCellData* outCD = output->GetCellData();
  if (vtkDataArray* material = input->GetCellData()->GetArray("Material"))
  {
    vtkNew<vtkIntArray> original;
    original->SetName("OriginalMaterial");
    original->SetNumberOfValues(facetCount);
    for (vtkIdType f = 0; f < facetCount; ++f)
    {
      original->SetValue(f, static_cast<int>(material->GetComponent(insideParents[f], 0)));
    }
    outCD->AddArray(original);
  }
  // A facet is a ghost of a piece where its inside cell is.
  stmPieces::AddFacetGhosts(input, insideParents.data(), facetCount, output);
  if (Dim == 3)
  {
    vtkNew<vtkDoubleArray> normals;
    normals->SetName("Normals");
    normals->SetNumberOfComponents(3);
    normals->SetNumberOfTuples(facetCount);
    vtkPoints* points = output->GetPoints();
    for (vtkIdType f = 0; f < facetCount; ++f)
    {
      double a[3], b[3], c[3], n[3];
      points->GetPoint(facets[f * Dim], a);
      points->GetPoint(facets[f * Dim + 1], b);
      points->GetPoint(facets[f * Dim + 2], c);
      vtkTriangle::ComputeNormal(a, b, c, n);
      normals->SetTuple(f, n);
    }
    outCD->SetNormals(normals);
  }
  vtkSmartPointer<vtkCellArray> cellArray = stmCutInput::FixedSizeCells<std::int64_t>(facets, Dim);
  std::vector<std::int64_t>().swap(facets);
  if (Dim == 3)
  {
    output->SetPolys(cellArray);
  }
  else
  {
    output->SetLines(cellArray);
  }
  return stm::Status::Ok();
}

template <int Dim, class IdType>
stm::Status Cut(CutRequest& request, const IdType* connectivity, vtkDataObject* output)
{
  vtkUnstructuredGrid* input = request.Input;
  stmSMPExecutor executor(request.Filter);
  executor.SetProgressRange(0.05, 0.85);
  vtkDataArray* material = input->GetCellData()->GetArray("Material");
  const int outsideMaterial = request.OutsideMaterial;
  const double* values = request.Values;
  const double iso = request.Options.IsoValue;
  auto allZeroSide = [&](std::int64_t cell)
  {
    if (material)
    {
      return material->GetComponent(cell, 0) == outsideMaterial ? stm::CutSide::Outside
                                                                : stm::CutSide::Inside;
    }
    double sum = 0.0;
    for (int v = 0; v <= Dim; ++v)
    {
      sum += values[connectivity[cell * (Dim + 1) + v]] - iso;
    }
    return sum > 0 ? stm::CutSide::Outside : stm::CutSide::Inside;
  };
  stm::MarchingSimplices<Dim> cutter;
  stm::Status status = cutter.Classify(values, input->GetNumberOfPoints(), connectivity,
    input->GetNumberOfCells(), request.Options, allZeroSide, executor);
  if (!status.IsOk())
  {
    return status;
  }
  request.SplitCells = cutter.GetNumberOfSplitCells();
  request.CutPoints = static_cast<vtkIdType>(cutter.GetCutEdges().size());
  executor.SetProgressRange(0.05, 0.85); // classification took the first half of this range
  if (request.OutputMode == stmMarchingSimplices::SURFACE)
  {
    return CutSurface<Dim>(
      request, cutter, connectivity, vtkPolyData::SafeDownCast(output), executor);
  }
  return CutVolume<Dim>(
    request, cutter, connectivity, vtkUnstructuredGrid::SafeDownCast(output), executor);
}
} // namespace

stmMarchingSimplices::stmMarchingSimplices()
{
  this->SetInputArrayToProcess(
    0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, "SeparatingFunction");
}

stmMarchingSimplices::~stmMarchingSimplices() = default;

void stmMarchingSimplices::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  static const char* const keptSides[] = { "Both", "Inside", "Outside" };
  os << indent << "IsoValue: " << this->IsoValue << "\n";
  os << indent << "ZeroTolerance: " << this->ZeroTolerance << "\n";
  os << indent << "OutputMode: " << (this->OutputMode == VOLUME ? "Volume" : "Surface") << "\n";
  os << indent << "KeepSide: " << keptSides[this->KeepSide] << "\n";
  os << indent << "InsideMaterial: " << this->InsideMaterial << "\n";
  os << indent << "OutsideMaterial: " << this->OutsideMaterial << "\n";
  os << indent << "NumberOfSplitCells: " << this->NumberOfSplitCells << "\n";
  os << indent << "NumberOfCutPoints: " << this->NumberOfCutPoints << "\n";
}

int stmMarchingSimplices::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkUnstructuredGrid");
  return 1;
}

int stmMarchingSimplices::FillOutputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkDataObject::DATA_TYPE_NAME(), "vtkPointSet");
  return 1;
}

int stmMarchingSimplices::RequestDataObject(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkDataObject* output = outInfo->Get(vtkDataObject::DATA_OBJECT());
  if (this->OutputMode == SURFACE && !vtkPolyData::SafeDownCast(output))
  {
    vtkNew<vtkPolyData> surface;
    outInfo->Set(vtkDataObject::DATA_OBJECT(), surface);
  }
  else if (this->OutputMode == VOLUME && !vtkUnstructuredGrid::SafeDownCast(output))
  {
    vtkNew<vtkUnstructuredGrid> volume;
    outInfo->Set(vtkDataObject::DATA_OBJECT(), volume);
  }
  return 1;
}

int stmMarchingSimplices::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkPointSet* output = vtkPointSet::GetData(outputVector, 0);
  vtkUnstructuredGrid* input = vtkUnstructuredGrid::GetData(inputVector[0], 0);
  this->NumberOfSplitCells = 0;
  this->NumberOfCutPoints = 0;
  if (!output)
  {
    vtkErrorMacro("the output is not a point set");
    return 0;
  }
  output->Initialize();
  auto fail = [&](const std::string& message)
  {
    output->Initialize();
    vtkErrorMacro(<< "MarchingSimplices failed: " << message);
    return 0;
  };
  std::string error;
  const int dimension =
    stmCutInput::Preflight(inputVector[0], input, stmCutInput::TessellateSimplicialFirst, error);
  if (dimension < 0)
  {
    return 1; // an upstream filter was aborted: an empty output, quietly
  }
  if (dimension == 0)
  {
    return fail(error);
  }
  int association = -1;
  vtkDataArray* function = this->GetInputArrayToProcess(0, input, association);
  const char* name = this->GetInputArrayInformation(0)->Get(vtkDataObject::FIELD_NAME());
  function = stmCutInput::FindSeparatingFunction(function, association, name, input, error);
  if (!function)
  {
    return fail(error);
  }
  std::vector<double> values;
  const double* valuePointer = stmFunctionValues::AsDoubles(function, values);

  vtkCellArray* cells = input->GetCells();
  CutRequest request{ this, input, valuePointer, function->GetName() ? function->GetName() : "", {},
    this->OutputMode, this->InsideMaterial, this->OutsideMaterial };
  request.Options.IsoValue = this->IsoValue;
  request.Options.ZeroTolerance = this->ZeroTolerance;
  request.Options.Keep = this->OutputMode == SURFACE ? stm::KeptSides::Both
    : this->KeepSide == INSIDE                       ? stm::KeptSides::Inside
    : this->KeepSide == OUTSIDE                      ? stm::KeptSides::Outside
                                                     : stm::KeptSides::Both;
  const stm::Status status = stmCutInput::DispatchSimplices(cells, dimension,
    [&](auto dim, const auto* ids) { return Cut<decltype(dim)::value>(request, ids, output); });
  if (!status.IsOk())
  {
    output->Initialize();
    if (this->GetAbortExecute() || status.GetCode() == stm::Status::Code::Aborted)
    {
      return 1;
    }
    return fail(status.GetMessage());
  }
  this->NumberOfSplitCells = request.SplitCells;
  this->NumberOfCutPoints = request.CutPoints;
  if (this->OutputMode == VOLUME)
  {
    stmCutInput::KeepGhostRings(vtkUnstructuredGrid::SafeDownCast(output), dimension,
      stmCutInput::KeptGhostRings(outputVector->GetInformationObject(0)), this);
  }
  stmPieces::PassPieceMarker(input, output);
  this->UpdateProgress(1.0);
  return 1;
}
