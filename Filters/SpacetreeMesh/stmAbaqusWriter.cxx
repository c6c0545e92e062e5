// SPDX-License-Identifier: BSD-3-Clause
#include "stmAbaqusWriter.h"

#include "stmMeshExport.h"

#include "vtkObjectFactory.h"

vtkStandardNewMacro(stmAbaqusWriter);

int stmAbaqusWriter::GetExportFormat()
{
  return static_cast<int>(stmMeshExport::Format::Abaqus);
}

void stmAbaqusWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
}
