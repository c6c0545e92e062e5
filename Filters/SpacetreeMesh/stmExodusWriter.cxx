// SPDX-License-Identifier: BSD-3-Clause
#include "stmExodusWriter.h"

#include "stmMeshExport.h"

#include "vtkObjectFactory.h"

vtkStandardNewMacro(stmExodusWriter);

int stmExodusWriter::GetExportFormat()
{
  return static_cast<int>(stmMeshExport::Format::Exodus);
}

void stmExodusWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
}
