// SPDX-License-Identifier: BSD-3-Clause
// Writes the element-quality report of the tessellation (docs/quality.md): for balance levels
// 1, 2, 3 and unbalanced trees, the worst Verdict condition number and the smallest angle
// (dihedral for tetrahedra) measured by vtkMeshQuality, and the number of distinct element shapes,
// on the AAL atlas, on a 2D slice of it, and on random box-and-ball label images.
//
//   stmElementQuality [--input aal.nii.gz] [--output docs/quality.md]

#include "stmImageToSpacetree.h"
#include "stmReportTool.h"
#include "stmSpacetreeBalance.h"
#include "stmSpacetreeTessellate.h"
#include "stmVerdictQuality.h"

#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkExtractVOI.h"
#include "vtkIdList.h"
#include "vtkImageData.h"
#include "vtkNIFTIImageReader.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkSMPTools.h"
#include "vtkSmartPointer.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace
{
struct Quality
{
  vtkIdType Cells = 0;
  double WorstCondition = 0;
  double SmallestAngle = 180;
  std::size_t Shapes = 0;
};

vtkSmartPointer<vtkUnstructuredGrid> Mesh(vtkImageData* image, int balanceLevel, int cellTemplate)
{
  vtkNew<stmImageToSpacetree> tree;
  vtkNew<stmSpacetreeBalance> balance;
  vtkNew<stmSpacetreeTessellate> tessellate;
  tessellate->SetSeparatingFunction(stmSpacetreeTessellate::NO_FUNCTION); // the staircase mesh
  tree->SetInputData(image);
  balance->SetInputConnection(tree->GetOutputPort());
  balance->SetBalanceLevel(std::max(1, balanceLevel));
  tessellate->SetCellTemplate(cellTemplate);
  tessellate->SetInputConnection(
    balanceLevel > 0 ? balance->GetOutputPort() : tree->GetOutputPort());
  tessellate->Update();
  auto mesh = vtkSmartPointer<vtkUnstructuredGrid>::New();
  mesh->ShallowCopy(tessellate->GetOutput());
  return mesh;
}

/// A shape up to similarity and vertex order: the sorted squared edge lengths over the largest.
std::size_t CountShapes(vtkUnstructuredGrid* mesh)
{
  using Key = std::array<long long, 6>; // 6 edges of a tetrahedron; a triangle uses 3
  std::vector<Key> keys(static_cast<std::size_t>(mesh->GetNumberOfCells()));
  vtkSMPTools::For(0, mesh->GetNumberOfCells(),
    [&](vtkIdType begin, vtkIdType end)
    {
      vtkNew<vtkIdList> ids;
      for (vtkIdType c = begin; c < end; ++c)
      {
        mesh->GetCellPoints(c, ids);
        std::array<double, 4 * 3> x{};
        const int n = static_cast<int>(std::min<vtkIdType>(ids->GetNumberOfIds(), 4));
        for (int v = 0; v < n; ++v)
        {
          mesh->GetPoints()->GetPoint(ids->GetId(v), &x[3 * v]);
        }
        std::array<double, 6> lengths{};
        int e = 0;
        for (int a = 0; a < n; ++a)
        {
          for (int b = a + 1; b < n; ++b)
          {
            double squared = 0;
            for (int k = 0; k < 3; ++k)
            {
              squared += (x[3 * a + k] - x[3 * b + k]) * (x[3 * a + k] - x[3 * b + k]);
            }
            lengths[e++] = squared;
          }
        }
        std::sort(lengths.begin(), lengths.begin() + e);
        Key key{};
        for (int i = 0; i < e; ++i)
        {
          key[i] = std::llround(1e6 * lengths[i] / lengths[e - 1]);
        }
        keys[c] = key;
      }
    });
  std::sort(keys.begin(), keys.end());
  return static_cast<std::size_t>(std::unique(keys.begin(), keys.end()) - keys.begin());
}

Quality Measure(vtkUnstructuredGrid* mesh)
{
  Quality quality;
  quality.Cells = mesh->GetNumberOfCells();
  if (quality.Cells == 0)
  {
    return quality;
  }
  const stmTest::VerdictQualityRange range = stmTest::MeasureVerdictQuality(mesh);
  quality.WorstCondition = range.WorstCondition;
  quality.SmallestAngle = range.SmallestAngle;
  quality.Shapes = CountShapes(mesh);
  return quality;
}

/// Random axis-aligned boxes and balls of labels 1 to 3 in a cube image; fixed seed, and the
/// generator's raw output only, so the image is the same on every platform.
vtkSmartPointer<vtkImageData> RandomImage(int n, int dimension, unsigned seed)
{
  std::mt19937 random(seed);
  auto uniform = [&](int lo, int hi) { return lo + static_cast<int>(random() % (hi - lo + 1)); };
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(n, n, dimension == 3 ? n : 1);
  image->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  auto* labels = vtkUnsignedCharArray::SafeDownCast(image->GetPointData()->GetScalars());
  labels->FillValue(0);
  const int nz = dimension == 3 ? n : 1;
  for (int shape = 0; shape < 40; ++shape)
  {
    const int label = uniform(1, 3);
    const int c[3] = { uniform(0, n - 1), uniform(0, n - 1),
      dimension == 3 ? uniform(0, n - 1) : 0 };
    const int r = uniform(1, n / 5);
    const bool ball = uniform(0, 1) == 1;
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
        {
          const int d[3] = { i - c[0], j - c[1], k - c[2] };
          const bool inside = ball
            ? d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= r * r
            : std::abs(d[0]) <= r && std::abs(d[1]) <= r && std::abs(d[2]) <= r;
          if (inside)
          {
            labels->SetValue(
              (static_cast<vtkIdType>(k) * n + j) * n + i, static_cast<unsigned char>(label));
          }
        }
  }
  return image;
}

std::string Row(
  const std::string& input, const std::string& balance, const std::string& cells, const Quality& q)
{
  std::ostringstream row;
  row << "| " << input << " | " << balance << " | " << cells << " | " << q.Cells << " | "
      << std::fixed << std::setprecision(3) << q.WorstCondition << " | " << std::setprecision(2)
      << q.SmallestAngle << " | " << q.Shapes << " |";
  return row.str();
}
} // namespace

int main(int argc, char* argv[])
{
  std::string input = "/usr/share/mricron/templates/aal.nii.gz";
  std::string output;
  if (!stmReport::ParseArguments(argc, argv,
        "stmElementQuality [--input aal.nii.gz] [--output docs/quality.md]", input, output))
  {
    return 2;
  }
  vtkSMPTools::SetBackend("STDThread");
  vtkNew<vtkNIFTIImageReader> reader;
  reader->SetFileName(input.c_str());
  reader->Update();
  if (reader->GetOutput()->GetNumberOfPoints() == 0)
  {
    std::cerr << "stmElementQuality: cannot read " << input << "\n";
    return 1;
  }
  vtkNew<vtkExtractVOI> slice;
  slice->SetInputConnection(reader->GetOutputPort());
  int dims[3];
  reader->GetOutput()->GetDimensions(dims);
  slice->SetVOI(0, dims[0] - 1, 0, dims[1] - 1, dims[2] / 2, dims[2] / 2);
  slice->Update();

  std::ostringstream report;
  report
    << "# Element quality of the tessellation\n\n"
    << "Generated by `stmElementQuality --input " << input
    << " --output docs/quality.md` (Benchmarks/stmElementQuality.cxx); do not edit by hand.\n\n"
    << "Worst condition number: the largest Verdict condition number over the elements "
       "(1 is the equilateral simplex). Smallest angle: the smallest dihedral angle of a "
       "tetrahedron, or the smallest angle of a triangle, in degrees. Shapes: the number of "
       "distinct element shapes up to similarity. Templates: Checkerboard cuts a regular "
       "cube into 5 tetrahedra (the paper's), Kuhn into 6.\n\n"
    << "| input | balance | template | elements | worst condition | smallest angle | shapes |\n"
    << "|---|---|---|---:|---:|---:|---:|\n";
  struct Input
  {
    std::string Name;
    vtkImageData* Image;
  };
  auto random3 = RandomImage(96, 3, 7);
  auto random2 = RandomImage(256, 2, 11);
  const std::vector<Input> inputs = { { "aal.nii.gz (3D, 116 labels)", reader->GetOutput() },
    { "aal.nii.gz axial slice " + std::to_string(dims[2] / 2) + " (2D)", slice->GetOutput() },
    { "random boxes and balls, 96^3", random3 }, { "random boxes and balls, 256^2", random2 } };
  for (const Input& in : inputs)
  {
    for (int cellTemplate : { 0, 1 })
    {
      for (int level : { 1, 2, 3, 0 })
      {
        const auto mesh = Mesh(in.Image, level, cellTemplate);
        const Quality q = Measure(mesh);
        report << Row(in.Name, level == 0 ? "unbalanced" : "L = " + std::to_string(level),
                    cellTemplate == 0 ? "Checkerboard" : "Kuhn", q)
               << "\n";
        std::cerr << "." << std::flush;
      }
    }
  }
  std::cerr << "\n";
  return stmReport::WriteReport(report.str(), output) ? 0 : 1;
}
