// SPDX-License-Identifier: BSD-3-Clause
#include "stmMeshExport.h"

#include "stmLabelTable.h"
#include "stmSMPExecutor.h"

#include "Export/AbaqusFormat.h"
#include "Export/FEBioFormat.h"
#include "Export/GmshFormat.h"
#include "Export/MeditFormat.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkNew.h"
#include "vtkPoints.h"
#include "vtkSMPTools.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <cstdio>
#include <fstream>
#include <unistd.h>

namespace stmMeshExport
{
namespace
{
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
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out)
    {
      error = "cannot open '" + temporary + "' for writing";
      return false;
    }
    switch (format)
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
    materials.resize(static_cast<std::size_t>(cells));
    vtkSMPTools::For(0, cells,
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType c = begin; c < end; ++c)
        {
          materials[c] = static_cast<std::int64_t>(labels->GetComponent(c, 0));
        }
      });
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
