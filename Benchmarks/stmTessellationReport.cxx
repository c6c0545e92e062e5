// SPDX-License-Identifier: BSD-3-Clause
// Writes the tessellation-output report (docs/tessellation-outputs.md): the AAL atlas meshed with
// every variant of stmSpacetreeTessellate (simplicial with the three template rules and both cell
// templates, hybrid, leaves) for balance levels 1 and 2: leaves, points, inserted points,
// elements by type, the share of the volume in hexahedra, the worst tetrahedron and pyramid,
// hanging nodes, the tessellation time, and a volume check of every mesh against the voxels.
//
//   stmTessellationReport [--input aal.nii.gz] [--output docs/tessellation-outputs.md]

#include "stmImageToSpacetree.h"
#include "stmQualityBounds.h"
#include "stmReportTool.h"
#include "stmSpacetreeBalance.h"
#include "stmSpacetreeTessellate.h"

#include "vtkCellData.h"
#include "vtkCellType.h"
#include "vtkDataArray.h"
#include "vtkImageData.h"
#include "vtkMeshQuality.h"
#include "vtkNIFTIImageReader.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkSMPTools.h"
#include "vtkSmartPointer.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace
{
using stmReport::Count;
using stmReport::Fixed;

/// One configuration of stmSpacetreeTessellate.
struct Variant
{
  const char* Name;
  int OutputType;
  int TemplateRule;
  int CellTemplate;
};

const Variant Variants[] = {
  { "Simplicial, midpoint everywhere", stmSpacetreeTessellate::SIMPLICIAL,
    stmSpacetreeTessellate::MIDPOINT_EVERYWHERE, stmSpacetreeTessellate::CHECKERBOARD },
  { "Simplicial, regular faces (default)", stmSpacetreeTessellate::SIMPLICIAL,
    stmSpacetreeTessellate::REGULAR_FACES, stmSpacetreeTessellate::CHECKERBOARD },
  { "Simplicial, extended", stmSpacetreeTessellate::SIMPLICIAL, stmSpacetreeTessellate::EXTENDED,
    stmSpacetreeTessellate::CHECKERBOARD },
  { "Simplicial, regular faces, Kuhn", stmSpacetreeTessellate::SIMPLICIAL,
    stmSpacetreeTessellate::REGULAR_FACES, stmSpacetreeTessellate::KUHN },
  { "Hybrid", stmSpacetreeTessellate::HYBRID, stmSpacetreeTessellate::REGULAR_FACES,
    stmSpacetreeTessellate::CHECKERBOARD },
  { "Leaves", stmSpacetreeTessellate::LEAVES, stmSpacetreeTessellate::REGULAR_FACES,
    stmSpacetreeTessellate::CHECKERBOARD },
};
constexpr int MidpointRow = 0, RegularRow = 1, ExtendedRow = 2, KuhnRow = 3, HybridRow = 4,
              LeavesRow = 5;
constexpr int NumberOfRuns = 3;
const char* const MeasurementBackend = "STDThread";
/// The volume check's tolerance, relative to the voxel volume of the body.
constexpr double VolumeTolerance = 1e-6;

struct Result
{
  vtkIdType Points = 0;
  vtkIdType InsertedPoints = 0;
  vtkIdType Elements = 0;
  vtkIdType Tetrahedra = 0;
  vtkIdType Pyramids = 0;
  vtkIdType Hexahedra = 0;
  double Volume = 0;
  double HexahedronVolume = 0;
  /// Largest Verdict condition number and smallest dihedral angle (degrees) of the tetrahedra.
  double WorstCondition = 0;
  double SmallestAngle = 180;
  /// Smallest Verdict scaled Jacobian of the pyramids.
  double PyramidScaledJacobian = 1;
  vtkIdType HangingNodes = 0;
  /// Median of the tessellation times, in seconds.
  double Seconds = 0;
};

/// Element counts, volumes, and the worst tetrahedron and pyramid of a mesh, all by Verdict
/// through vtkMeshQuality (stmQualityBounds.h). Volumes come from vtkMeshQuality rather than
/// vtkCellSizeFilter, which is sequential: the tetrahedra's take a pass of their own, the
/// pyramids' and hexahedra's ride along with the other measures.
void Measure(vtkUnstructuredGrid* mesh, Result& result)
{
  result.Points = mesh->GetNumberOfPoints();
  result.Elements = mesh->GetNumberOfCells();
  if (result.Elements == 0)
  {
    return;
  }
  auto first = stmTest::VerdictValues(mesh,
    [](vtkMeshQuality* quality)
    {
      quality->SetTetQualityMeasureToCondition();
      quality->SetPyramidQualityMeasureToScaledJacobian();
      quality->SetHexQualityMeasureToVolume();
    });
  bool tetrahedra = false, pyramids = false;
  for (vtkIdType cell = 0; cell < result.Elements && !(tetrahedra && pyramids); ++cell)
  {
    tetrahedra = tetrahedra || mesh->GetCellType(cell) == VTK_TETRA;
    pyramids = pyramids || mesh->GetCellType(cell) == VTK_PYRAMID;
  }
  vtkSmartPointer<vtkDataArray> second, third;
  if (tetrahedra || pyramids)
  {
    second = stmTest::VerdictValues(mesh,
      [](vtkMeshQuality* quality)
      {
        quality->SetTetQualityMeasureToMinAngle();
        quality->SetPyramidQualityMeasureToVolume();
      });
  }
  if (tetrahedra)
  {
    third = stmTest::VerdictValues(
      mesh, [](vtkMeshQuality* quality) { quality->SetTetQualityMeasureToVolume(); });
  }
  for (vtkIdType cell = 0; cell < result.Elements; ++cell)
  {
    switch (mesh->GetCellType(cell))
    {
      case VTK_TETRA:
        ++result.Tetrahedra;
        result.WorstCondition = std::max(result.WorstCondition, first->GetComponent(cell, 0));
        result.SmallestAngle = std::min(result.SmallestAngle, second->GetComponent(cell, 0));
        result.Volume += third->GetComponent(cell, 0);
        break;
      case VTK_PYRAMID:
        ++result.Pyramids;
        result.PyramidScaledJacobian =
          std::min(result.PyramidScaledJacobian, first->GetComponent(cell, 0));
        result.Volume += second->GetComponent(cell, 0);
        break;
      case VTK_HEXAHEDRON:
        ++result.Hexahedra;
        result.HexahedronVolume += first->GetComponent(cell, 0);
        result.Volume += first->GetComponent(cell, 0);
        break;
      default:
        break;
    }
  }
}

/// Runs one variant NumberOfRuns times on the updated spacetree and measures the last output.
Result Tessellate(vtkAlgorithmOutput* tree, const Variant& variant)
{
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetSeparatingFunction(stmSpacetreeTessellate::NO_FUNCTION); // the staircase mesh
  tessellate->SetInputConnection(tree);
  tessellate->SetOutputType(variant.OutputType);
  tessellate->SetTemplateRule(variant.TemplateRule);
  tessellate->SetCellTemplate(variant.CellTemplate);
  std::vector<double> seconds;
  for (int run = 0; run < NumberOfRuns; ++run)
  {
    tessellate->Modified();
    const auto start = std::chrono::steady_clock::now();
    tessellate->Update();
    const auto stop = std::chrono::steady_clock::now();
    seconds.push_back(std::chrono::duration<double>(stop - start).count());
  }
  std::sort(seconds.begin(), seconds.end());
  Result result;
  result.Seconds = seconds[seconds.size() / 2];
  result.InsertedPoints = tessellate->GetNumberOfInsertedPoints();
  vtkUnstructuredGrid* mesh = tessellate->GetOutput();
  // The measurement is deterministic and takes longer than the tessellation: give vtkMeshQuality
  // every core, whatever the default backend the timing reports.
  vtkSMPTools::LocalScope(
    vtkSMPTools::Config{ std::string(MeasurementBackend) }, [&]() { Measure(mesh, result); });
  if (vtkDataArray* hanging = mesh->GetPointData()->GetArray("HangingNode"))
  {
    for (vtkIdType p = 0; p < hanging->GetNumberOfTuples(); ++p)
    {
      result.HangingNodes += hanging->GetComponent(p, 0) == 1 ? 1 : 0;
    }
  }
  return result;
}

std::string Scientific(double value)
{
  std::ostringstream text;
  text << std::scientific << std::setprecision(1) << value;
  return text.str();
}

/// "12.3 % fewer ... than", "4.5 % more ... than" or "as many ... as": how a compares with b,
/// around the noun.
std::string Relative(double a, double b, const std::string& noun)
{
  if (a == b)
  {
    return "as many " + noun + " as";
  }
  const double change = a / b - 1;
  return Fixed(100 * std::abs(change), std::abs(change) < 0.01 ? 2 : 1) + " % " +
    (change < 0 ? "fewer " : "more ") + noun + " than";
}

double Ratio(vtkIdType a, vtkIdType b)
{
  return static_cast<double>(a) / static_cast<double>(b);
}

double RelativeVolumeError(const Result& r, double voxelVolume)
{
  return std::abs(r.Volume - voxelVolume) / voxelVolume;
}
} // namespace

int main(int argc, char* argv[])
{
  const std::string defaultInput = "/usr/share/mricron/templates/aal.nii.gz";
  std::string input = defaultInput;
  std::string output;
  if (!stmReport::ParseArguments(
        argc, argv, "stmTessellationReport [--input aal.nii.gz] [--output FILE]", input, output))
  {
    return 2;
  }
  vtkNew<vtkNIFTIImageReader> reader;
  reader->SetFileName(input.c_str());
  reader->Update();
  vtkImageData* image = reader->GetOutput();
  vtkDataArray* labels = image->GetPointData()->GetScalars();
  if (image->GetNumberOfPoints() == 0 || !labels)
  {
    std::cerr << "stmTessellationReport: cannot read " << input << "\n";
    return 1;
  }
  // The body is every label but the background label 0 (stmImageToSpacetree's defaults), so the
  // mesh must cover exactly the non-zero voxels.
  long long bodyVoxels = 0;
  for (vtkIdType v = 0; v < labels->GetNumberOfTuples(); ++v)
  {
    bodyVoxels += labels->GetComponent(v, 0) != 0 ? 1 : 0;
  }
  const double* spacing = image->GetSpacing();
  const double voxelVolume = static_cast<double>(bodyVoxels) * spacing[0] * spacing[1] * spacing[2];

  const std::vector<int> balanceLevels = { 1, 2 };
  constexpr int NumberOfVariants = static_cast<int>(sizeof(Variants) / sizeof(Variants[0]));
  std::vector<std::vector<Result>> results;
  for (int level : balanceLevels)
  {
    vtkNew<stmImageToSpacetree> tree;
    tree->SetInputConnection(reader->GetOutputPort());
    vtkNew<stmSpacetreeBalance> balance;
    balance->SetInputConnection(tree->GetOutputPort());
    balance->SetBalanceLevel(level);
    balance->Update();
    results.emplace_back();
    for (const Variant& variant : Variants)
    {
      results.back().push_back(Tessellate(balance->GetOutputPort(), variant));
      std::cerr << "." << std::flush;
    }
  }
  std::cerr << "\n";

  bool allValid = true;
  std::ostringstream report;
  report << "# Tessellation outputs on the AAL atlas\n\n"
         << "Generated by `stmTessellationReport "
         << (input == defaultInput ? std::string() : "--input " + input + " ")
         << "--output docs/tessellation-outputs.md` (Benchmarks/stmTessellationReport.cxx; the "
            "program is built in `build/bin`); do not edit by hand. The times depend on the "
            "machine and its load; every other figure is deterministic.\n\n"
         << "The AAL atlas (" << image->GetDimensions()[0] << " x " << image->GetDimensions()[1]
         << " x " << image->GetDimensions()[2] << " voxels of " << spacing[0] << " x " << spacing[1]
         << " x " << spacing[2] << " mm; " << Count(bodyVoxels)
         << " voxels of the body, every label but 0), read by `vtkNIFTIImageReader`, turned into "
            "a spacetree by `stmImageToSpacetree` with its defaults, balanced by "
            "`stmSpacetreeBalance` with `BalanceLevel` L, and meshed by "
            "`stmSpacetreeTessellate` in every variant: `OutputType` SIMPLICIAL with "
            "`TemplateRule` MIDPOINT_EVERYWHERE, REGULAR_FACES (the default) and EXTENDED (all "
            "with `CellTemplate` CHECKERBOARD), SIMPLICIAL with REGULAR_FACES and KUHN, HYBRID, "
            "and LEAVES.\n\n"
         << "Machine: " << std::thread::hardware_concurrency()
         << " cores (`std::thread::hardware_concurrency`); vtkSMPTools left at its default, "
            "backend "
         << vtkSMPTools::GetBackend() << " with " << vtkSMPTools::GetEstimatedNumberOfThreads()
         << " thread(s) (`VTK_SMP_BACKEND_IN_USE` chooses another backend). Times are medians "
            "of "
         << NumberOfRuns << " runs on a shared, noisy virtual machine, and only indicative.\n\n"
         << "## Columns\n\n"
         << "Leaves: leaves of the body (the cells of the LEAVES output), the same for every "
            "row of a balance level. Inserted points: `GetNumberOfInsertedPoints()`, the points "
            "the tessellation added to the leaf corners (face and cell centres). Elements: "
            "cells of the output, and by type. Hexahedra volume: the share of the mesh volume "
            "in hexahedra. Worst condition and smallest angle: the "
            "largest Verdict condition number (1 is the regular tetrahedron) and the smallest "
            "dihedral angle in degrees over the tetrahedra; pyramid scaled Jacobian: the "
            "smallest Verdict scaled Jacobian over the pyramids; these and the volumes by "
            "`vtkMeshQuality` (run with "
            "the "
         << MeasurementBackend
         << " backend, which does not change its values). "
            "Hanging nodes: points of the LEAVES output with `HangingNode` = 1. Time: "
            "`stmSpacetreeTessellate` alone, in seconds, with its input already updated. "
            "Volume: the total volume of the mesh against the volume of the body's voxels; "
            "\"ok\" when they agree to a relative "
         << Scientific(VolumeTolerance) << " (the relative difference in brackets).\n\n";

  for (std::size_t l = 0; l < balanceLevels.size(); ++l)
  {
    const std::vector<Result>& rows = results[l];
    const vtkIdType leaves = rows[LeavesRow].Elements;
    report << "## L = " << balanceLevels[l] << "\n\n"
           << "| variant | leaves | points | inserted points | elements | tetrahedra | "
              "pyramids | hexahedra | hexahedra volume | worst condition | smallest angle | "
              "pyramid scaled Jacobian | hanging nodes | time (s) | volume |\n"
           << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
    for (int v = 0; v < NumberOfVariants; ++v)
    {
      const Result& r = rows[static_cast<std::size_t>(v)];
      const bool tetrahedra = r.Tetrahedra > 0;
      const double error = RelativeVolumeError(r, voxelVolume);
      const bool valid = error <= VolumeTolerance;
      allValid = allValid && valid;
      report << "| " << Variants[v].Name << " | " << Count(leaves) << " | " << Count(r.Points)
             << " | " << Count(r.InsertedPoints) << " | " << Count(r.Elements) << " | "
             << Count(r.Tetrahedra) << " | " << Count(r.Pyramids) << " | " << Count(r.Hexahedra)
             << " | " << Fixed(100 * r.HexahedronVolume / r.Volume, 1) << " % | "
             << (tetrahedra ? Fixed(r.WorstCondition, 3) : "-") << " | "
             << (tetrahedra ? Fixed(r.SmallestAngle, 2) : "-") << " | "
             << (r.Pyramids > 0 ? Fixed(r.PyramidScaledJacobian, 3) : "-") << " | "
             << (v == LeavesRow ? Count(r.HangingNodes) : "-") << " | " << Fixed(r.Seconds, 2)
             << " | " << (valid ? "ok" : "FAILED") << " (" << Scientific(error) << ") |\n";
    }
    report << "\n";
  }

  // The reading is computed from the figures, so a regenerated report cannot contradict its
  // own tables.
  report << "## Savings\n\n";
  for (std::size_t l = 0; l < balanceLevels.size(); ++l)
  {
    const std::vector<Result>& rows = results[l];
    const Result& midpoint = rows[MidpointRow];
    const Result& regular = rows[RegularRow];
    const Result& extended = rows[ExtendedRow];
    const Result& kuhn = rows[KuhnRow];
    const Result& hybrid = rows[HybridRow];
    const bool extendedWorse = extended.WorstCondition > regular.WorstCondition ||
      extended.SmallestAngle < regular.SmallestAngle;
    report << "At L = " << balanceLevels[l] << ", extended templates insert "
           << Relative(static_cast<double>(extended.InsertedPoints),
                static_cast<double>(regular.InsertedPoints), "points")
           << " regular-face templates (" << Count(extended.InsertedPoints) << " against "
           << Count(regular.InsertedPoints) << ") and make "
           << Relative(static_cast<double>(extended.Elements),
                static_cast<double>(regular.Elements), "elements")
           << " them, " << (extendedWorse ? "at the price of a worse" : "with an equal or better")
           << " worst tetrahedron (condition " << Fixed(extended.WorstCondition, 3) << " against "
           << Fixed(regular.WorstCondition, 3) << ", smallest angle "
           << Fixed(extended.SmallestAngle, 2) << "° against " << Fixed(regular.SmallestAngle, 2)
           << "°) and a median time of " << Fixed(extended.Seconds, 2) << " s against "
           << Fixed(regular.Seconds, 2) << " s. Regular-face templates insert "
           << Relative(static_cast<double>(regular.InsertedPoints),
                static_cast<double>(midpoint.InsertedPoints), "points")
           << " the midpoint rule everywhere and make "
           << Relative(static_cast<double>(regular.Elements),
                static_cast<double>(midpoint.Elements), "elements")
           << " it. Kuhn templates make "
           << Relative(static_cast<double>(kuhn.Elements), static_cast<double>(regular.Elements),
                "elements")
           << " checkerboard templates. The hybrid mesh has "
           << Relative(static_cast<double>(hybrid.Elements), static_cast<double>(regular.Elements),
                "elements")
           << " the default simplicial mesh and "
           << Relative(
                static_cast<double>(hybrid.Points), static_cast<double>(regular.Points), "points")
           << " it, with " << Fixed(100 * hybrid.HexahedronVolume / hybrid.Volume, 1)
           << " % of its volume in hexahedra; the leaves have "
           << Fixed(100 * Ratio(rows[LeavesRow].HangingNodes, rows[LeavesRow].Points), 1)
           << " % of their points hanging.\n\n";
  }
  report << "## Validity\n\n"
         << (allValid ? "Every mesh above, the leaves included, "
                      : "NOT every mesh above (see the FAILED rows) ")
         << "covers exactly the volume of the body's voxels (" << Count(bodyVoxels) << " x "
         << spacing[0] * spacing[1] * spacing[2]
         << " mm³). This cheap check catches missing or overlapping elements in bulk; "
            "conformity and orientation are tested in Testing/Cxx/Filters.\n";

  return stmReport::WriteReport(report.str(), output) && allValid ? 0 : 1;
}
