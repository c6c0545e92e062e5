// SPDX-License-Identifier: BSD-3-Clause
/**
 * stmeshTestHelper: test support for the stmesh command-line tests (TestStmesh.py).
 *
 *   stmeshTestHelper readback MESH.vtu|MESH.vtk [geometry]
 *     reads a mesh written by stmesh and prints one JSON object: cell and point counts, the
 *     distinct cell types, the cell array names and the cells per value of "Material". With
 *     "geometry" also the total measure (volume, or area of triangles) per material of the
 *     simplices (signed for tetrahedra) and the smallest one, and the longest and shortest
 *     cell edge (the extent of a cell's bounding box along one axis) per material.
 *   stmeshTestHelper make-image IMAGE TYPE [VARIANT]
 *     writes a small 3D label image (labels 0, 1, 2, 7) with scalar TYPE uint8, int16 or float,
 *     as .vti, .mha, .mhd, .nii, .nii.gz or .nrrd (chosen by extension, case-insensitive).
 *     VARIANT "2d" writes one slice of it (20 x 18 x 1 voxels); "sizing" adds the point arrays
 *     "sizing" (2.0 everywhere) and "bad_sizing" (0 at i = 0, else 1.0) and the cell array
 *     "cell_sizing" (1.0) for the --sizing-array tests (only .vti keeps them).
 *
 * Exit code 0 on success, 1 on any error (also any VTK error), with a message on stderr.
 */

#include "vtkCallbackCommand.h"
#include "vtkCellData.h"
#include "vtkCommand.h"
#include "vtkDataArray.h"
#include "vtkFloatArray.h"
#include "vtkIdList.h"
#include "vtkImageData.h"
#include "vtkMetaImageWriter.h"
#include "vtkNIFTIImageWriter.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkUnstructuredGrid.h"
#include "vtkUnstructuredGridReader.h"
#include "vtkXMLImageDataWriter.h"
#include "vtkXMLUnstructuredGridReader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <set>
#include <string>

namespace
{
bool VTKErrorHappened = false;

void RecordError(vtkObject*, unsigned long, void*, void* callData)
{
  VTKErrorHappened = true;
  std::cerr << "stmeshTestHelper: VTK error: " << (callData ? static_cast<char*>(callData) : "")
            << '\n';
}

void Watch(vtkObject* object)
{
  vtkNew<vtkCallbackCommand> onError;
  onError->SetCallback(RecordError);
  object->AddObserver(vtkCommand::ErrorEvent, onError);
}

std::string LowerCase(std::string text)
{
  std::transform(text.begin(), text.end(), text.begin(),
    [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

bool EndsWith(const std::string& text, const std::string& suffix)
{
  return text.size() >= suffix.size() &&
    text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

int ReadBack(const std::string& path, bool geometry)
{
  const std::string lower = LowerCase(path);
  vtkUnstructuredGrid* grid = nullptr;
  vtkNew<vtkXMLUnstructuredGridReader> xmlReader;
  vtkNew<vtkUnstructuredGridReader> legacyReader;
  if (EndsWith(lower, ".vtu"))
  {
    Watch(xmlReader);
    xmlReader->SetFileName(path.c_str());
    xmlReader->Update();
    grid = xmlReader->GetOutput();
  }
  else if (EndsWith(lower, ".vtk"))
  {
    Watch(legacyReader);
    legacyReader->SetFileName(path.c_str());
    legacyReader->Update();
    grid = legacyReader->GetOutput();
  }
  else
  {
    std::cerr << "stmeshTestHelper: readback needs a .vtu or .vtk file\n";
    return 1;
  }
  if (VTKErrorHappened || !grid)
  {
    std::cerr << "stmeshTestHelper: cannot read " << path << '\n';
    return 1;
  }

  std::set<int> cellTypes;
  for (vtkIdType cell = 0; cell < grid->GetNumberOfCells(); ++cell)
  {
    cellTypes.insert(grid->GetCellType(cell));
  }
  std::map<long long, long long> materialCounts;
  std::map<long long, double> measures;
  std::map<long long, double> longestEdges;
  std::map<long long, double> shortestEdges;
  double smallestMeasure = std::numeric_limits<double>::infinity();
  vtkDataArray* materials = grid->GetCellData()->GetArray("Material");
  if (materials && grid->GetPoints())
  {
    vtkNew<vtkIdList> ids;
    for (vtkIdType cell = 0; cell < materials->GetNumberOfTuples(); ++cell)
    {
      const long long material = static_cast<long long>(materials->GetTuple1(cell));
      ++materialCounts[material];
      if (!geometry)
      {
        continue;
      }
      grid->GetCellPoints(cell, ids);
      double p[8][3];
      const vtkIdType n = std::min<vtkIdType>(ids->GetNumberOfIds(), 8);
      double low[3] = { VTK_DOUBLE_MAX, VTK_DOUBLE_MAX, VTK_DOUBLE_MAX };
      double high[3] = { VTK_DOUBLE_MIN, VTK_DOUBLE_MIN, VTK_DOUBLE_MIN };
      for (vtkIdType i = 0; i < n; ++i)
      {
        grid->GetPoints()->GetPoint(ids->GetId(i), p[i]);
        for (int c = 0; c < 3; ++c)
        {
          low[c] = std::min(low[c], p[i][c]);
          high[c] = std::max(high[c], p[i][c]);
        }
      }
      // The edge of an axis-aligned leaf; for a simplex, its bounding box's longest side.
      double longest = 0.0;
      double shortest = VTK_DOUBLE_MAX;
      for (int c = 0; c < 3; ++c)
      {
        longest = std::max(longest, high[c] - low[c]);
        if (high[c] - low[c] > 0)
        {
          shortest = std::min(shortest, high[c] - low[c]);
        }
      }
      longestEdges[material] = std::max(longestEdges[material], longest);
      shortestEdges[material] =
        shortestEdges.count(material) ? std::min(shortestEdges[material], shortest) : shortest;
      double a[3], b[3], c[3];
      for (int k = 0; k < 3; ++k)
      {
        a[k] = p[1][k] - p[0][k];
        b[k] = p[2][k] - p[0][k];
        c[k] = n > 3 ? p[3][k] - p[0][k] : 0.0;
      }
      const double cross[3] = { a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0] };
      double measure = 0.0;
      if (grid->GetCellType(cell) == VTK_TETRA)
      {
        measure = (cross[0] * c[0] + cross[1] * c[1] + cross[2] * c[2]) / 6.0;
      }
      else if (grid->GetCellType(cell) == VTK_TRIANGLE)
      {
        measure = 0.5 * std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]);
      }
      else
      {
        continue;
      }
      measures[material] += measure;
      smallestMeasure = std::min(smallestMeasure, measure);
    }
  }

  std::cout << "{\"cells\": " << grid->GetNumberOfCells()
            << ", \"points\": " << grid->GetNumberOfPoints() << ", \"cell_types\": [";
  bool first = true;
  for (int type : cellTypes)
  {
    std::cout << (first ? "" : ", ") << type;
    first = false;
  }
  std::cout << "], \"cell_arrays\": [";
  for (int i = 0; i < grid->GetCellData()->GetNumberOfArrays(); ++i)
  {
    const char* name = grid->GetCellData()->GetArrayName(i);
    std::cout << (i ? ", " : "") << '"' << (name ? name : "") << '"';
  }
  std::cout << "], \"material_counts\": {";
  first = true;
  for (const auto& entry : materialCounts)
  {
    std::cout << (first ? "" : ", ") << '"' << entry.first << "\": " << entry.second;
    first = false;
  }
  std::cout << "}" << std::setprecision(15);
  if (!geometry)
  {
    std::cout << "}\n";
    return 0;
  }
  const std::pair<const char*, const std::map<long long, double>*> perMaterial[] = {
    { "material_measures", &measures }, { "longest_edges", &longestEdges },
    { "shortest_edges", &shortestEdges }
  };
  for (const auto& entries : perMaterial)
  {
    std::cout << ", \"" << entries.first << "\": {";
    first = true;
    for (const auto& entry : *entries.second)
    {
      std::cout << (first ? "" : ", ") << '"' << entry.first << "\": " << entry.second;
      first = false;
    }
    std::cout << "}";
  }
  std::cout << ", \"smallest_measure\": ";
  if (measures.empty())
  {
    std::cout << "null";
  }
  else
  {
    std::cout << smallestMeasure;
  }
  std::cout << "}\n";
  return 0;
}

/// The label of voxel (i, j, k) in the 20 x 18 x 16 test image: a ball of label 1, a box of
/// label 2 touching it, a small block of label 7, background 0.
int TestLabel(int i, int j, int k)
{
  const int di = i - 9;
  const int dj = j - 9;
  const int dk = k - 8;
  if (di * di + dj * dj + dk * dk <= 25)
  {
    return 1;
  }
  if (i >= 13 && i <= 18 && j >= 2 && j <= 8 && k >= 4 && k <= 11)
  {
    return 2;
  }
  if (i >= 2 && i <= 3 && j >= 13 && j <= 15 && k >= 2 && k <= 4)
  {
    return 7;
  }
  return 0;
}

/// NRRD with a raw little-endian payload; VTK has a NRRD reader but no writer.
bool WriteNrrd(vtkImageData* image, const std::string& path, const char* nrrdType)
{
  int dimensions[3];
  image->GetDimensions(dimensions);
  vtkDataArray* scalars = image->GetPointData()->GetScalars();
  std::ofstream file(path, std::ios::binary);
  file << "NRRD0004\n"
       << "type: " << nrrdType << "\n"
       << "dimension: 3\n"
       << "sizes: " << dimensions[0] << ' ' << dimensions[1] << ' ' << dimensions[2] << "\n"
       << "spacings: 1 1 1\n"
       << "endian: little\n"
       << "encoding: raw\n\n";
  file.write(static_cast<const char*>(scalars->GetVoidPointer(0)),
    static_cast<std::streamsize>(scalars->GetNumberOfValues() * scalars->GetDataTypeSize()));
  return static_cast<bool>(file);
}

int MakeImage(const std::string& path, const std::string& typeName, const std::string& variant)
{
  if (variant != "plain" && variant != "2d" && variant != "sizing")
  {
    std::cerr << "stmeshTestHelper: VARIANT must be 2d or sizing\n";
    return 1;
  }
  const bool flat = variant == "2d";
  const int slices = flat ? 1 : 16;
  int scalarType = VTK_UNSIGNED_CHAR;
  const char* nrrdType = "uint8";
  if (typeName == "int16")
  {
    scalarType = VTK_SHORT;
    nrrdType = "int16";
  }
  else if (typeName == "float")
  {
    scalarType = VTK_FLOAT;
    nrrdType = "float";
  }
  else if (typeName != "uint8")
  {
    std::cerr << "stmeshTestHelper: TYPE must be uint8, int16 or float\n";
    return 1;
  }

  vtkNew<vtkImageData> image;
  image->SetDimensions(20, 18, slices);
  image->AllocateScalars(scalarType, 1);
  vtkDataArray* scalars = image->GetPointData()->GetScalars();
  scalars->SetName("labels");
  vtkIdType index = 0;
  for (int k = 0; k < slices; ++k)
  {
    for (int j = 0; j < 18; ++j)
    {
      for (int i = 0; i < 20; ++i)
      {
        // A float image gets fractional values, as a gray-value image would.
        const double value = TestLabel(i, j, flat ? 8 : k) + (scalarType == VTK_FLOAT ? 0.25 : 0.0);
        scalars->SetTuple1(index++, value);
      }
    }
  }
  if (variant == "sizing")
  {
    vtkNew<vtkFloatArray> sizing;
    sizing->SetName("sizing");
    sizing->SetNumberOfValues(image->GetNumberOfPoints());
    sizing->Fill(2.0);
    image->GetPointData()->AddArray(sizing);
    vtkNew<vtkFloatArray> badSizing;
    badSizing->SetName("bad_sizing");
    badSizing->SetNumberOfValues(image->GetNumberOfPoints());
    for (vtkIdType point = 0; point < image->GetNumberOfPoints(); ++point)
    {
      badSizing->SetValue(point, point % 20 == 0 ? 0.0f : 1.0f);
    }
    image->GetPointData()->AddArray(badSizing);
    vtkNew<vtkFloatArray> cellSizing;
    cellSizing->SetName("cell_sizing");
    cellSizing->SetNumberOfValues(image->GetNumberOfCells());
    cellSizing->Fill(1.0);
    image->GetCellData()->AddArray(cellSizing);
  }

  const std::string lower = LowerCase(path);
  int written = 0;
  if (EndsWith(lower, ".vti"))
  {
    vtkNew<vtkXMLImageDataWriter> writer;
    Watch(writer);
    writer->SetInputData(image);
    writer->SetFileName(path.c_str());
    writer->SetDataModeToBinary(); // inline: Debian 12's libexpat fails on appended data
    written = writer->Write();
  }
  else if (EndsWith(lower, ".mha") || EndsWith(lower, ".mhd"))
  {
    vtkNew<vtkMetaImageWriter> writer;
    Watch(writer);
    writer->SetInputData(image);
    writer->SetFileName(path.c_str());
    writer->SetCompression(false);
    writer->Write();
    written = VTKErrorHappened ? 0 : 1;
  }
  else if (EndsWith(lower, ".nii") || EndsWith(lower, ".nii.gz"))
  {
    vtkNew<vtkNIFTIImageWriter> writer;
    Watch(writer);
    writer->SetInputData(image);
    writer->SetFileName(path.c_str());
    writer->Write();
    written = VTKErrorHappened ? 0 : 1;
  }
  else if (EndsWith(lower, ".nrrd"))
  {
    written = WriteNrrd(image, path, nrrdType) ? 1 : 0;
  }
  else
  {
    std::cerr << "stmeshTestHelper: unsupported image extension: " << path << '\n';
    return 1;
  }
  if (!written || VTKErrorHappened)
  {
    std::cerr << "stmeshTestHelper: cannot write " << path << '\n';
    return 1;
  }
  return 0;
}
} // namespace

int main(int argc, char* argv[])
{
  if ((argc == 3 || (argc == 4 && std::strcmp(argv[3], "geometry") == 0)) &&
    std::strcmp(argv[1], "readback") == 0)
  {
    return ReadBack(argv[2], argc == 4);
  }
  if ((argc == 4 || argc == 5) && std::strcmp(argv[1], "make-image") == 0)
  {
    return MakeImage(argv[2], argv[3], argc == 5 ? argv[4] : "plain");
  }
  std::cerr << "usage: stmeshTestHelper readback MESH.vtu|MESH.vtk [geometry]\n"
               "       stmeshTestHelper make-image IMAGE.(vti|mha|mhd|nii|nii.gz|nrrd) "
               "uint8|int16|float [2d|sizing]\n";
  return 1;
}
