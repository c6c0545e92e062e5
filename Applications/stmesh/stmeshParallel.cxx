// SPDX-License-Identifier: BSD-3-Clause
#include "stmeshParallel.h"

#include "stmPieces.h"
#include "stmeshErrors.h"

#include "vtkAggregateDataSetFilter.h"
#include "vtkCellArray.h"
#include "vtkCellArrayIterator.h"
#include "vtkCellData.h"
#include "vtkCommunicator.h"
#include "vtkDataSetAttributes.h"
#include "vtkFieldData.h"
#include "vtkGenerateGlobalIds.h"
#include "vtkIdTypeArray.h"
#include "vtkIntArray.h"
#include "vtkMPIController.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPointSet.h"
#include "vtkPolyData.h"
#include "vtkRemoveGhosts.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"
#include "vtk_mpi.h"

#include <cstdlib>
#include <iostream>
#include <numeric>
#include <string>

namespace stmesh
{
namespace
{
/// The point array WithoutGhostCells leaves for WithGlobalIds: 1 where a point of the piece's
/// own cells also belonged to a ghost cell.
const char* const PieceBorderName = "stmeshPieceBorder";

int EnvironmentInteger(const char* name)
{
  const char* text = std::getenv(name);
  if (!text || !*text)
  {
    return -1;
  }
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  return (*end == '\0' && value >= 0 && value < (1L << 30)) ? static_cast<int>(value) : -1;
}

/// Where each rank's values go in a gathered buffer, from the ranks' value counts.
struct GatherLayout
{
  template <class Number>
  explicit GatherLayout(const std::vector<Number>& lengths)
  {
    for (const Number length : lengths)
    {
      this->Counts.push_back(static_cast<vtkIdType>(length));
      this->Offsets.push_back(this->Total);
      this->Total += this->Counts.back();
    }
  }
  std::vector<vtkIdType> Counts;
  std::vector<vtkIdType> Offsets;
  vtkIdType Total = 0;
};

/// The output of a filter run on mesh, as a copy that outlives the filter.
vtkSmartPointer<vtkPointSet> RunOn(vtkAlgorithm* filter, vtkPointSet* mesh, const char* context)
{
  Watch(filter);
  filter->SetInputDataObject(0, mesh);
  filter->Update();
  ThrowIfFailed(context);
  vtkPointSet* output = vtkPointSet::SafeDownCast(filter->GetOutputDataObject(0));
  if (!output)
  {
    throw Failure(std::string(context) + ": the filter produced no mesh");
  }
  vtkSmartPointer<vtkPointSet> copy = vtkSmartPointer<vtkPointSet>::Take(output->NewInstance());
  copy->ShallowCopy(output);
  return copy;
}
} // namespace

LaunchEnvironment ReadLaunchEnvironment()
{
  LaunchEnvironment launch;
  // Open MPI's mpiexec, then MPICH's Hydra and Slurm's PMI, then PMIx launchers.
  const char* const sizeNames[] = { "OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE" };
  const char* const rankNames[] = { "OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK" };
  const char* const localSizeNames[] = { "OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS",
    "PMIX_LOCAL_SIZE" };
  for (int launcher = 0; launcher < 3; ++launcher)
  {
    const int ranks = EnvironmentInteger(sizeNames[launcher]);
    const int rank = EnvironmentInteger(rankNames[launcher]);
    if (ranks > 0 && rank >= 0 && rank < ranks)
    {
      launch.Ranks = ranks;
      launch.Rank = rank;
      launch.RanksOnThisNode = EnvironmentInteger(localSizeNames[launcher]);
      break;
    }
  }
  return launch;
}

ParallelRun::~ParallelRun()
{
  if (this->Controller)
  {
    this->Controller->Finalize();
    vtkMultiProcessController::SetGlobalController(nullptr);
  }
}

void ParallelRun::Start(int* argc, char*** argv)
{
  auto controller = vtkSmartPointer<vtkMPIController>::New();
  controller->Initialize(argc, argv);
  vtkMultiProcessController::SetGlobalController(controller);
  this->Controller = controller;
  this->RankValue = controller->GetLocalProcessId();
  this->RanksValue = controller->GetNumberOfProcesses();
}

vtkMultiProcessController* ParallelRun::GetController() const
{
  return this->Controller;
}

void ParallelRun::Abort(int status)
{
  std::cout.flush();
  std::cerr.flush();
  MPI_Abort(MPI_COMM_WORLD, status);
  std::exit(status); // not reached: MPI_Abort ends the process
}

long long ParallelRun::Sum(long long value) const
{
  long long sum = value;
  if (this->Controller)
  {
    this->Controller->AllReduce(&value, &sum, 1, vtkCommunicator::SUM_OP);
  }
  return sum;
}

long long ParallelRun::ExclusiveSum(long long value) const
{
  const std::vector<long long> all = this->AllGather({ value });
  return std::accumulate(all.begin(), all.begin() + this->RankValue, 0LL);
}

std::vector<long long> ParallelRun::AllGather(const std::vector<long long>& values) const
{
  if (!this->Controller)
  {
    return values;
  }
  const int ranks = this->RanksValue;
  const long long length = static_cast<long long>(values.size());
  std::vector<long long> lengths(ranks);
  this->Controller->AllGather(&length, lengths.data(), 1);
  GatherLayout layout(lengths); // not const: VTK takes the counts as vtkIdType*
  std::vector<long long> all(static_cast<std::size_t>(layout.Total) + 1);
  this->Controller->AllGatherV(values.data(), all.data(), static_cast<vtkIdType>(values.size()),
    layout.Counts.data(), layout.Offsets.data());
  all.resize(static_cast<std::size_t>(layout.Total));
  return all;
}

std::vector<std::vector<double>> ParallelRun::GatherOnFirstRank(
  const std::vector<double>& values) const
{
  if (!this->Controller)
  {
    return { values };
  }
  const int ranks = this->RanksValue;
  const double length = static_cast<double>(values.size());
  std::vector<double> lengths(ranks);
  this->Controller->Gather(&length, lengths.data(), 1, 0);
  GatherLayout layout(lengths); // not const: VTK takes the counts as vtkIdType*
  std::vector<double> received(static_cast<std::size_t>(layout.Total) + 1);
  this->Controller->GatherV(values.data(), received.data(), static_cast<vtkIdType>(values.size()),
    layout.Counts.data(), layout.Offsets.data(), 0);
  std::vector<std::vector<double>> perRank;
  if (this->RankValue == 0)
  {
    for (int rank = 0; rank < ranks; ++rank)
    {
      const auto first = received.begin() + layout.Offsets[rank];
      perRank.emplace_back(first, first + layout.Counts[rank]);
    }
  }
  return perRank;
}

vtkSmartPointer<vtkPointSet> WithoutGhostCells(vtkPointSet* mesh)
{
  // A point that another piece can have is on the border between this piece's cells and its
  // ghost cells: the neighbour's cells at such a point are this piece's ghost cells there.
  vtkUnsignedCharArray* cellGhosts = mesh->GetCellData()->GetGhostArray();
  vtkNew<vtkUnsignedCharArray> border;
  border->SetName(PieceBorderName);
  border->SetNumberOfValues(mesh->GetNumberOfPoints());
  border->FillValue(0);
  vtkUnstructuredGrid* grid = vtkUnstructuredGrid::SafeDownCast(mesh);
  if (cellGhosts && grid)
  {
    constexpr unsigned char InOwnedCell = 1;
    constexpr unsigned char InGhostCell = 2;
    vtkIdType size = 0;
    const vtkIdType* ids = nullptr;
    auto cells = vtk::TakeSmartPointer(grid->GetCells()->NewIterator());
    for (cells->GoToFirstCell(); !cells->IsDoneWithTraversal(); cells->GoToNextCell())
    {
      cells->GetCurrentCell(size, ids);
      const unsigned char role =
        cellGhosts->GetValue(cells->GetCurrentCellId()) ? InGhostCell : InOwnedCell;
      for (vtkIdType corner = 0; corner < size; ++corner)
      {
        border->SetValue(ids[corner], border->GetValue(ids[corner]) | role);
      }
    }
    for (vtkIdType p = 0; p < border->GetNumberOfValues(); ++p)
    {
      border->SetValue(p, border->GetValue(p) == (InOwnedCell | InGhostCell));
    }
  }
  vtkSmartPointer<vtkPointSet> marked = vtkSmartPointer<vtkPointSet>::Take(mesh->NewInstance());
  marked->ShallowCopy(mesh);
  marked->GetPointData()->AddArray(border);
  if (grid)
  {
    // In place, with the connectivity's 32-bit storage kept: vtkRemoveGhosts's copy raised a
    // rank's peak memory by a quarter (2x atlas, 2 ranks) and slowed the write.
    vtkUnstructuredGrid::SafeDownCast(marked)->RemoveGhostCells();
    marked->GetCellData()->RemoveArray(vtkDataSetAttributes::GhostArrayName()); // all 0 now
    return marked;
  }
  vtkNew<vtkRemoveGhosts> removeGhosts;
  return RunOn(removeGhosts, marked, "removing the ghost cells");
}

vtkSmartPointer<vtkPointSet> GatherOnFirstRank(vtkPointSet* mesh)
{
  vtkSmartPointer<vtkPointSet> piece = vtkSmartPointer<vtkPointSet>::Take(mesh->NewInstance());
  piece->ShallowCopy(mesh);
  piece->GetPointData()->RemoveArray(PieceBorderName);
  // The gathered mesh is whole: the later stages must not take it for a piece.
  piece->GetFieldData()->RemoveArray(stmPieces::PieceMarkerName);
  vtkNew<vtkAggregateDataSetFilter> aggregate;
  aggregate->SetNumberOfTargetProcesses(1);
  aggregate->MergePointsOn();
  vtkSmartPointer<vtkPointSet> gathered = RunOn(aggregate, piece, "gathering the pieces on rank 0");
  // vtkAggregateDataSetFilter gives the whole mesh to the rank that had the most points, which
  // need not be rank 0 (with pieces balanced by cost it was rank 1 of 2, and rank 0 wrote an
  // empty mesh); that rank sends it on.
  vtkMultiProcessController* controller = vtkMultiProcessController::GetGlobalController();
  if (!controller || controller->GetNumberOfProcesses() < 2)
  {
    return gathered;
  }
  const int rank = controller->GetLocalProcessId();
  const int ranks = controller->GetNumberOfProcesses();
  int candidate = gathered->GetNumberOfPoints() > 0 ? rank : ranks;
  int holder = ranks;
  controller->AllReduce(&candidate, &holder, 1, vtkCommunicator::MIN_OP);
  if (holder == 0 || holder == ranks)
  {
    return gathered;
  }
  constexpr int GatheredMeshTag = 4711;
  if (rank == holder)
  {
    controller->Send(gathered, 0, GatheredMeshTag);
    return vtkSmartPointer<vtkPointSet>::Take(gathered->NewInstance());
  }
  if (rank == 0)
  {
    vtkSmartPointer<vtkDataObject> received =
      vtk::TakeSmartPointer(controller->ReceiveDataObject(holder, GatheredMeshTag));
    vtkPointSet* mesh = vtkPointSet::SafeDownCast(received);
    if (!mesh)
    {
      throw Failure(
        "gathering the pieces on rank 0: rank " + std::to_string(holder) + " sent no mesh");
    }
    return mesh;
  }
  return gathered;
}

vtkSmartPointer<vtkPointSet> WithGlobalIds(vtkPointSet* mesh, const ParallelRun& parallel)
{
  // Only the points on a piece's border can be shared. vtkGenerateGlobalIds matches and numbers
  // them between the ranks (run on the whole mesh it takes longer than the meshing); the others
  // are numbered after them, in rank order.
  vtkUnsignedCharArray* border =
    vtkUnsignedCharArray::SafeDownCast(mesh->GetPointData()->GetArray(PieceBorderName));
  vtkNew<vtkIdTypeArray> meshPointOfBoundary;
  vtkNew<vtkPoints> borderPoints;
  borderPoints->SetDataType(mesh->GetPoints() ? mesh->GetPoints()->GetDataType() : VTK_DOUBLE);
  for (vtkIdType p = 0; border && p < border->GetNumberOfValues(); ++p)
  {
    if (border->GetValue(p))
    {
      meshPointOfBoundary->InsertNextValue(p);
      borderPoints->InsertNextPoint(mesh->GetPoint(p));
    }
  }
  vtkNew<vtkPolyData> boundaryPoints;
  boundaryPoints->SetPoints(borderPoints);
  vtkNew<vtkGenerateGlobalIds> match;
  match->SetController(parallel.GetController());
  match->SetTolerance(0.0); // shared points are equal bit for bit
  vtkSmartPointer<vtkPointSet> matched =
    RunOn(match, boundaryPoints, "matching the points the pieces share");
  vtkIdTypeArray* borderPointIds =
    vtkIdTypeArray::SafeDownCast(matched->GetPointData()->GetGlobalIds());
  vtkUnsignedCharArray* boundaryGhosts = matched->GetPointData()->GetGhostArray();
  const vtkIdType numberOfBoundaryPoints = matched->GetNumberOfPoints();
  if (numberOfBoundaryPoints > 0 && (!borderPointIds || !boundaryGhosts))
  {
    throw Failure("matching the points the pieces share: vtkGenerateGlobalIds gave no ids");
  }

  const vtkIdType numberOfPoints = mesh->GetNumberOfPoints();
  vtkNew<vtkUnsignedCharArray> pointGhosts;
  pointGhosts->SetName(vtkDataSetAttributes::GhostArrayName());
  pointGhosts->SetNumberOfValues(numberOfPoints);
  pointGhosts->FillValue(0);
  for (vtkIdType b = 0; b < numberOfBoundaryPoints; ++b)
  {
    if (boundaryGhosts->GetValue(b) & vtkDataSetAttributes::DUPLICATEPOINT)
    {
      pointGhosts->SetValue(meshPointOfBoundary->GetValue(b), vtkDataSetAttributes::DUPLICATEPOINT);
    }
  }
  // vtkGenerateGlobalIds numbered the border points 0 .. (their number - 1) over all ranks, a
  // shared point with its owner's id on every rank that has it; the other points follow, in
  // rank order. So no rank needs the others' ids (an all-gather of them grew with the ranks).
  vtkIdType ownedBorderPoints = 0;
  for (vtkIdType b = 0; b < numberOfBoundaryPoints; ++b)
  {
    ownedBorderPoints += (boundaryGhosts->GetValue(b) & vtkDataSetAttributes::DUPLICATEPOINT) == 0;
  }
  vtkIdType ownedPoints = 0;
  for (vtkIdType p = 0; p < numberOfPoints; ++p)
  {
    ownedPoints += pointGhosts->GetValue(p) == 0;
  }
  const long long numberOfBorderIds = parallel.Sum(ownedBorderPoints);
  const long long pointOffset =
    numberOfBorderIds + parallel.ExclusiveSum(ownedPoints - ownedBorderPoints);
  vtkNew<vtkIdTypeArray> globalPointIds;
  globalPointIds->SetName("GlobalPointIds");
  globalPointIds->SetNumberOfValues(numberOfPoints);
  globalPointIds->FillValue(-1);
  for (vtkIdType b = 0; b < numberOfBoundaryPoints; ++b)
  {
    const vtkIdType id = borderPointIds->GetValue(b);
    if (id < 0 || id >= numberOfBorderIds)
    {
      throw Failure("numbering the points globally: vtkGenerateGlobalIds gave a border point the "
                    "id " +
        std::to_string(id) + ", not one of 0 to " + std::to_string(numberOfBorderIds - 1));
    }
    globalPointIds->SetValue(meshPointOfBoundary->GetValue(b), id);
  }
  vtkIdType next = pointOffset;
  for (vtkIdType p = 0; p < numberOfPoints; ++p)
  {
    if (globalPointIds->GetValue(p) < 0)
    {
      globalPointIds->SetValue(p, next++);
    }
  }

  const vtkIdType numberOfCells = mesh->GetNumberOfCells();
  vtkNew<vtkIntArray> processIds;
  processIds->SetName("ProcessId");
  processIds->SetNumberOfValues(numberOfCells);
  processIds->FillValue(parallel.Rank());

  vtkSmartPointer<vtkPointSet> numbered = vtkSmartPointer<vtkPointSet>::Take(mesh->NewInstance());
  numbered->ShallowCopy(mesh);
  numbered->GetPointData()->RemoveArray(PieceBorderName);
  numbered->GetPointData()->SetGlobalIds(globalPointIds);
  numbered->GetPointData()->AddArray(pointGhosts);
  numbered->GetCellData()->AddArray(processIds);
  return numbered;
}

} // namespace stmesh
