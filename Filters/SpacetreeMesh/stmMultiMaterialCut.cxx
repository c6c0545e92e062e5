// SPDX-License-Identifier: BSD-3-Clause
#include "stmMultiMaterialCut.h"

#include "stmCutInput.h"
#include "stmPieceBorder.h"
#include "stmPieceExchange.h"
#include "stmPieces.h"
#include "stmPlaneFrame.h"
#include "stmSMPExecutor.h"
#include "stmSnapExchange.h"

#include "Cut/MultiMaterialCut.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkIdList.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkIntArray.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkSMPThreadLocal.h"
#include "vtkSMPTools.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

vtkStandardNewMacro(stmMultiMaterialCut);

namespace
{
/// The materials in peeling order: the distinct labels of the cell array ascending, the
/// background last. Each thread keeps a sorted list of the labels it met (label images have
/// few), instead of a sort of every cell's label.
std::vector<std::int64_t> PeelingOrder(vtkDataArray* labels, std::int64_t background)
{
  vtkSMPThreadLocal<std::vector<std::int64_t>> found;
  vtkSMPTools::For(0, labels->GetNumberOfTuples(),
    [&](vtkIdType begin, vtkIdType end)
    {
      std::vector<std::int64_t>& mine = found.Local();
      for (vtkIdType c = begin; c < end; ++c)
      {
        const auto label = static_cast<std::int64_t>(labels->GetComponent(c, 0));
        const auto at = std::lower_bound(mine.begin(), mine.end(), label);
        if (at == mine.end() || *at != label)
        {
          mine.insert(at, label);
        }
      }
    });
  std::vector<std::int64_t> order{ background };
  for (const std::vector<std::int64_t>& mine : found)
  {
    order.insert(order.end(), mine.begin(), mine.end());
  }
  std::sort(order.begin(), order.end());
  order.erase(std::unique(order.begin(), order.end()), order.end());
  order.erase(std::find(order.begin(), order.end(), background));
  order.push_back(background);
  return order;
}

/// The peeling order of every rank's labels together (collective), so that the pieces that
/// exchange make the same steps.
std::vector<std::int64_t> CommonPeelingOrder(vtkMultiProcessController* controller,
  const std::vector<std::int64_t>& order, std::int64_t background)
{
  const std::vector<double> all =
    stmPieceBorder::detail::AllGather(controller, std::vector<double>(order.begin(), order.end()));
  std::vector<std::int64_t> common(all.begin(), all.end());
  std::sort(common.begin(), common.end());
  common.erase(std::unique(common.begin(), common.end()), common.end());
  common.erase(std::find(common.begin(), common.end(), background));
  common.push_back(background);
  return common;
}

struct CutResult
{
  int Materials = 0;
  vtkIdType SplitCells = 0;
  vtkIdType SplitAssignedCells = 0;
  vtkIdType CutPoints = 0;
  vtkIdType SnappedPoints = 0;
  bool CutRan = false; // the core's Run was called (it takes part in the exchanges itself)
};

template <int Dim, class IdType>
stm::Status Cut(stmMultiMaterialCut* filter, vtkUnstructuredGrid* input, const IdType* connectivity,
  vtkDataArray* labels, const std::vector<std::int64_t>& order, const stmPlaneFrame& frame,
  const stm::MultiMaterialCutOptions& options, vtkUnstructuredGrid* output, CutResult& result)
{
  const vtkIdType numberOfPoints = input->GetNumberOfPoints();
  const vtkIdType numberOfCells = input->GetNumberOfCells();
  std::vector<std::int32_t> materials(static_cast<std::size_t>(numberOfCells));
  vtkSMPTools::For(0, numberOfCells,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType c = begin; c < end; ++c)
      {
        const auto label = static_cast<std::int64_t>(labels->GetComponent(c, 0));
        materials[c] = static_cast<std::int32_t>(
          std::lower_bound(order.begin(), order.end() - 1, label) - order.begin());
        materials[c] =
          order[materials[c]] == label ? materials[c] : static_cast<std::int32_t>(order.size()) - 1;
      }
    });
  std::vector<double> xyz(static_cast<std::size_t>(3 * numberOfPoints));
  vtkPoints* inputPoints = input->GetPoints();
  vtkSMPTools::For(0, numberOfPoints,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType p = begin; p < end; ++p)
      {
        inputPoints->GetPoint(p, xyz.data() + 3 * p);
      }
    });

  if (filter->GetAbortExecute())
  {
    return stm::Status::Aborted();
  }
  stmSMPExecutor executor(filter);
  executor.SetProgressRange(0.02, 0.15);
  const int count = static_cast<int>(order.size());
  stm::MaterialFractions fractions;
  stm::Status status = stm::CornerFractions<Dim>(xyz.data(), numberOfPoints, connectivity,
    numberOfCells, materials.data(), count, count - 1, fractions, executor);
  if (!status.IsOk())
  {
    return status;
  }
  executor.SetProgressRange(0.15, 0.85);
  std::vector<double> core = frame.CoreCoordinates<Dim>(inputPoints);
  // The input's volume per material, before snapping moves points: what BoundarySmooth's
  // RestoreOriginalVolumes gives back to each material. A piece's own cells only: the smoothing
  // sums its volumes without the ghost cells, which it does not move and of which the cut keeps
  // only a ring.
  const std::vector<stm::ExactSum> inputVolumes = stm::VolumePerMaterial<Dim>(core.data(),
    connectivity, numberOfCells, materials.data(), count, stmPieces::GhostCellFlags(input));
  stm::MultiMaterialCut<Dim> cut;
  result.CutRan = true;
  status = cut.Run(numberOfPoints, options.SnapVertices ? core.data() : nullptr, connectivity,
    numberOfCells, materials.data(), count, std::move(fractions), options, executor);
  std::vector<double>().swap(core);
  if (!status.IsOk())
  {
    return status;
  }
  std::vector<std::int32_t>().swap(materials);
  result.Materials = count;
  result.SplitCells = cut.GetCounts().SplitCells;
  result.SplitAssignedCells = cut.GetCounts().SplitAssignedCells;
  result.CutPoints = cut.GetCounts().AddedPoints;
  result.SnappedPoints = cut.GetCounts().SnappedPoints;

  // Points: the input's, then each added point on its edge, in order (an edge's ends come
  // first).
  const std::vector<stm::CutEdge>& added = cut.GetAddedPoints();
  const vtkIdType total = numberOfPoints + static_cast<vtkIdType>(added.size());
  // The cells first, as the largest arrays: the core's copy is freed before the points and
  // the cell data are made (AAL, 116 labels: 222 MB).
  const vtkIdType cells = cut.GetNumberOfCells();
  {
    const std::vector<std::int64_t> cellIds = cut.TakeCells();
    const bool fits32 = total < std::numeric_limits<std::int32_t>::max() &&
      cells * (Dim + 1) < std::numeric_limits<std::int32_t>::max();
    output->SetCells(Dim == 3 ? VTK_TETRA : VTK_TRIANGLE,
      fits32 ? stmCutInput::FixedSizeCells<std::int32_t>(cellIds, Dim + 1)
             : stmCutInput::FixedSizeCells<std::int64_t>(cellIds, Dim + 1));
  }
  filter->UpdateProgress(0.88);

  // The points, written straight into the output, and the point data interpolated the same
  // way.
  vtkNew<vtkDoubleArray> coordinates;
  coordinates->SetNumberOfComponents(3);
  coordinates->SetNumberOfTuples(total);
  double* xyzOut = coordinates->GetPointer(0);
  std::copy(xyz.begin(), xyz.end(), xyzOut);
  std::vector<double>().swap(xyz);
  for (vtkIdType p = numberOfPoints; p < total; ++p)
  {
    const stm::CutEdge& edge = added[p - numberOfPoints];
    for (int c = 0; c < 3; ++c)
    {
      xyzOut[3 * p + c] = (1.0 - edge.T) * xyzOut[3 * edge.A + c] + edge.T * xyzOut[3 * edge.B + c];
    }
  }
  if (options.SnapVertices)
  {
    // The core's places: snapped points moved, later cut points between moved points.
    const std::vector<double>& places = cut.GetPoints();
    vtkSMPTools::For(0, total,
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType p = begin; p < end; ++p)
        {
          double original[3] = { xyzOut[3 * p], xyzOut[3 * p + 1], xyzOut[3 * p + 2] };
          frame.Lift<Dim>(places.data() + p * Dim, original, xyzOut + 3 * p);
        }
      });
  }
  vtkNew<vtkPoints> points;
  points->SetData(coordinates);
  output->SetPoints(points);
  vtkPointData* inPD = input->GetPointData();
  vtkPointData* outPD = output->GetPointData();
  outPD->InterpolateAllocate(inPD, total);
  // The input points' data as one range per array (a call per point took 0.1 s of the 116
  // labels' cut for one array).
  outPD->CopyData(inPD, vtkIdType{ 0 }, numberOfPoints, vtkIdType{ 0 });
  for (vtkIdType p = numberOfPoints; p < total; ++p)
  {
    const stm::CutEdge& edge = added[p - numberOfPoints];
    outPD->InterpolateEdge(outPD, p, edge.A, edge.B, edge.T);
  }
  filter->UpdateProgress(0.92);

  vtkCellData* inCD = input->GetCellData();
  vtkCellData* outCD = output->GetCellData();
  outCD->CopyAllocate(inCD, cells);
  stmCutInput::GatherTuples(inCD, outCD, cut.GetCellParents().data(), cells, 0);
  if (vtkAbstractArray* original = outCD->GetAbstractArray("Material"))
  {
    original->SetName("OriginalMaterial");
  }
  vtkNew<vtkDoubleArray> volumes;
  volumes->SetName("OriginalMaterialVolumes");
  volumes->SetNumberOfComponents(2);
  volumes->SetComponentName(0, "Material");
  volumes->SetComponentName(1, "Volume");
  for (int m = 0; m < count; ++m)
  {
    if (inputVolumes[m].Value() > 0.0)
    {
      volumes->InsertNextTuple2(static_cast<double>(order[m]), inputVolumes[m].Value());
    }
  }
  output->GetFieldData()->AddArray(volumes);
  if (stmPieces::GhostCellFlags(input))
  {
    // A piece's own volumes as exact parts, which the pieces' smoothing adds up to the whole
    // mesh's volumes (the rounded sums of pieces are not the whole mesh's rounded sum).
    vtkNew<vtkDoubleArray> parts;
    parts->SetName(stmPieces::VolumePartsName);
    parts->SetNumberOfComponents(2);
    parts->SetComponentName(0, "Material");
    parts->SetComponentName(1, "VolumePart");
    for (int m = 0; m < count; ++m)
    {
      for (const double part : inputVolumes[m].Parts())
      {
        parts->InsertNextTuple2(static_cast<double>(order[m]), part);
      }
    }
    output->GetFieldData()->AddArray(parts);
  }
  vtkNew<vtkIntArray> material;
  material->SetName("Material");
  material->SetNumberOfValues(cells);
  const std::vector<std::int32_t>& indices = cut.GetCellMaterials();
  vtkSMPTools::For(0, cells,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType c = begin; c < end; ++c)
      {
        material->SetValue(c, static_cast<int>(order[indices[c]]));
      }
    });
  outCD->AddArray(material);
  outCD->SetActiveScalars("Material");
  return stm::Status::Ok();
}
} // namespace

void stmMultiMaterialCut::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "BackgroundMaterial: " << this->BackgroundMaterial << "\n";
  os << indent << "ZeroTolerance: " << this->ZeroTolerance << "\n";
  os << indent << "VertexSnapping: " << (this->VertexSnapping ? "On" : "Off") << "\n";
  os << indent << "NumberOfMaterials: " << this->NumberOfMaterials << "\n";
  os << indent << "NumberOfSplitCells: " << this->NumberOfSplitCells << "\n";
  os << indent << "NumberOfSplitAssignedCells: " << this->NumberOfSplitAssignedCells << "\n";
  os << indent << "NumberOfCutPoints: " << this->NumberOfCutPoints << "\n";
  os << indent << "NumberOfSnappedPoints: " << this->NumberOfSnappedPoints << "\n";
}

int stmMultiMaterialCut::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkUnstructuredGrid* input = vtkUnstructuredGrid::GetData(inputVector[0], 0);
  vtkUnstructuredGrid* output = vtkUnstructuredGrid::GetData(outputVector, 0);
  this->NumberOfMaterials = 0;
  this->NumberOfSplitCells = 0;
  this->NumberOfSplitAssignedCells = 0;
  this->NumberOfCutPoints = 0;
  this->NumberOfSnappedPoints = 0;
  output->Initialize();
  // Pieces on the ranks of an MPI run snap as the whole mesh does (stmStepSnapExchanges), if
  // every rank has a piece with ghost cells: every rank agrees once (`agree`), those that stop
  // before with false. After the agreement and until the core's Run takes part in the exchanges
  // itself, a rank that stops tells the others at their first agreement (`stopExchanging`).
  vtkMultiProcessController* controller =
    stmPieces::ControllerOfPieces(outputVector->GetInformationObject(0));
  std::unique_ptr<stmStepSnapExchanges> exchanges;
  bool agreed = controller == nullptr;
  auto agree = [&](bool can, int dimension)
  {
    if (!agreed)
    {
      agreed = true;
      if (stmPieceExchange::AllAgree(controller, can))
      {
        exchanges = std::make_unique<stmStepSnapExchanges>(controller, dimension);
      }
    }
  };
  auto stopExchanging = [&](bool aborted)
  {
    if (exchanges)
    {
      exchanges->Maximum(aborted ? 1.0 : 2.0);
      exchanges.reset();
    }
  };
  auto fail = [&](const std::string& message)
  {
    agree(false, 0);
    stopExchanging(false);
    output->Initialize();
    vtkErrorMacro(<< "MultiMaterialCut failed: " << message);
    return 0;
  };
  std::string problem;
  const int dimension =
    stmCutInput::Preflight(inputVector[0], input, stmCutInput::TessellateSimplicialFirst, problem);
  if (dimension < 0)
  {
    agree(false, 0);
    return 1; // an upstream filter was aborted: an empty output, quietly
  }
  if (dimension == 0)
  {
    return fail(problem);
  }
  vtkDataArray* materialArray = input->GetCellData()->GetArray("Material");
  if (!materialArray)
  {
    return fail("the input has no cell array Material; tessellate a label image (Spacetree "
                "Tessellate) or add the materials as the integer cell array Material");
  }
  if (materialArray->GetNumberOfComponents() != 1)
  {
    return fail("the cell array Material must have one component, it has " +
      std::to_string(materialArray->GetNumberOfComponents()));
  }
  // The serial preparation below takes most of a second on the AAL mesh: an abort set at the
  // first progress event (the GUI's) is honoured before and after it, not only in the cut.
  if (this->GetAbortExecute())
  {
    agree(false, 0);
    return 1;
  }
  std::vector<std::int64_t> order = PeelingOrder(materialArray, this->BackgroundMaterial);
  if (this->GetAbortExecute())
  {
    agree(false, 0);
    return 1;
  }
  if (order.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
  {
    return fail("too many materials");
  }
  stmPlaneFrame frame;
  if (this->VertexSnapping &&
    !frame.Build(input, dimension, "vertex snapping needs a planar triangle mesh", problem))
  {
    return fail(problem);
  }
  agree(this->VertexSnapping && stmPieces::HasGhostCells(input), dimension);
  if (exchanges)
  {
    order = CommonPeelingOrder(controller, order, this->BackgroundMaterial);
  }
  stm::MultiMaterialCutOptions options;
  options.ZeroTolerance = this->ZeroTolerance;
  options.SnapVertices = this->VertexSnapping;
  options.GhostCells = exchanges ? stmPieces::GhostCellFlags(input) : nullptr;
  options.Exchanges = exchanges.get();
  this->UpdateProgress(0.02);

  CutResult result;
  const stm::Status status = stmCutInput::DispatchSimplices(input->GetCells(), dimension,
    [&](auto dim, const auto* ids)
    {
      return Cut<decltype(dim)::value>(
        this, input, ids, materialArray, order, frame, options, output, result);
    });
  if (result.CutRan)
  {
    exchanges.reset();
  }
  if (!status.IsOk())
  {
    output->Initialize();
    if (this->GetAbortExecute() || status.GetCode() == stm::Status::Code::Aborted)
    {
      stopExchanging(true);
      return 1;
    }
    return fail(status.GetMessage());
  }
  this->NumberOfMaterials = result.Materials;
  this->NumberOfSplitCells = result.SplitCells;
  this->NumberOfSplitAssignedCells = result.SplitAssignedCells;
  this->NumberOfCutPoints = result.CutPoints;
  this->NumberOfSnappedPoints = result.SnappedPoints;
  stmCutInput::KeepGhostRings(
    output, dimension, stmCutInput::KeptGhostRings(outputVector->GetInformationObject(0)), this);
  stmPieces::PassPieceMarker(input, output);
  this->UpdateProgress(1.0);
  return 1;
}
