// SPDX-License-Identifier: BSD-3-Clause
// stmXMLUnstructuredGridWriter, stmXMLPolyDataWriter and stmXMLPUnstructuredGridWriter write
// the same bytes as VTK's writers for every setting (compressors, header types, block sizes,
// byte orders, id types, data modes) and every kind of array, including the ones they leave to
// VTK's path; and what they write reads back.

#include "stmXMLPUnstructuredGridWriter.h"
#include "stmXMLPolyDataWriter.h"
#include "stmXMLUnstructuredGridWriter.h"

#include "vtkBitArray.h"
#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkFloatArray.h"
#include "vtkIdTypeArray.h"
#include "vtkInformation.h"
#include "vtkInformationStringKey.h"
#include "vtkIntArray.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkSOADataArrayTemplate.h"
#include "vtkStringArray.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"
#include "vtkXMLPUnstructuredGridWriter.h"
#include "vtkXMLPolyDataWriter.h"
#include "vtkXMLUnstructuredGridReader.h"
#include "vtkXMLUnstructuredGridWriter.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

namespace
{
/// Points with random coordinates (incompressible), tetrahedra over them, and arrays of every
/// kind: random and constant values, several types and component counts, an empty field array,
/// a string array and a bit array (VTK's own path), a structure-of-arrays one (also VTK's).
template <class Mesh>
void FillMesh(Mesh* mesh, vtkIdType pointCount)
{
  std::mt19937 random(42);
  std::uniform_real_distribution<double> coordinate(-1.0, 1.0);
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(pointCount);
  for (vtkIdType point = 0; point < pointCount; ++point)
  {
    points->SetPoint(point, coordinate(random), coordinate(random), coordinate(random));
  }
  mesh->SetPoints(points);

  vtkNew<vtkFloatArray> vectors;
  vectors->SetName("Vectors");
  vectors->SetNumberOfComponents(3);
  vectors->SetNumberOfTuples(pointCount);
  vtkNew<vtkIntArray> constant;
  constant->SetName("Constant");
  constant->SetNumberOfTuples(pointCount);
  vtkNew<vtkSOADataArrayTemplate<double>> split;
  split->SetName("StructureOfArrays");
  split->SetNumberOfComponents(2);
  split->SetNumberOfTuples(pointCount);
  for (vtkIdType point = 0; point < pointCount; ++point)
  {
    vectors->SetTuple3(point, coordinate(random), coordinate(random), coordinate(random));
    constant->SetValue(point, 7);
    split->SetTuple2(point, coordinate(random), 1.0);
  }
  // Information keys other than VTK's cached ranges: the range is left to VTK (the writer
  // writes the keys after the data), the data are encoded on all threads.
  vtkNew<vtkDoubleArray> temperature;
  temperature->SetName("Temperature");
  temperature->SetNumberOfTuples(pointCount);
  temperature->FillValue(310.15);
  temperature->GetInformation()->Set(vtkDataArray::UNITS_LABEL(), "K");
  mesh->GetPointData()->AddArray(vectors);
  mesh->GetPointData()->AddArray(constant);
  mesh->GetPointData()->AddArray(split);
  mesh->GetPointData()->AddArray(temperature);

  vtkNew<vtkStringArray> names;
  names->SetName("Names");
  names->InsertNextValue("brain");
  names->InsertNextValue("skull, and scalp");
  vtkNew<vtkBitArray> bits;
  bits->SetName("Bits");
  for (int bit = 0; bit < 77; ++bit)
  {
    bits->InsertNextValue(bit % 3 == 0);
  }
  vtkNew<vtkDoubleArray> empty;
  empty->SetName("Empty");
  vtkNew<vtkIdTypeArray> ids;
  ids->SetName("Ids");
  for (vtkIdType id = 0; id < 1001; ++id)
  {
    ids->InsertNextValue(id * id);
  }
  mesh->GetFieldData()->AddArray(names);
  mesh->GetFieldData()->AddArray(bits);
  mesh->GetFieldData()->AddArray(empty);
  mesh->GetFieldData()->AddArray(ids);
}

/// A grid of `cellCount` random tetrahedra with a material per cell.
vtkSmartPointer<vtkUnstructuredGrid> MakeGrid(vtkIdType pointCount, vtkIdType cellCount)
{
  auto grid = vtkSmartPointer<vtkUnstructuredGrid>::New();
  FillMesh(grid.Get(), pointCount);
  std::mt19937 random(7);
  std::uniform_int_distribution<vtkIdType> point(0, pointCount - 1);
  grid->Allocate(cellCount);
  vtkNew<vtkUnsignedCharArray> materials;
  materials->SetName("Material");
  for (vtkIdType cell = 0; cell < cellCount; ++cell)
  {
    const vtkIdType corners[4] = { point(random), point(random), point(random), point(random) };
    grid->InsertNextCell(VTK_TETRA, 4, corners);
    materials->InsertNextValue(static_cast<unsigned char>(cell % 5));
  }
  grid->GetCellData()->AddArray(materials);
  return grid;
}

vtkSmartPointer<vtkPolyData> MakeSurface(vtkIdType pointCount, vtkIdType cellCount)
{
  auto surface = vtkSmartPointer<vtkPolyData>::New();
  FillMesh(surface.Get(), pointCount);
  std::mt19937 random(11);
  std::uniform_int_distribution<vtkIdType> point(0, pointCount - 1);
  vtkNew<vtkCellArray> triangles;
  for (vtkIdType cell = 0; cell < cellCount; ++cell)
  {
    triangles->InsertNextCell({ point(random), point(random), point(random) });
  }
  surface->SetPolys(triangles);
  return surface;
}

struct Settings
{
  int Compressor;
  int HeaderType;
  size_t BlockSize;
  int ByteOrder;
  int IdType;
  int DataMode;
};

std::string Describe(const Settings& settings)
{
  return "compressor " + std::to_string(settings.Compressor) + ", header " +
    std::to_string(settings.HeaderType) + ", block " + std::to_string(settings.BlockSize) +
    ", byte order " + std::to_string(settings.ByteOrder) + ", ids " +
    std::to_string(settings.IdType) + ", mode " + std::to_string(settings.DataMode);
}

/// How many arrays the last write of one of our writers encoded on all threads (0 for VTK's).
vtkIdType ThreadedArraysOf(vtkObject* writer)
{
  if (auto* grid = stmXMLUnstructuredGridWriter::SafeDownCast(writer))
  {
    return grid->GetThreadedArrays();
  }
  if (auto* surface = stmXMLPolyDataWriter::SafeDownCast(writer))
  {
    return surface->GetThreadedArrays();
  }
  return 0;
}

/// Writes the mesh to a string with the given writer class and settings.
template <class Writer>
std::string WriteToString(
  vtkDataObject* mesh, const Settings& settings, vtkIdType* threadedArrays = nullptr)
{
  vtkNew<Writer> writer;
  writer->SetInputData(mesh);
  writer->SetWriteToOutputString(true);
  writer->SetCompressorType(settings.Compressor);
  writer->SetHeaderType(settings.HeaderType);
  writer->SetBlockSize(settings.BlockSize);
  writer->SetByteOrder(settings.ByteOrder);
  writer->SetIdType(settings.IdType);
  writer->SetDataMode(settings.DataMode);
  EXPECT_EQ(writer->Write(), 1) << Describe(settings);
  EXPECT_EQ(writer->GetErrorCode(), 0u) << Describe(settings);
  if (threadedArrays)
  {
    *threadedArrays = ThreadedArraysOf(writer);
  }
  return writer->GetOutputString();
}

/// The arrays the threaded path writes in binary mode: of the grid, the points, the cells'
/// connectivity, offsets and types, the material, three of the four point arrays (not the
/// structure-of-arrays one) and two of the four field arrays (not the strings or the bits); of
/// the surface, the same without cell data and types but with the connectivity and offsets of
/// its four cell arrays (verts, lines, strips, polys). None in the other byte order (even
/// one-byte arrays have swapped headers); with 32-bit ids not the vtkIdType field array.
vtkIdType ExpectedThreadedArrays(const Settings& settings, bool grid)
{
  if (settings.DataMode != vtkXMLWriterBase::Binary)
  {
    return 0;
  }
  if (settings.ByteOrder != vtkXMLWriterBase::LittleEndian)
  {
    return 0;
  }
  const vtkIdType all = grid ? 10 : 14;
  return settings.IdType == vtkXMLWriterBase::Int32 ? all - 1 : all;
}

/// Every compressor, header type and block size (many blocks in several batches, or one block
/// that is not full) in binary mode, and the cases VTK's path keeps.
std::vector<Settings> AllSettings()
{
  std::vector<Settings> all;
  for (int compressor : { vtkXMLWriterBase::NONE, vtkXMLWriterBase::ZLIB, vtkXMLWriterBase::LZ4,
         vtkXMLWriterBase::LZMA })
  {
    for (int header : { vtkXMLWriterBase::UInt32, vtkXMLWriterBase::UInt64 })
    {
      for (size_t blockSize : { size_t{ 4096 }, size_t{ 1 } << 20 })
      {
        all.push_back({ compressor, header, blockSize, vtkXMLWriterBase::LittleEndian,
          vtkXMLWriterBase::Int64, vtkXMLWriterBase::Binary });
      }
    }
    all.push_back({ compressor, vtkXMLWriterBase::UInt64, 4096, vtkXMLWriterBase::BigEndian,
      vtkXMLWriterBase::Int64, vtkXMLWriterBase::Binary });
    all.push_back({ compressor, vtkXMLWriterBase::UInt32, 4096, vtkXMLWriterBase::LittleEndian,
      vtkXMLWriterBase::Int32, vtkXMLWriterBase::Binary });
    all.push_back({ compressor, vtkXMLWriterBase::UInt64, 4096, vtkXMLWriterBase::LittleEndian,
      vtkXMLWriterBase::Int64, vtkXMLWriterBase::Appended });
  }
  all.push_back({ vtkXMLWriterBase::NONE, vtkXMLWriterBase::UInt64, 4096,
    vtkXMLWriterBase::LittleEndian, vtkXMLWriterBase::Int64, vtkXMLWriterBase::Ascii });
  return all;
}
} // namespace

TEST(XMLWriters, UnstructuredGridSameBytesAsVTK)
{
  // 10,000 points of 24 bytes: 240,000 bytes, 59 blocks of 4 KiB (4 batches on 2 threads), or
  // one block of 1 MiB, not full; 20,000 tetrahedra.
  const vtkSmartPointer<vtkUnstructuredGrid> grid = MakeGrid(10000, 20000);
  for (const Settings& settings : AllSettings())
  {
    vtkIdType threaded = -1;
    const std::string ours = WriteToString<stmXMLUnstructuredGridWriter>(grid, settings, &threaded);
    const std::string theirs = WriteToString<vtkXMLUnstructuredGridWriter>(grid, settings);
    EXPECT_EQ(threaded, ExpectedThreadedArrays(settings, true)) << Describe(settings);
    ASSERT_GT(theirs.size(), 30000u) << Describe(settings);
    ASSERT_EQ(ours.size(), theirs.size()) << Describe(settings);
    EXPECT_TRUE(ours == theirs) << Describe(settings);
  }
}

TEST(XMLWriters, PolyDataSameBytesAsVTK)
{
  const vtkSmartPointer<vtkPolyData> surface = MakeSurface(5000, 9001);
  for (const Settings& settings : AllSettings())
  {
    vtkIdType threaded = -1;
    const std::string ours = WriteToString<stmXMLPolyDataWriter>(surface, settings, &threaded);
    const std::string theirs = WriteToString<vtkXMLPolyDataWriter>(surface, settings);
    EXPECT_EQ(threaded, ExpectedThreadedArrays(settings, false)) << Describe(settings);
    ASSERT_EQ(ours.size(), theirs.size()) << Describe(settings);
    EXPECT_TRUE(ours == theirs) << Describe(settings);
  }
}

TEST(XMLWriters, SmallAndEmptyMeshesSameBytesAsVTK)
{
  // Arrays of 0, 1 and 2 values leave 0, 1 or 2 bytes for the padded end of the base64.
  for (vtkIdType count : { 1, 2, 3, 4, 5 })
  {
    const vtkSmartPointer<vtkUnstructuredGrid> grid = MakeGrid(count, count - 1);
    for (const Settings& settings : AllSettings())
    {
      vtkIdType threaded = -1;
      const std::string ours =
        WriteToString<stmXMLUnstructuredGridWriter>(grid, settings, &threaded);
      const std::string theirs = WriteToString<vtkXMLUnstructuredGridWriter>(grid, settings);
      EXPECT_EQ(threaded, ExpectedThreadedArrays(settings, true)) << Describe(settings);
      EXPECT_TRUE(ours == theirs) << count << " points, " << Describe(settings);
    }
  }
  vtkNew<vtkUnstructuredGrid> nothing;
  const Settings lz4{ vtkXMLWriterBase::LZ4, vtkXMLWriterBase::UInt64, 1 << 20,
    vtkXMLWriterBase::LittleEndian, vtkXMLWriterBase::Int64, vtkXMLWriterBase::Binary };
  EXPECT_EQ(WriteToString<stmXMLUnstructuredGridWriter>(nothing, lz4),
    WriteToString<vtkXMLUnstructuredGridWriter>(nothing, lz4));
}

TEST(XMLWriters, ReadsBack)
{
  const vtkSmartPointer<vtkUnstructuredGrid> grid = MakeGrid(30000, 60000);
  const Settings lz4{ vtkXMLWriterBase::LZ4, vtkXMLWriterBase::UInt64, 1 << 20,
    vtkXMLWriterBase::LittleEndian, vtkXMLWriterBase::Int64, vtkXMLWriterBase::Binary };
  const std::string written = WriteToString<stmXMLUnstructuredGridWriter>(grid, lz4);
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetReadFromInputString(true);
  reader->SetInputString(written);
  reader->Update();
  vtkUnstructuredGrid* read = reader->GetOutput();
  ASSERT_EQ(read->GetNumberOfPoints(), 30000);
  ASSERT_EQ(read->GetNumberOfCells(), 60000);
  for (vtkIdType point : { vtkIdType{ 0 }, vtkIdType{ 12345 }, vtkIdType{ 29999 } })
  {
    for (int axis = 0; axis < 3; ++axis)
    {
      EXPECT_EQ(read->GetPoint(point)[axis], grid->GetPoint(point)[axis]);
    }
  }
  vtkNew<vtkIdList> readCorners;
  vtkNew<vtkIdList> corners;
  read->GetCellPoints(59999, readCorners);
  grid->GetCellPoints(59999, corners);
  ASSERT_EQ(readCorners->GetNumberOfIds(), 4);
  for (vtkIdType corner = 0; corner < 4; ++corner)
  {
    EXPECT_EQ(readCorners->GetId(corner), corners->GetId(corner));
  }
  vtkDataArray* materials = read->GetCellData()->GetArray("Material");
  ASSERT_NE(materials, nullptr);
  EXPECT_EQ(materials->GetTuple1(59999), 59999 % 5);
  auto* names = vtkStringArray::SafeDownCast(read->GetFieldData()->GetAbstractArray("Names"));
  ASSERT_NE(names, nullptr);
  EXPECT_EQ(names->GetValue(1), "skull, and scalp");
  vtkDataArray* ids = read->GetFieldData()->GetArray("Ids");
  ASSERT_NE(ids, nullptr);
  EXPECT_EQ(ids->GetTuple1(1000), 1000.0 * 1000.0);
}

TEST(XMLWriters, PiecesSameBytesAsVTK)
{
  const vtkSmartPointer<vtkUnstructuredGrid> grid = MakeGrid(20000, 40000);
  const std::string folder = testing::TempDir();
  auto write = [&](vtkXMLPUnstructuredGridWriter* writer, const std::string& name)
  {
    writer->SetInputData(grid);
    writer->SetFileName((folder + name + ".pvtu").c_str());
    writer->SetDataModeToBinary();
    writer->SetCompressorTypeToLZ4();
    writer->SetNumberOfPieces(2);
    writer->SetStartPiece(0);
    writer->SetEndPiece(1);
    EXPECT_EQ(writer->Write(), 1);
  };
  vtkNew<stmXMLPUnstructuredGridWriter> ours;
  vtkNew<vtkXMLPUnstructuredGridWriter> theirs;
  write(ours, "stm_pieces");
  write(theirs, "vtk_pieces");
  auto contents = [](const std::string& path)
  {
    std::ifstream file(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
  };
  for (int piece = 0; piece < 2; ++piece)
  {
    const std::string suffix = "_" + std::to_string(piece) + ".vtu";
    const std::string mine = contents(folder + "stm_pieces" + suffix);
    const std::string reference = contents(folder + "vtk_pieces" + suffix);
    ASSERT_GT(reference.size(), 10000u) << piece;
    EXPECT_TRUE(mine == reference) << piece;
  }
}
