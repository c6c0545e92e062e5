// SPDX-License-Identifier: BSD-3-Clause
#include "stmMeshWriter.h"

#include "stmMeshExport.h"

#include "vtkErrorCode.h"
#include "vtkInformation.h"
#include "vtkUnstructuredGrid.h"

int stmMeshWriter::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkUnstructuredGrid");
  return 1;
}

void stmMeshWriter::WriteData()
{
  std::string error;
  if (!stmMeshExport::Write(this, vtkUnstructuredGrid::SafeDownCast(this->GetInput()),
        this->FileName, static_cast<stmMeshExport::Format>(this->GetExportFormat()),
        this->MaterialArrayName, error))
  {
    vtkErrorMacro(<< "writing '" << this->FileName << "' failed: " << error);
    this->SetErrorCode(vtkErrorCode::UnknownError);
  }
}

void stmMeshWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "FileName: " << this->FileName << "\n";
  os << indent << "MaterialArrayName: " << this->MaterialArrayName << "\n";
}
