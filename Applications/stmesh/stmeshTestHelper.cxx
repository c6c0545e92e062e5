// SPDX-License-Identifier: BSD-3-Clause
/**
 * stmeshTestHelper: test support for the stmesh command-line tests (TestStmesh.py).
 *
 *   stmeshTestHelper readback MESH.vtu|MESH.vtk
 *     reads a mesh written by stmesh and prints one JSON object: cell and point counts, the
 *     distinct cell types, the cell array names and the cells per value of "Material".
 *   stmeshTestHelper make-image IMAGE TYPE
 *     writes a small 3D label image (labels 0, 1, 2, 7) with scalar TYPE uint8, int16 or float,
 *     as .vti, .mha, .mhd, .nii, .nii.gz or .nrrd (chosen by extension, case-insensitive).
 *
 * Exit code 0 on success, 1 on any error (also any VTK error), with a message on stderr.
 */

#include "vtkCallbackCommand.h"
#include "vtkCellData.h"
#include "vtkCommand.h"
#include "vtkDataArray.h"
#include "vtkImageData.h"
#include "vtkMetaImageWriter.h"
#include "vtkNIFTIImageWriter.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkUnstructuredGrid.h"
#include "vtkUnstructuredGridReader.h"
#include "vtkXMLImageDataWriter.h"
#include "vtkXMLUnstructuredGridReader.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <fstream>
#include <iostream>
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

int ReadBack(const std::string& path)
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
  if (vtkDataArray* materials = grid->GetCellData()->GetArray("Material"))
  {
    for (vtkIdType cell = 0; cell < materials->GetNumberOfTuples(); ++cell)
    {
      ++materialCounts[static_cast<long long>(materials->GetTuple1(cell))];
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
  std::cout << "}}\n";
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

int MakeImage(const std::string& path, const std::string& typeName)
{
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
  image->SetDimensions(20, 18, 16);
  image->AllocateScalars(scalarType, 1);
  vtkDataArray* scalars = image->GetPointData()->GetScalars();
  scalars->SetName("labels");
  vtkIdType index = 0;
  for (int k = 0; k < 16; ++k)
  {
    for (int j = 0; j < 18; ++j)
    {
      for (int i = 0; i < 20; ++i)
      {
        // A float image gets fractional values, as a gray-value image would.
        const double value = TestLabel(i, j, k) + (scalarType == VTK_FLOAT ? 0.25 : 0.0);
        scalars->SetTuple1(index++, value);
      }
    }
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
  if (argc == 3 && std::strcmp(argv[1], "readback") == 0)
  {
    return ReadBack(argv[2]);
  }
  if (argc == 4 && std::strcmp(argv[1], "make-image") == 0)
  {
    return MakeImage(argv[2], argv[3]);
  }
  std::cerr << "usage: stmeshTestHelper readback MESH.vtu|MESH.vtk\n"
               "       stmeshTestHelper make-image IMAGE.(vti|mha|mhd|nii|nii.gz|nrrd) "
               "uint8|int16|float\n";
  return 1;
}
