// SPDX-License-Identifier: BSD-3-Clause
// Writes the refinement-pattern report (docs/refinement-patterns.md): the AAL atlas resampled to
// 1 x 1 x 2 mm voxels (every second axial slice) meshed with the automatic refinement pattern and
// with isotropic 2x2x2 refinement, for balance levels 1, 2, 3 and both templates: body leaves,
// tetrahedra, points, worst Verdict condition number, smallest dihedral angle and tessellation
// time; the level table the automatic pattern chose; where the tetrahedra come from (regular and
// irregular leaves per level); and the isotropic atlas with 3x3x3 against 2x2x2 refinement.
//
//   stmPatternComparison [--input aal.nii.gz] [--output docs/refinement-patterns.md]

#include "stmImageToSpacetree.h"
#include "stmReportTool.h"
#include "stmSpacetreeBalance.h"
#include "stmSpacetreeTessellate.h"
#include "stmVerdictQuality.h"

#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkExtractVOI.h"
#include "vtkFieldData.h"
#include "vtkIdList.h"
#include "vtkImageData.h"
#include "vtkMatrix3x3.h"
#include "vtkNIFTIImageReader.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkSMPTools.h"
#include "vtkSmartPointer.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

namespace
{
using stmReport::Count;
using stmReport::Fixed;

const char* const TemplateNames[2] = { "Checkerboard", "Kuhn" };

/// Per level of the spacetree (0 = root): body leaves, how many of them took their template
/// (regular) and the tetrahedra they were cut into.
struct LevelCount
{
  long long Leaves = 0;
  long long Regular = 0;
  long long Tetrahedra = 0;
};

struct Result
{
  long long BodyLeaves = 0;
  vtkIdType Tetrahedra = 0;
  vtkIdType Points = 0;
  double WorstCondition = 0;
  double SmallestAngle = 180;
  double Seconds = 0;
  std::vector<LevelCount> Levels;
};

/// Cell edges per level and spacetree axis, in lattice units, root first.
using LevelTable = std::vector<std::array<int, 3>>;

LevelTable ReadLevelTable(vtkUnstructuredGrid* tree)
{
  vtkFieldData* fd = tree->GetFieldData();
  const int dim = static_cast<int>(fd->GetArray("SpacetreeDimension")->GetComponent(0, 0));
  vtkDataArray* sizes = fd->GetArray("SpacetreeCellSizes");
  LevelTable table(static_cast<std::size_t>(sizes->GetNumberOfTuples() / dim), { 1, 1, 1 });
  for (std::size_t l = 0; l < table.size(); ++l)
  {
    for (int a = 0; a < dim; ++a)
    {
      table[l][a] = static_cast<int>(sizes->GetComponent(static_cast<vtkIdType>(l) * dim + a, 0));
    }
  }
  return table;
}

int BackgroundLabel(vtkUnstructuredGrid* tree)
{
  return static_cast<int>(
    tree->GetFieldData()->GetArray("SpacetreeBackgroundLabel")->GetComponent(0, 0));
}

/// Assigns every tetrahedron to the leaf that contains its centroid (a leaf is cut into
/// tetrahedra inside it), by rasterising the leaves on the lattice. A body leaf cut into exactly
/// as many tetrahedra as its template gives (5 or 6) is regular; the others had a finer
/// neighbour and went through the recursive midpoint rule.
std::vector<LevelCount> CountPerLevel(
  vtkUnstructuredGrid* tree, vtkUnstructuredGrid* mesh, int templateTetrahedra)
{
  vtkFieldData* fd = tree->GetFieldData();
  const LevelTable table = ReadLevelTable(tree);
  int extent[3];
  for (int a = 0; a < 3; ++a)
  {
    extent[a] = static_cast<int>(fd->GetArray("SpacetreeRootGridDimensions")->GetComponent(a, 0)) *
      table[0][a];
  }
  vtkDataArray* levels = tree->GetCellData()->GetArray("Level");
  vtkDataArray* indices = tree->GetCellData()->GetArray("LatticeIndex");
  vtkDataArray* materials = tree->GetCellData()->GetArray("Material");
  const int background = BackgroundLabel(tree);
  std::vector<int> leafOf(static_cast<std::size_t>(extent[0]) * extent[1] * extent[2], -1);
  for (vtkIdType c = 0; c < tree->GetNumberOfCells(); ++c)
  {
    const int l = static_cast<int>(levels->GetComponent(c, 0));
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a)
    {
      lo[a] = static_cast<int>(indices->GetComponent(c, a)) * table[l][a];
      hi[a] = lo[a] + table[l][a];
    }
    for (int k = lo[2]; k < hi[2]; ++k)
      for (int j = lo[1]; j < hi[1]; ++j)
        for (int i = lo[0]; i < hi[0]; ++i)
        {
          leafOf[(static_cast<std::size_t>(k) * extent[1] + j) * extent[0] + i] =
            static_cast<int>(c);
        }
  }
  // Physical to lattice coordinates: x = origin + sum_a lattice[a] * axis[a].
  double origin[3];
  vtkNew<vtkMatrix3x3> toLattice;
  for (int r = 0; r < 3; ++r)
  {
    origin[r] = fd->GetArray("SpacetreeLatticeOrigin")->GetComponent(r, 0);
    for (int a = 0; a < 3; ++a)
    {
      toLattice->SetElement(r, a, fd->GetArray("SpacetreeLatticeAxes")->GetComponent(3 * a + r, 0));
    }
  }
  toLattice->Invert();
  std::vector<int> tetrahedraPerLeaf(static_cast<std::size_t>(tree->GetNumberOfCells()), 0);
  vtkNew<vtkIdList> ids;
  for (vtkIdType c = 0; c < mesh->GetNumberOfCells(); ++c)
  {
    mesh->GetCellPoints(c, ids);
    double centroid[3] = { 0, 0, 0 };
    for (vtkIdType v = 0; v < ids->GetNumberOfIds(); ++v)
    {
      double x[3];
      mesh->GetPoint(ids->GetId(v), x);
      for (int r = 0; r < 3; ++r)
      {
        centroid[r] += (x[r] - origin[r]) / static_cast<double>(ids->GetNumberOfIds());
      }
    }
    double lattice[3];
    toLattice->MultiplyPoint(centroid, lattice);
    const std::size_t voxel = (static_cast<std::size_t>(std::floor(lattice[2])) * extent[1] +
                                static_cast<std::size_t>(std::floor(lattice[1]))) *
        extent[0] +
      static_cast<std::size_t>(std::floor(lattice[0]));
    ++tetrahedraPerLeaf[static_cast<std::size_t>(leafOf.at(voxel))];
  }
  std::vector<LevelCount> perLevel(table.size());
  for (vtkIdType c = 0; c < tree->GetNumberOfCells(); ++c)
  {
    if (static_cast<int>(materials->GetComponent(c, 0)) == background)
    {
      continue;
    }
    LevelCount& count = perLevel[static_cast<std::size_t>(levels->GetComponent(c, 0))];
    ++count.Leaves;
    count.Regular += tetrahedraPerLeaf[c] == templateTetrahedra ? 1 : 0;
    count.Tetrahedra += tetrahedraPerLeaf[c];
  }
  return perLevel;
}

struct Spacetree
{
  vtkNew<stmImageToSpacetree> Tree;
  vtkNew<stmSpacetreeBalance> Balance;

  Spacetree(vtkImageData* image, const std::string& pattern, int balanceLevel)
  {
    this->Tree->SetInputData(image);
    this->Tree->SetRefinementPattern(pattern.c_str());
    this->Balance->SetInputConnection(this->Tree->GetOutputPort());
    this->Balance->SetBalanceLevel(balanceLevel);
    this->Balance->Update();
  }

  long long BodyLeaves()
  {
    vtkUnstructuredGrid* tree = this->Balance->GetOutput();
    vtkDataArray* materials = tree->GetCellData()->GetArray("Material");
    const int background = BackgroundLabel(tree);
    long long count = 0;
    for (vtkIdType c = 0; c < tree->GetNumberOfCells(); ++c)
    {
      count += static_cast<int>(materials->GetComponent(c, 0)) != background ? 1 : 0;
    }
    return count;
  }

  Result Tessellate(int cellTemplate, bool perLevel)
  {
    vtkNew<stmSpacetreeTessellate> tessellate;
    tessellate->SetSeparatingFunction(stmSpacetreeTessellate::NO_FUNCTION); // the staircase mesh
    tessellate->SetInputConnection(this->Balance->GetOutputPort());
    tessellate->SetCellTemplate(cellTemplate);
    const auto start = std::chrono::steady_clock::now();
    tessellate->Update();
    const auto stop = std::chrono::steady_clock::now();
    vtkUnstructuredGrid* mesh = tessellate->GetOutput();
    Result result;
    result.Seconds = std::chrono::duration<double>(stop - start).count();
    result.BodyLeaves = this->BodyLeaves();
    result.Tetrahedra = mesh->GetNumberOfCells();
    result.Points = mesh->GetNumberOfPoints();
    const stmTest::VerdictQualityRange range = stmTest::MeasureVerdictQuality(mesh);
    result.WorstCondition = range.WorstCondition;
    result.SmallestAngle = range.SmallestAngle;
    if (perLevel)
    {
      result.Levels = CountPerLevel(this->Balance->GetOutput(), mesh, cellTemplate == 0 ? 5 : 6);
    }
    return result;
  }
};

std::string Size(const std::array<int, 3>& size, const double scale[3])
{
  std::ostringstream text;
  text << size[0] * scale[0] << " x " << size[1] * scale[1] << " x " << size[2] * scale[2];
  return text.str();
}

std::string Split(const LevelTable& table, std::size_t level)
{
  if (level + 1 >= table.size())
  {
    return "leaf (voxel)";
  }
  std::ostringstream text;
  text << table[level][0] / table[level + 1][0] << "x" << table[level][1] / table[level + 1][1]
       << "x" << table[level][2] / table[level + 1][2];
  return text.str();
}

std::string Percent(double value)
{
  std::ostringstream text;
  text << std::showpos << std::fixed << std::setprecision(std::abs(value) < 0.01 ? 2 : 1)
       << 100.0 * value << " %";
  return text.str();
}
} // namespace

int main(int argc, char* argv[])
{
  std::string input = "/usr/share/mricron/templates/aal.nii.gz";
  std::string output;
  if (!stmReport::ParseArguments(argc, argv,
        "stmPatternComparison [--input aal.nii.gz] [--output docs/refinement-patterns.md]", input,
        output))
  {
    return 2;
  }
  vtkSMPTools::SetBackend("STDThread");
  vtkNew<vtkNIFTIImageReader> reader;
  reader->SetFileName(input.c_str());
  reader->Update();
  if (reader->GetOutput()->GetNumberOfPoints() == 0)
  {
    std::cerr << "stmPatternComparison: cannot read " << input << "\n";
    return 1;
  }
  vtkNew<vtkExtractVOI> resample;
  resample->SetInputConnection(reader->GetOutputPort());
  resample->SetSampleRate(1, 1, 2);
  resample->Update();
  vtkImageData* anisotropic = resample->GetOutput();
  int dims[3];
  double spacing[3];
  anisotropic->GetDimensions(dims);
  anisotropic->GetSpacing(spacing);

  // Anisotropic atlas: both patterns, L = 1, 2, 3, both templates.
  const std::vector<std::string> patterns = { "auto", "2x2x2" };
  std::map<std::string, LevelTable> tables;
  struct Key
  {
    int Level, Template;
    std::string Pattern;
    bool operator<(const Key& other) const
    {
      return std::tie(this->Level, this->Template, this->Pattern) <
        std::tie(other.Level, other.Template, other.Pattern);
    }
  };
  std::map<Key, Result> results;
  for (int level : { 1, 2, 3 })
  {
    for (const std::string& pattern : patterns)
    {
      Spacetree tree(anisotropic, pattern, level);
      tables[pattern] = ReadLevelTable(tree.Tree->GetOutput());
      for (int cellTemplate : { 0, 1 })
      {
        results[{ level, cellTemplate, pattern }] =
          tree.Tessellate(cellTemplate, cellTemplate == 0);
        std::cerr << "." << std::flush;
      }
    }
  }
  // The isotropic atlas: 2x2x2 at L = 1, 2, 3 (the reference for the worst elements) and 3x3x3
  // at L = 1.
  std::map<Key, Result> isotropic;
  for (int level : { 1, 2, 3 })
  {
    for (const std::string pattern : { "3x3x3", "2x2x2" })
    {
      if (pattern == "3x3x3" && level != 1)
      {
        continue;
      }
      Spacetree tree(reader->GetOutput(), pattern, level);
      tables[pattern + " isotropic"] = ReadLevelTable(tree.Tree->GetOutput());
      for (int cellTemplate : { 0, 1 })
      {
        isotropic[{ level, cellTemplate, pattern }] = tree.Tessellate(cellTemplate, false);
        std::cerr << "." << std::flush;
      }
    }
  }
  // The template of a regular voxel leaf: 2 x 2 x 2 voxels of 1 x 1 x 2 mm, all of different
  // labels, so that every leaf is a voxel and every leaf is regular.
  Result voxelTemplate[2];
  {
    vtkNew<vtkImageData> voxels;
    voxels->SetDimensions(2, 2, 2);
    voxels->SetSpacing(spacing);
    voxels->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
    for (vtkIdType v = 0; v < 8; ++v)
    {
      voxels->GetPointData()->GetScalars()->SetComponent(v, 0, 1.0 + v);
    }
    Spacetree tree(voxels, "auto", 1);
    for (int cellTemplate : { 0, 1 })
    {
      voxelTemplate[cellTemplate] = tree.Tessellate(cellTemplate, false);
      if (voxelTemplate[cellTemplate].Tetrahedra != 8 * (cellTemplate == 0 ? 5 : 6))
      {
        std::cerr << "stmPatternComparison: the voxel leaves are not all regular\n";
        return 1;
      }
    }
  }
  std::cerr << "\n";

  auto sameWorst = [](const Result& a, const Result& b)
  {
    return std::abs(a.WorstCondition - b.WorstCondition) < 5e-4 &&
      std::abs(a.SmallestAngle - b.SmallestAngle) < 5e-3;
  };
  auto join = [](const std::vector<std::string>& names)
  {
    std::string text;
    for (std::size_t i = 0; i < names.size(); ++i)
    {
      text += (i == 0 ? "" : i + 1 == names.size() ? " and " : ", ") + names[i];
    }
    return text.empty() ? std::string("no case") : text;
  };
  auto caseName = [](int level, int cellTemplate)
  { return "L = " + std::to_string(level) + " " + TemplateNames[cellTemplate]; };
  auto worst = [](const Result& r)
  { return Fixed(r.WorstCondition, 3) + " / " + Fixed(r.SmallestAngle, 2) + "°"; };
  const char* const tableHeader =
    "| balance | template | pattern | body leaves | tetrahedra | points | worst condition | "
    "smallest angle | time (s) |\n|---|---|---|---:|---:|---:|---:|---:|---:|\n";
  auto row = [](int level, int cellTemplate, const std::string& pattern, const Result& r)
  {
    return "| L = " + std::to_string(level) + " | " + TemplateNames[cellTemplate] + " | " +
      pattern + " | " + Count(r.BodyLeaves) + " | " + Count(r.Tetrahedra) + " | " +
      Count(r.Points) + " | " + Fixed(r.WorstCondition, 3) + " | " + Fixed(r.SmallestAngle, 2) +
      " | " + Fixed(r.Seconds, 2) + " |\n";
  };

  std::ostringstream report;
  report << "# Refinement patterns on an anisotropic image\n\n"
         << "Generated by `stmPatternComparison --input " << input
         << " --output docs/refinement-patterns.md` (Benchmarks/stmPatternComparison.cxx; the "
            "program is built in `build/bin`); do not edit by hand. The times depend on the "
            "machine and its load; every other figure is deterministic.\n\n";
  report << "## The image and what `auto` chose\n\n"
         << "The AAL atlas (" << reader->GetOutput()->GetDimensions()[0] << " x "
         << reader->GetOutput()->GetDimensions()[1] << " x "
         << reader->GetOutput()->GetDimensions()[2]
         << " voxels of 1 mm, 116 labels), read by `vtkNIFTIImageReader` and resampled by "
            "`vtkExtractVOI` with `SampleRate` (1, 1, 2), i.e. every second axial slice: "
         << dims[0] << " x " << dims[1] << " x " << dims[2] << " voxels of " << spacing[0] << " x "
         << spacing[1] << " x " << spacing[2]
         << " mm. Everything else is default (`MaxCellSize` 16; the body is every label but "
            "0).\n\n"
         << "`RefinementPattern` \"auto\" (the default) chooses at every level the axes to "
            "split so that the cells become as cubic as possible in physical units. The level "
            "tables below are the spacetree's field array `SpacetreeCellSizes` (cell edges per "
            "level and axis, root first, in lattice units, which are voxels here); \"split\" is "
            "how a cell of that level is divided into the cells of the next.\n\n";
  const double voxelScale[3] = { 1, 1, 1 };
  for (const std::string& pattern : patterns)
  {
    const LevelTable& table = tables[pattern];
    report << "`" << pattern << "`:\n\n"
           << "| level | cell (voxels) | cell (mm) | split |\n|---:|---|---|---|\n";
    for (std::size_t l = 0; l < table.size(); ++l)
    {
      report << "| " << l << " | " << Size(table[l], voxelScale) << " | " << Size(table[l], spacing)
             << " | " << Split(table, l) << " |\n";
    }
    report << "\n";
  }
  report << "So `auto` refines 2x2x2 from cubic root cells of 16 mm down to cubes of 2 mm, and "
            "then 2x2x1 into the voxels; isotropic 2x2x2 refinement keeps the voxel's aspect "
            "ratio of 2 at every level (its root cells are 16 x 16 x 32 mm). The finest leaves "
            "of both trees are the voxels, and every label's volume in the mesh is exactly its "
            "voxel volume (Testing/Cxx/Filters/TestAnisotropicAtlas.cxx checks it, with "
            "conformity, for both patterns at L = 1, 2 and 3).\n\n";

  report << "## Figures\n\n"
         << "Body leaves: leaves of the balanced spacetree that are not background. Worst "
            "condition: the largest Verdict condition number over the tetrahedra (1 is the "
            "regular tetrahedron); smallest angle: the smallest dihedral angle in degrees; both "
            "measured by `vtkMeshQuality`. Time: `stmSpacetreeTessellate` alone, in seconds, "
            "with vtkSMPTools' STDThread backend on "
         << vtkSMPTools::GetEstimatedNumberOfThreads()
         << " threads (informational). Change: `auto` relative to 2x2x2.\n\n"
         << tableHeader;
  for (int level : { 1, 2, 3 })
  {
    for (int cellTemplate : { 0, 1 })
    {
      for (const std::string& pattern : patterns)
      {
        report << row(level, cellTemplate, pattern, results[{ level, cellTemplate, pattern }]);
      }
      const Result& a = results[{ level, cellTemplate, "auto" }];
      const Result& b = results[{ level, cellTemplate, "2x2x2" }];
      report << "| L = " << level << " | " << TemplateNames[cellTemplate] << " | change | "
             << Percent(static_cast<double>(a.BodyLeaves) / b.BodyLeaves - 1) << " | "
             << Percent(static_cast<double>(a.Tetrahedra) / b.Tetrahedra - 1) << " | "
             << Percent(static_cast<double>(a.Points) / b.Points - 1) << " | "
             << Percent(a.WorstCondition / b.WorstCondition - 1) << " | "
             << Percent(a.SmallestAngle / b.SmallestAngle - 1) << " | |\n";
    }
  }
  report << "\n";

  // The reading: every statement that depends on the figures is computed from them, so a
  // regenerated report cannot silently contradict its own tables.
  bool qualityBetter = true, fewerLeaves = true;
  double leastGain = 1, mostGain = 0; // relative decrease of the worst condition number
  std::vector<std::string> moreTetrahedra, fewerTetrahedra, likeIsotropic, likeVoxel;
  for (int level : { 1, 2, 3 })
  {
    for (int cellTemplate : { 0, 1 })
    {
      const Result& a = results[{ level, cellTemplate, "auto" }];
      const Result& b = results[{ level, cellTemplate, "2x2x2" }];
      qualityBetter =
        qualityBetter && a.WorstCondition < b.WorstCondition && a.SmallestAngle > b.SmallestAngle;
      leastGain = std::min(leastGain, 1 - a.WorstCondition / b.WorstCondition);
      mostGain = std::max(mostGain, 1 - a.WorstCondition / b.WorstCondition);
      fewerLeaves = fewerLeaves && a.BodyLeaves < b.BodyLeaves;
      (a.Tetrahedra > b.Tetrahedra ? moreTetrahedra : fewerTetrahedra)
        .push_back(caseName(level, cellTemplate) + " (" +
          Percent(static_cast<double>(a.Tetrahedra) / b.Tetrahedra - 1) + ")");
      if (sameWorst(a, isotropic[{ level, cellTemplate, "2x2x2" }]))
      {
        likeIsotropic.push_back(caseName(level, cellTemplate));
      }
      if (sameWorst(a, voxelTemplate[cellTemplate]))
      {
        likeVoxel.push_back(caseName(level, cellTemplate));
      }
    }
  }
  report << "## Reading\n\n"
         << "**Quality.** `auto` has "
         << (qualityBetter ? "the better worst element in every case"
                           : "NOT the better worst element in every case")
         << " (smaller worst condition number, larger smallest dihedral angle); the worst "
            "condition number is "
         << Fixed(100 * leastGain, 0) << " to " << Fixed(100 * mostGain, 0)
         << " % lower. Its cells are cubes down to 2 mm, while 2x2x2 stretches every "
            "level by 2 along z and its tetrahedra inherit the stretch. The voxel leaves, which "
            "both trees have and which are always regular (nothing is finer), bound the worst "
            "element from below: the template of a 1 x 1 x 2 mm box gives "
         << worst(voxelTemplate[0]) << " with Checkerboard, " << worst(voxelTemplate[1])
         << " with Kuhn. Worst condition / smallest angle against the isotropic atlas (1 mm "
            "voxels, 2x2x2; docs/quality.md):\n\n"
         << "| balance | template | `auto`, 1 x 1 x 2 mm | 2x2x2, 1 x 1 x 2 mm | 2x2x2, 1 mm "
            "voxels |\n|---|---|---:|---:|---:|\n";
  for (int level : { 1, 2, 3 })
  {
    for (int cellTemplate : { 0, 1 })
    {
      report << "| L = " << level << " | " << TemplateNames[cellTemplate] << " | "
             << worst(results[{ level, cellTemplate, "auto" }]) << " | "
             << worst(results[{ level, cellTemplate, "2x2x2" }]) << " | "
             << worst(isotropic[{ level, cellTemplate, "2x2x2" }]) << " |\n";
    }
  }
  report << "\n`auto` reaches exactly the worst element of the isotropic atlas for "
         << join(likeIsotropic) << "; its worst element is the voxel template's for "
         << join(likeVoxel) << ".\n\n";

  const std::size_t finest = tables["auto"].size() - 1;
  // Voxel leaves: the same at every L? More leaves above the voxels with auto at every L?
  bool sameVoxels = true, moreAbove = true;
  for (int level : { 1, 2, 3 })
  {
    const LevelCount& a = results[{ level, 0, "auto" }].Levels[finest];
    const LevelCount& b = results[{ level, 0, "2x2x2" }].Levels[finest];
    sameVoxels = sameVoxels && a.Leaves == results[{ 1, 0, "auto" }].Levels[finest].Leaves &&
      b.Leaves == results[{ 1, 0, "2x2x2" }].Levels[finest].Leaves;
    moreAbove = moreAbove &&
      results[{ level, 0, "auto" }].BodyLeaves - a.Leaves >
        results[{ level, 0, "2x2x2" }].BodyLeaves - b.Leaves;
  }
  report << "**Leaves.** `auto` has " << (fewerLeaves ? "fewer" : "NOT always fewer")
         << " body leaves everywhere, because a mixed 2 mm cube is split 2x2x1 into 4 voxels "
            "where 2x2x2 splits a mixed 2 x 2 x 4 mm cell into 8: "
         << Count(results[{ 1, 0, "auto" }].Levels[finest].Leaves) << " voxel leaves against "
         << Count(results[{ 1, 0, "2x2x2" }].Levels[finest].Leaves)
         << (sameVoxels ? " at every L" : " at L = 1 (other L differ)")
         << ". Above the voxels `auto` has " << (moreAbove ? "more" : "NOT always more")
         << " leaves (its cells are half the volume of 2x2x2's cells of the same level), but "
            "fewer than it saves.\n\n";
  report << "**Tetrahedra.** Fewer with `auto` for " << join(fewerTetrahedra) << "; more for "
         << join(moreTetrahedra)
         << ". Fewer leaves do not mean fewer tetrahedra: a regular leaf is cut into 5 "
            "(Checkerboard) or 6 (Kuhn) tetrahedra by its template, a leaf with a finer "
            "neighbour (irregular) into many more by the recursive midpoint rule. The table "
            "assigns every tetrahedron to the leaf that contains its centroid (Checkerboard; a "
            "leaf is regular when it got exactly 5):\n\n"
         << "| balance | pattern | level | cell (mm) | body leaves | regular | irregular | "
            "tetrahedra | tetrahedra per irregular leaf |\n"
         << "|---|---|---:|---|---:|---:|---:|---:|---:|\n";
  for (int level : { 1, 3 })
  {
    for (const std::string& pattern : patterns)
    {
      const Result& r = results[{ level, 0, pattern }];
      for (std::size_t l = 0; l < r.Levels.size(); ++l)
      {
        const LevelCount& c = r.Levels[l];
        if (c.Leaves == 0)
        {
          continue;
        }
        const long long irregular = c.Leaves - c.Regular;
        report << "| L = " << level << " | " << pattern << " | " << l << " | "
               << Size(tables[pattern][l], spacing) << " | " << Count(c.Leaves) << " | "
               << Count(c.Regular) << " | " << Count(irregular) << " | " << Count(c.Tetrahedra)
               << " | "
               << (irregular > 0
                      ? Fixed(static_cast<double>(c.Tetrahedra - 5 * c.Regular) / irregular, 1)
                      : std::string("-"))
               << " |\n";
      }
    }
  }
  // Tetrahedra of the voxel leaves and of the leaves above them, auto minus 2x2x2.
  auto split = [&](int level, const std::string& pattern, bool voxels)
  {
    long long sum = 0;
    const std::vector<LevelCount>& levels = results[{ level, 0, pattern }].Levels;
    for (std::size_t l = 0; l < levels.size(); ++l)
    {
      sum += (l + 1 == levels.size()) == voxels ? levels[l].Tetrahedra : 0;
    }
    return sum;
  };
  auto signedCount = [](long long value)
  { return (value < 0 ? "-" : "+") + Count(value < 0 ? -value : value); };
  const std::size_t band = finest - 1;
  const LevelCount& a1 = results[{ 1, 0, "auto" }].Levels[band];
  const LevelCount& b1 = results[{ 1, 0, "2x2x2" }].Levels[band];
  const LevelCount& a3 = results[{ 3, 0, "auto" }].Levels[band];
  auto perIrregular = [](const LevelCount& c)
  { return static_cast<double>(c.Tetrahedra - 5 * c.Regular) / (c.Leaves - c.Regular); };
  const long long voxelSaving1 = split(1, "auto", true) - split(1, "2x2x2", true);
  const long long voxelSaving3 = split(3, "auto", true) - split(3, "2x2x2", true);
  const long long cost1 = split(1, "auto", false) - split(1, "2x2x2", false);
  const long long cost3 = split(3, "auto", false) - split(3, "2x2x2", false);
  report << "\nWhere the difference comes from, `auto` minus 2x2x2 with Checkerboard:\n\n"
         << "| balance | voxel leaves | leaves above the voxels | all |\n|---|---:|---:|---:|\n";
  for (int level : { 1, 3 })
  {
    const long long voxels = split(level, "auto", true) - split(level, "2x2x2", true);
    const long long above = split(level, "auto", false) - split(level, "2x2x2", false);
    report << "| L = " << level << " | " << signedCount(voxels) << " | " << signedCount(above)
           << " | " << signedCount(voxels + above) << " |\n";
  }
  report << "\nThe voxel leaves save "
         << (voxelSaving1 == voxelSaving3 ? "the same number of tetrahedra at every L"
                                          : "a number of tetrahedra that depends on L")
         << " (half as many voxel leaves, 5 tetrahedra each). The cost is the layer of level-"
         << band
         << " cells that balancing puts around them: with `auto` these are 2 mm cubes (2 x 2 x "
            "1 voxels), half the volume of the 2 x 2 x 4 mm cells of 2x2x2, so at L = 1 the "
            "layer has "
         << Fixed(static_cast<double>(a1.Leaves) / b1.Leaves, 1) << " times as many leaves ("
         << Count(a1.Leaves) << " against " << Count(b1.Leaves) << "; irregular "
         << Count(a1.Leaves - a1.Regular) << " against " << Count(b1.Leaves - b1.Regular)
         << "). An irregular 2 mm cube gets fewer tetrahedra than an irregular 2 x 2 x 4 mm "
            "cell ("
         << Fixed(perIrregular(a1), 1) << " against " << Fixed(perIrregular(b1), 1)
         << " on average), but not few enough: at L = 1 the leaves above the voxels cost "
         << (cost1 > -voxelSaving1 ? "more" : "less")
         << " than the voxels save. At L = 3 a voxel "
            "may border leaves three levels coarser, so `auto` needs "
         << Count(a3.Leaves) << " level-" << band << " leaves instead of " << Count(a1.Leaves)
         << ", the cost above the voxels drops to " << signedCount(cost3) << ", and the saving "
         << (cost3 < -voxelSaving3 ? "wins" : "does NOT win")
         << ". Every irregular leaf is cut by the recursive midpoint rule; templates for "
            "irregular cells (issue 4) will change these counts.\n\n";

  report << "## 3^d refinement on the isotropic atlas\n\n"
         << "The atlas itself (1 mm voxels) at L = 1 with the uniform pattern 3x3x3 (root cells "
            "of "
         << tables["3x3x3 isotropic"][0][0]
         << " voxels, the largest power of 3 not above `MaxCellSize` 16) against 2x2x2 (root "
            "cells of "
         << tables["2x2x2 isotropic"][0][0]
         << " voxels), to show the 3^d pattern at work on real data. Conformity and exact "
            "volumes of 3^d meshes are tested on synthetic images "
            "(Testing/Cxx/Filters/TestRefinementCriteria.cxx, "
            "Testing/Cxx/Core/TestRefinementPatterns.cxx).\n\n"
         << tableHeader;
  for (int cellTemplate : { 0, 1 })
  {
    for (const std::string pattern : { "3x3x3", "2x2x2" })
    {
      report << row(1, cellTemplate, pattern, isotropic[{ 1, cellTemplate, pattern }]);
    }
  }
  {
    const Result& three = isotropic[{ 1, 0, "3x3x3" }];
    const Result& two = isotropic[{ 1, 0, "2x2x2" }];
    const double tetrahedra = static_cast<double>(three.Tetrahedra) / two.Tetrahedra - 1;
    const double leaves = static_cast<double>(three.BodyLeaves) / two.BodyLeaves - 1;
    auto relative = [](double change)
    { return Percent(std::abs(change)).substr(1) + (change < 0 ? " fewer" : " more"); };
    report << "\nWith Checkerboard, 3x3x3 gives " << relative(tetrahedra) << " tetrahedra and "
           << relative(leaves) << " body leaves than 2x2x2, and a "
           << (three.WorstCondition > two.WorstCondition ? "worse" : "better") << " worst element ("
           << worst(three) << " against " << worst(two)
           << "), presumably from the recursive midpoint rule: it joins the centre of a leaf "
              "with a finer neighbour to the children of its facets, which are a third of the "
              "leaf's edge with 3x3x3 and a half with 2x2x2, so the tetrahedra are more "
              "elongated.\n";
  }

  return stmReport::WriteReport(report.str(), output) ? 0 : 1;
}
