// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmeshParallel_h
#define stmeshParallel_h

// stmesh under MPI (issue 11): `mpiexec -n P stmesh image.nii.gz -o mesh.pvtu`. Every rank reads
// its extent of the image (stmesh::OpenImage: the reader stays in the pipeline), meshes the root
// cells of its piece (stmImageToSpacetree::SplitIntoPieces, with two root cells of ghosts, of which
// the cut keeps one ring of cells), drops its ghost cells and then either writes its piece of a
// .pvtu (global point ids, point ghosts, a ProcessId array; vtkGenerateGlobalIds and
// vtkXMLPUnstructuredGridWriter) or sends it to rank 0, which merges the shared points and writes
// one file (vtkAggregateDataSetFilter). VTK's own parallel filters do the exchanges.

#include "vtkSmartPointer.h"

#include <string>
#include <vector>

class vtkMultiProcessController;
class vtkPointSet;

namespace stmesh
{

/// The process's rank and the number of ranks as an MPI launcher announces them in the
/// environment (Open MPI, MPICH/Hydra, PMIx): known before MPI is started, so that only one rank
/// prints a command-line mistake. Ranks() is 0 when no launcher started the process.
struct LaunchEnvironment
{
  int Rank = 0;
  int Ranks = 0;
  int RanksOnThisNode = 0;
};
LaunchEnvironment ReadLaunchEnvironment();

/// MPI for one run of stmesh: started by Start (vtkMPIController, made VTK's global controller),
/// finished when the object goes away. Without Start, a single rank without MPI.
class ParallelRun
{
public:
  ParallelRun() = default;
  ~ParallelRun();

  void Start(int* argc, char*** argv);
  int Rank() const { return this->RankValue; }
  int Ranks() const { return this->RanksValue; }
  vtkMultiProcessController* GetController() const;

  /// Ends every rank at once after a failure on one of them, which the others may be waiting
  /// for in an exchange (MPI_Abort).
  [[noreturn]] void Abort(int status);

  /// The sum over all ranks (every rank gets it).
  long long Sum(long long value) const;
  /// The sum of value over the ranks before this one.
  long long ExclusiveSum(long long value) const;
  /// Every rank's values, rank by rank, on every rank.
  std::vector<long long> AllGather(const std::vector<long long>& values) const;
  /// Every rank's values on rank 0, rank by rank (empty on the other ranks).
  std::vector<std::vector<double>> GatherOnFirstRank(const std::vector<double>& values) const;

private:
  vtkSmartPointer<vtkMultiProcessController> Controller;
  int RankValue = 0;
  int RanksValue = 1;

  ParallelRun(const ParallelRun&) = delete;
  void operator=(const ParallelRun&) = delete;
};

/// The mesh without the cells marked as ghosts (vtkRemoveGhosts), with a point array that
/// tells WithGlobalIds which points other pieces may share.
vtkSmartPointer<vtkPointSet> WithoutGhostCells(vtkPointSet* mesh);

/// Rank 0 gets the pieces of all ranks as one mesh, their shared points merged; the other ranks
/// get an empty mesh (vtkAggregateDataSetFilter).
vtkSmartPointer<vtkPointSet> GatherOnFirstRank(vtkPointSet* mesh);

/// The piece with "GlobalPointIds" (0 to the number of points of all pieces together, minus 1),
/// point ghosts (vtkGhostType: a point shared by pieces belongs to the lowest rank that has it)
/// and the cell array "ProcessId". The pieces come from WithoutGhostCells (a single piece may
/// come straight from the meshing).
vtkSmartPointer<vtkPointSet> WithGlobalIds(vtkPointSet* mesh, const ParallelRun& parallel);

} // namespace stmesh

#endif
