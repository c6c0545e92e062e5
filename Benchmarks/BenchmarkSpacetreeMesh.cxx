// SPDX-License-Identifier: BSD-3-Clause
// Timings of the stages on the AAL atlas (181 x 217 x 181 voxels, 116 labels), each stage alone
// on the output of the previous one, the first three together, and the .vtu write. Run with
//   BenchmarkSpacetreeMesh --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// The SMP backend is STDThread; VTK_SMP_MAX_THREADS or --threads=N (first argument) limit it.

#include "stmImageToSpacetree.h"
#include "stmMarchingSimplices.h"
#include "stmSpacetreeBalance.h"
#include "stmSpacetreeTessellate.h"
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

vtkSmartPointer<vtkUnstructuredGrid> Spacetree(int balanceLevel)
{
  vtkNew<stmImageToSpacetree> tree;
  tree->SetInputData(Atlas());
  // The staircase tree of the earlier figures (docs/performance.md), not the cut's refinement.
  tree->SetThinPartRefinement(stmImageToSpacetree::NO_THIN_PARTS);
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
  state.counters["input tetrahedra"] = static_cast<double>(mesh->GetNumberOfCells());
  state.counters["output cells"] = static_cast<double>(cells);
  state.counters["tetrahedra/s"] = benchmark::Counter(
    static_cast<double>(mesh->GetNumberOfCells()), benchmark::Counter::kIsIterationInvariantRate);
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
  state.counters["tetrahedra"] = static_cast<double>(mesh->GetNumberOfCells());
  state.counters["bytes"] = static_cast<double>(bytes);
  state.counters["tetrahedra/s"] = benchmark::Counter(
    static_cast<double>(mesh->GetNumberOfCells()), benchmark::Counter::kIsIterationInvariantRate);
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
