// SPDX-License-Identifier: BSD-3-Clause
// Timings of the stages on the AAL atlas (181 x 217 x 181 voxels, 116 labels), each stage alone
// on the output of the previous one, the first three together, and the .vtu write. The snap,
// the cut of every label and the smoothing take their inputs from stmesh's default pipelines
// (the brain mask, and --materials separate). Run with
//   BenchmarkSpacetreeMesh --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// The SMP backend is STDThread; VTK_SMP_MAX_THREADS or --threads=N (first argument) limit it.

#include "stmBoundarySmooth.h"
#include "stmImageToSpacetree.h"
#include "stmMarchingSimplices.h"
#include "stmMultiMaterialCut.h"
#include "stmSpacetreeBalance.h"
#include "stmSpacetreeTessellate.h"
#include "stmVertexSnap.h"
#include "stmXMLUnstructuredGridWriter.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkImageData.h"
#include "vtkNIFTIImageReader.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkSMPTools.h"
#include "vtkSmartPointer.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"
#include "vtkXMLUnstructuredGridWriter.h"

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <cstring>
#include <string>

namespace
{
std::string AalPath = "/usr/share/mricron/templates/aal.nii.gz";

vtkImageData* Atlas()
{
  static vtkSmartPointer<vtkNIFTIImageReader> reader;
  if (!reader)
  {
    reader = vtkSmartPointer<vtkNIFTIImageReader>::New();
    reader->SetFileName(AalPath.c_str());
    reader->Update();
  }
  return reader->GetOutput();
}

/// The spacetree of the atlas; by default the staircase tree of the earlier figures
/// (docs/performance.md), without the cut's refinement of thin parts.
vtkSmartPointer<vtkUnstructuredGrid> Spacetree(
  int balanceLevel, int thinParts = stmImageToSpacetree::NO_THIN_PARTS)
{
  vtkNew<stmImageToSpacetree> tree;
  tree->SetInputData(Atlas());
  tree->SetThinPartRefinement(thinParts);
  tree->Update();
  auto result = vtkSmartPointer<vtkUnstructuredGrid>::New();
  if (balanceLevel == 0)
  {
    result->ShallowCopy(tree->GetOutput());
    return result;
  }
  vtkNew<stmSpacetreeBalance> balance;
  balance->SetBalanceLevel(balanceLevel);
  balance->SetInputConnection(tree->GetOutputPort());
  balance->Update();
  result->ShallowCopy(balance->GetOutput());
  return result;
}

// The argument is the thin-part refinement: none (0), of the body (1) or of every material (2),
// whose voxel tests (Filters/Core/Spacetree/ThinParts.h) read every voxel of the image.
void BM_ImageToSpacetree(benchmark::State& state)
{
  vtkImageData* image = Atlas();
  vtkIdType leaves = 0;
  for (auto _ : state)
  {
    vtkNew<stmImageToSpacetree> tree;
    tree->SetInputData(image);
    tree->SetThinPartRefinement(static_cast<int>(state.range(0)));
    tree->Update();
    leaves = tree->GetOutput()->GetNumberOfCells();
  }
  state.counters["leaves"] = static_cast<double>(leaves);
  state.counters["voxels/s"] = benchmark::Counter(
    static_cast<double>(image->GetNumberOfPoints()), benchmark::Counter::kIsIterationInvariantRate);
}

void BM_SpacetreeBalance(benchmark::State& state)
{
  auto input = Spacetree(0);
  vtkIdType leaves = 0;
  for (auto _ : state)
  {
    vtkNew<stmSpacetreeBalance> balance;
    balance->SetBalanceLevel(static_cast<int>(state.range(0)));
    balance->SetInputData(input);
    balance->Update();
    leaves = balance->GetOutput()->GetNumberOfCells();
  }
  state.counters["leaves"] = static_cast<double>(leaves);
}

void BM_SpacetreeTessellate(benchmark::State& state)
{
  auto input = Spacetree(static_cast<int>(state.range(0)));
  vtkIdType cells = 0;
  for (auto _ : state)
  {
    vtkNew<stmSpacetreeTessellate> tessellate;
    tessellate->SetSeparatingFunction(stmSpacetreeTessellate::NO_FUNCTION); // the staircase mesh
    tessellate->SetInputData(input);
    tessellate->Update();
    cells = tessellate->GetOutput()->GetNumberOfCells();
  }
  state.counters["tetrahedra"] = static_cast<double>(cells);
  state.counters["tetrahedra/s"] =
    benchmark::Counter(static_cast<double>(cells), benchmark::Counter::kIsIterationInvariantRate);
}

void BM_AllThreeStages(benchmark::State& state)
{
  vtkImageData* image = Atlas();
  vtkIdType cells = 0;
  for (auto _ : state)
  {
    vtkNew<stmImageToSpacetree> tree;
    vtkNew<stmSpacetreeBalance> balance;
    vtkNew<stmSpacetreeTessellate> tessellate;
    tessellate->SetSeparatingFunction(stmSpacetreeTessellate::NO_FUNCTION); // the staircase mesh
    tree->SetThinPartRefinement(stmImageToSpacetree::NO_THIN_PARTS);
    tree->SetInputData(image);
    balance->SetInputConnection(tree->GetOutputPort());
    tessellate->SetInputConnection(balance->GetOutputPort());
    tessellate->Update();
    cells = tessellate->GetOutput()->GetNumberOfCells();
  }
  state.counters["tetrahedra"] = static_cast<double>(cells);
  state.counters["tetrahedra/s"] =
    benchmark::Counter(static_cast<double>(cells), benchmark::Counter::kIsIterationInvariantRate);
}

/// The counters of a stage timed on mesh: its cells under `name`, and the cells per second.
void CountCells(benchmark::State& state, const char* name, vtkDataSet* mesh)
{
  const auto cells = static_cast<double>(mesh->GetNumberOfCells());
  state.counters[name] = cells;
  state.counters["tetrahedra/s"] =
    benchmark::Counter(cells, benchmark::Counter::kIsIterationInvariantRate);
}

/// Marching simplices on the default mesh of the atlas (balance 1, the labels function with its
/// boundary layer): input tetrahedra per second, volume (0) or surface (1) output.
void BM_MarchingSimplices(benchmark::State& state)
{
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetInputData(Spacetree(1));
  tessellate->Update();
  vtkUnstructuredGrid* mesh = tessellate->GetOutput();
  vtkIdType cells = 0;
  for (auto _ : state)
  {
    vtkNew<stmMarchingSimplices> cut;
    cut->SetOutputMode(static_cast<int>(state.range(0)));
    cut->SetInputData(mesh);
    cut->Update();
    cells = vtkDataSet::SafeDownCast(cut->GetOutputDataObject(0))->GetNumberOfCells();
  }
  CountCells(state, "input tetrahedra", mesh);
  state.counters["output cells"] = static_cast<double>(cells);
}

/// Marks every array of the mesh modified, so that a writer computes the ranges and the distinct
/// cell types again instead of finding them cached from the previous iteration.
void ForgetCachedRanges(vtkUnstructuredGrid* mesh)
{
  for (vtkDataSetAttributes* data : { static_cast<vtkDataSetAttributes*>(mesh->GetPointData()),
         static_cast<vtkDataSetAttributes*>(mesh->GetCellData()) })
  {
    for (int array = 0; array < data->GetNumberOfArrays(); ++array)
    {
      data->GetAbstractArray(array)->Modified();
    }
  }
  mesh->GetPoints()->GetData()->Modified();
  mesh->GetCells()->GetConnectivityArray()->Modified();
  mesh->GetCells()->GetOffsetsArray()->Modified();
  mesh->GetCellTypesArray()->Modified();
}

/// Writing the cut mesh of the atlas (the same as BM_MarchingSimplices's volume output) to a
/// string as stmesh writes its .vtu: inline binary, LZ4, blocks of 1 MiB, 64-bit headers; with
/// VTK's writer (0) or stmXMLUnstructuredGridWriter (1), which write the same bytes.
void BM_XMLWrite(benchmark::State& state)
{
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetInputData(Spacetree(1));
  vtkNew<stmMarchingSimplices> cut;
  cut->SetInputConnection(tessellate->GetOutputPort());
  cut->Update();
  vtkUnstructuredGrid* mesh = vtkUnstructuredGrid::SafeDownCast(cut->GetOutputDataObject(0));
  vtkSmartPointer<vtkXMLUnstructuredGridWriter> writer;
  if (state.range(0) == 0)
  {
    writer = vtkSmartPointer<vtkXMLUnstructuredGridWriter>::New();
  }
  else
  {
    writer = vtkSmartPointer<stmXMLUnstructuredGridWriter>::New();
  }
  writer->SetInputData(mesh);
  writer->SetWriteToOutputString(true);
  writer->SetDataModeToBinary();
  writer->SetCompressorTypeToLZ4();
  writer->SetBlockSize(1 << 20);
  writer->SetHeaderTypeToUInt64();
  size_t bytes = 0;
  for (auto _ : state)
  {
    ForgetCachedRanges(mesh);
    writer->Write();
    bytes = writer->GetOutputString().size();
  }
  CountCells(state, "tetrahedra", mesh);
  state.counters["bytes"] = static_cast<double>(bytes);
}

/// The tessellation of stmesh's default pipeline: the brain mask's (0: thin parts of the body
/// refined) or every label's (1: thin parts of every material, as --materials separate).
vtkSmartPointer<vtkUnstructuredGrid> DefaultTessellation(bool everyLabel)
{
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetInputData(Spacetree(1,
    everyLabel ? stmImageToSpacetree::THIN_MATERIAL_PARTS : stmImageToSpacetree::THIN_BODY_PARTS));
  tessellate->Update();
  auto result = vtkSmartPointer<vtkUnstructuredGrid>::New();
  result->ShallowCopy(tessellate->GetOutput());
  return result;
}

/// The mesh the smoothing gets in stmesh's default pipeline: the brain mask's snapped and cut
/// mesh (0), or the cut of every label (1).
vtkSmartPointer<vtkUnstructuredGrid> SmoothingInput(bool everyLabel)
{
  auto result = vtkSmartPointer<vtkUnstructuredGrid>::New();
  if (everyLabel)
  {
    vtkNew<stmMultiMaterialCut> cut;
    cut->SetBackgroundMaterial(0);
    cut->SetInputData(DefaultTessellation(true));
    cut->Update();
    result->ShallowCopy(cut->GetOutputDataObject(0));
    return result;
  }
  vtkNew<stmVertexSnap> snap;
  snap->SetInputData(DefaultTessellation(false));
  vtkNew<stmMarchingSimplices> cut;
  cut->SetInputConnection(snap->GetOutputPort());
  cut->Update();
  result->ShallowCopy(cut->GetOutputDataObject(0));
  return result;
}

/// Quality-driven snapping (stmesh's default) of the brain mask's tessellation: input tetrahedra
/// per second.
void BM_VertexSnap(benchmark::State& state)
{
  auto mesh = DefaultTessellation(false);
  vtkIdType snapped = 0;
  for (auto _ : state)
  {
    vtkNew<stmVertexSnap> snap;
    snap->SetInputData(mesh);
    snap->Update();
    snapped = snap->GetNumberOfSnappedPoints();
  }
  CountCells(state, "input tetrahedra", mesh);
  state.counters["snapped points"] = static_cast<double>(snapped);
}

/// The cut at the interfaces of all 116 labels, snapping before each (stmesh --materials
/// separate): input tetrahedra per second.
void BM_MultiMaterialCut(benchmark::State& state)
{
  auto mesh = DefaultTessellation(true);
  vtkIdType cells = 0;
  for (auto _ : state)
  {
    vtkNew<stmMultiMaterialCut> cut;
    cut->SetBackgroundMaterial(0);
    cut->SetInputData(mesh);
    cut->Update();
    cells = vtkDataSet::SafeDownCast(cut->GetOutputDataObject(0))->GetNumberOfCells();
  }
  CountCells(state, "input tetrahedra", mesh);
  state.counters["output cells"] = static_cast<double>(cells);
}

/// stmesh's smoothing (20 Taubin iterations) of the brain mask's cut mesh (0) or of the 116
/// labels' (1, with the labels' volumes restored): tetrahedra per second.
void BM_BoundarySmooth(benchmark::State& state)
{
  const bool everyLabel = state.range(0) != 0;
  auto mesh = SmoothingInput(everyLabel);
  vtkIdType moved = 0;
  for (auto _ : state)
  {
    vtkNew<stmBoundarySmooth> smooth;
    smooth->SetBackgroundMaterial(0);
    smooth->SetRestoreOriginalVolumes(everyLabel);
    smooth->SetInputData(mesh);
    smooth->Update();
    moved = smooth->GetNumberOfMovedPoints();
  }
  CountCells(state, "tetrahedra", mesh);
  state.counters["moved points"] = static_cast<double>(moved);
}

BENCHMARK(BM_ImageToSpacetree)
  ->Arg(stmImageToSpacetree::NO_THIN_PARTS)
  ->Arg(stmImageToSpacetree::THIN_BODY_PARTS)
  ->Arg(stmImageToSpacetree::THIN_MATERIAL_PARTS)
  ->Unit(benchmark::kMillisecond)
  ->UseRealTime();
BENCHMARK(BM_SpacetreeBalance)
  ->Arg(1)
  ->Arg(2)
  ->Arg(3)
  ->Unit(benchmark::kMillisecond)
  ->UseRealTime();
BENCHMARK(BM_SpacetreeTessellate)
  ->Arg(1)
  ->Arg(2)
  ->Arg(3)
  ->Unit(benchmark::kMillisecond)
  ->UseRealTime();
BENCHMARK(BM_AllThreeStages)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MarchingSimplices)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_XMLWrite)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_VertexSnap)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MultiMaterialCut)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_BoundarySmooth)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
} // namespace

int main(int argc, char** argv)
{
  const char* backend = std::getenv("VTK_SMP_BACKEND_IN_USE");
  vtkSMPTools::SetBackend(backend ? backend : "STDThread");
  int threads = 0;
  for (int i = 1; i < argc; ++i)
  {
    if (std::strncmp(argv[i], "--threads=", 10) == 0)
    {
      threads = std::atoi(argv[i] + 10);
    }
    else if (std::strncmp(argv[i], "--input=", 8) == 0)
    {
      AalPath = argv[i] + 8;
    }
  }
  vtkSMPTools::Initialize(threads);
  benchmark::Initialize(&argc, argv);
  benchmark::AddCustomContext("smp_backend", vtkSMPTools::GetBackend());
  benchmark::AddCustomContext(
    "smp_threads", std::to_string(vtkSMPTools::GetEstimatedNumberOfThreads()));
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
