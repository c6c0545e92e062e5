// SPDX-License-Identifier: BSD-3-Clause
#include "stmMeditWriter.h"

#include "stmMeshExport.h"

#include "vtkObjectFactory.h"

vtkStandardNewMacro(stmMeditWriter);

int stmMeditWriter::GetExportFormat()
{
  return static_cast<int>(stmMeshExport::Format::Medit);
}

void stmMeditWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
}
