// SPDX-License-Identifier: BSD-3-Clause
#include "stmMeshExport.h"

#include "stmCutInput.h"
#include "stmLabelTable.h"
#include "stmSMPExecutor.h"

#include "Export/AbaqusFormat.h"
#include "Export/FEBioFormat.h"
#include "Export/GmshFormat.h"
#include "Export/MeditFormat.h"

#include <limits>
#include <map>

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkErrorCode.h"
#include "vtkFieldData.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkSMPTools.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"
#include "vtk_exodusII.h"

#include <cstdio>
#include <fstream>
#include <unistd.h>

namespace stmMeshExport
{
namespace
{
/// Exodus II (netCDF-4 flavour: the classic one writes in small pieces, 14 s for the AAL atlas)
/// through the Exodus library VTK bundles (VTK's vtkExodusIIWriter took 30 s for the AAL atlas's
/// 116 materials, most of it per block). One element block per material group and
/// shape (an Exodus block holds one element type): a group's first block has the group's tag as
/// its id, its other blocks count on after the largest tag, and all the blocks of a group of
/// several shapes are named "<name>_<type>" (FEBioElementType), others the group's name. Nodes in
/// point order (no node map needed), the element map the cell ids + 1 in block order.
template <class IdType>
stm::Status WriteExodus(
  const stm::ExportMesh<IdType>& mesh, const stm::ExportBlocks& blocks, const std::string& path)
{
  const stm::Status solids = stm::SolidsOnly(blocks, "Exodus", "TETRA, PYRAMID, WEDGE, HEX8");
  if (!solids.IsOk())
  {
    return solids;
  }
  if (mesh.NumberOfPoints >= std::numeric_limits<int>::max() ||
    mesh.NumberOfCells >= std::numeric_limits<int>::max())
  {
    return stm::Status::Invalid("the mesh is too large for the Exodus export's 32-bit ids");
  }
  std::int64_t nextId = 1;
  std::vector<std::string> groupNames;
  for (const stm::MaterialGroup& group : blocks.Groups)
  {
    nextId = std::max(nextId, group.Tag + 1);
    groupNames.push_back(group.Name);
  }
  std::vector<std::string> names = stm::BlockNames(blocks, groupNames);
  int computeWordSize = 8, ioWordSize = 8;
  const int file = ex_create(path.c_str(), EX_CLOBBER | EX_NETCDF4, &computeWordSize, &ioWordSize);
  if (file < 0)
  {
    return stm::Status::Invalid("cannot create the Exodus file");
  }
  bool ok = ex_put_init(file, "SpacetreeMesh", 3, mesh.NumberOfPoints, mesh.NumberOfCells,
              static_cast<std::int64_t>(blocks.Blocks.size()), 0, 0) >= 0;
  // Every block is defined, and named, before any data is written: netCDF moves the data
  // written so far each time a definition is added (the AAL atlas: 14 s against 1 s).
  std::vector<char> groupStarted(blocks.Groups.size(), 0);
  std::vector<std::int64_t> blockIds;
  for (const stm::ExportBlock& block : blocks.Blocks)
  {
    const std::int64_t id = groupStarted[block.Group] ? nextId++ : blocks.Groups[block.Group].Tag;
    groupStarted[block.Group] = 1;
    blockIds.push_back(id);
    const auto shape = static_cast<stm::ElementShape>(block.Shape);
    const char* type = shape == stm::ElementShape::Tetra ? "TETRA"
      : shape == stm::ElementShape::Pyramid              ? "PYRAMID"
      : shape == stm::ElementShape::Wedge                ? "WEDGE"
                                                         : "HEX8";
    ok = ok &&
      ex_put_block(file, EX_ELEM_BLOCK, id, type, block.End - block.Begin,
        stm::ShapeCorners(block.Shape), 0, 0, 0) >= 0;
  }
  std::vector<char*> pointers;
  for (std::string& name : names)
  {
    pointers.push_back(&name[0]);
  }
  ok = ok && (pointers.empty() || ex_put_names(file, EX_ELEM_BLOCK, pointers.data()) >= 0);
  {
    std::vector<double> coordinates[3];
    for (int c = 0; c < 3; ++c)
    {
      coordinates[c].resize(static_cast<std::size_t>(mesh.NumberOfPoints));
    }
    vtkSMPTools::For(0, mesh.NumberOfPoints,
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType p = begin; p < end; ++p)
        {
          for (int c = 0; c < 3; ++c)
          {
            coordinates[c][p] = mesh.Points[3 * p + c];
          }
        }
      });
    ok = ok &&
      ex_put_coord(file, coordinates[0].data(), coordinates[1].data(), coordinates[2].data()) >= 0;
  }
  std::vector<int> elementMap;
  elementMap.reserve(static_cast<std::size_t>(mesh.NumberOfCells));
  for (std::size_t b = 0; b < blocks.Blocks.size(); ++b)
  {
    const stm::ExportBlock& block = blocks.Blocks[b];
    const int corners = stm::ShapeCorners(block.Shape);
    const std::int64_t count = block.End - block.Begin;
    std::vector<int> connectivity(static_cast<std::size_t>(count * corners));
    vtkSMPTools::For(0, count,
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType i = begin; i < end; ++i)
        {
          const std::int64_t cell = blocks.Cells[block.Begin + i];
          const IdType* ids = mesh.Connectivity + mesh.Offsets[cell];
          for (int v = 0; v < corners; ++v)
          {
            connectivity[i * corners + v] =
              static_cast<int>(ids[stm::FiniteElementCorner(block.Shape, v)]) + 1;
          }
        }
      });
    ok = ok &&
      ex_put_conn(file, EX_ELEM_BLOCK, blockIds[b], connectivity.data(), nullptr, nullptr) >= 0;
    for (std::int64_t i = block.Begin; i < block.End; ++i)
    {
      elementMap.push_back(static_cast<int>(blocks.Cells[i] + 1));
    }
  }
  ok = ok && (elementMap.empty() || ex_put_id_map(file, EX_ELEM_MAP, elementMap.data()) >= 0);
  ok = ex_close(file) >= 0 && ok;
  return ok ? stm::Status::Ok()
            : stm::Status::Invalid("the Exodus library failed to write the file (disk full?)");
}

template <class IdType>
bool WriteTyped(stmSMPExecutor& executor, const stm::ExportMesh<IdType>& mesh,
  const std::vector<stm::MaterialName>& names, const std::string& path, Format format,
  std::string& error)
{
  stm::ExportBlocks blocks;
  stm::Status status = stm::MakeExportBlocks(mesh, names, blocks);
  if (!status.IsOk())
  {
    error = status.GetMessage();
    return false;
  }
  // A temporary file beside the target (the same file system, so the rename is atomic).
  const std::string temporary = path + ".tmp-" + std::to_string(::getpid());
  if (format == Format::Exodus)
  {
    status = WriteExodus(mesh, blocks, temporary);
  }
  else
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out)
    {
      error = "cannot open '" + temporary + "' for writing";
      return false;
    }
    switch (format) // Exodus is written above
    {
      case Format::GmshAscii:
      case Format::GmshBinary:
        status = stm::WriteGmsh(out, mesh, blocks, format == Format::GmshBinary, executor);
        break;
      case Format::Medit:
        status = stm::WriteMedit(out, mesh, blocks, executor);
        break;
      case Format::Abaqus:
        status = stm::WriteAbaqus(out, mesh, blocks, executor);
        break;
      case Format::FEBio:
        status = stm::WriteFEBio(out, mesh, blocks, executor);
        break;
      case Format::Exodus:
        break;
    }
    out.close();
    if (status.IsOk() && !out)
    {
      status = stm::Status::Invalid("closing the file failed (disk full?)");
    }
  }
  if (!status.IsOk() || std::rename(temporary.c_str(), path.c_str()) != 0)
  {
    std::remove(temporary.c_str());
    error =
      status.IsOk() ? "cannot rename '" + temporary + "' to '" + path + "'" : status.GetMessage();
    return false;
  }
  return true;
}
}

bool Write(vtkAlgorithm* writer, vtkUnstructuredGrid* input, const std::string& fileName,
  Format format, const std::string& materialArray, std::string& error)
{
  if (!input)
  {
    error = "no input";
    return false;
  }
  if (fileName.empty())
  {
    error = "no file name";
    return false;
  }
  vtkNew<stmLabelTable> table;
  if (!table->ReadFieldData(input->GetFieldData()))
  {
    error = table->GetLastError();
    return false;
  }
  std::vector<stm::MaterialName> names;
  for (int i = 0; i < table->GetNumberOfLabels(); ++i)
  {
    names.push_back({ table->GetLabel(i), table->GetName(i) });
  }
  const vtkIdType points = input->GetNumberOfPoints();
  const vtkIdType cells = input->GetNumberOfCells();
  // Points as doubles: the array itself when it is one (the pipeline's outputs), else a copy.
  vtkSmartPointer<vtkDoubleArray> coordinates;
  if (points > 0)
  {
    coordinates = vtkDoubleArray::FastDownCast(input->GetPoints()->GetData());
    if (!coordinates || coordinates->GetNumberOfComponents() != 3)
    {
      coordinates = vtkSmartPointer<vtkDoubleArray>::New();
      coordinates->SetNumberOfComponents(3);
      coordinates->SetNumberOfTuples(points);
      vtkDataArray* from = input->GetPoints()->GetData();
      vtkSMPTools::For(0, points,
        [&](vtkIdType begin, vtkIdType end)
        {
          double x[3];
          for (vtkIdType p = begin; p < end; ++p)
          {
            from->GetTuple(p, x);
            coordinates->SetTypedTuple(p, x);
          }
        });
    }
  }
  std::vector<std::int64_t> materials;
  if (vtkDataArray* labels = input->GetCellData()->GetArray(materialArray.c_str()))
  {
    if (labels->GetDataType() == VTK_FLOAT || labels->GetDataType() == VTK_DOUBLE ||
      labels->GetNumberOfComponents() != 1)
    {
      error = "the cell array '" + materialArray + "' must hold one integer label per cell";
      return false;
    }
    materials = stmCutInput::CellMaterials(input, materialArray.c_str());
  }
  vtkCellArray* cellArray = input->GetCells();
  vtkUnsignedCharArray* types = input->GetCellTypesArray();
  stmSMPExecutor executor(writer);
  auto fill = [&](auto& mesh, auto* offsets, auto* connectivity)
  {
    mesh.NumberOfPoints = points;
    mesh.Points = coordinates ? coordinates->GetPointer(0) : nullptr;
    mesh.NumberOfCells = cells;
    mesh.Offsets = offsets;
    mesh.Connectivity = connectivity;
    mesh.Shapes = types && cells > 0 ? types->GetPointer(0) : nullptr;
    mesh.Materials = materials.empty() ? nullptr : materials.data();
  };
  if (!cellArray || cells == 0)
  {
    stm::ExportMesh<vtkTypeInt64> mesh;
    fill(
      mesh, static_cast<const vtkTypeInt64*>(nullptr), static_cast<const vtkTypeInt64*>(nullptr));
    return WriteTyped(executor, mesh, names, fileName, format, error);
  }
  if (cellArray->IsStorage64Bit())
  {
    stm::ExportMesh<vtkTypeInt64> mesh;
    fill(mesh, cellArray->GetOffsetsArray64()->GetPointer(0),
      cellArray->GetConnectivityArray64()->GetPointer(0));
    return WriteTyped(executor, mesh, names, fileName, format, error);
  }
  stm::ExportMesh<vtkTypeInt32> mesh;
  fill(mesh, cellArray->GetOffsetsArray32()->GetPointer(0),
    cellArray->GetConnectivityArray32()->GetPointer(0));
  return WriteTyped(executor, mesh, names, fileName, format, error);
}
}
