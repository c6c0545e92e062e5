// SPDX-License-Identifier: BSD-3-Clause
#include "stmFEBioWriter.h"

#include "stmMeshExport.h"

#include "vtkObjectFactory.h"

vtkStandardNewMacro(stmFEBioWriter);

int stmFEBioWriter::GetExportFormat()
{
  return static_cast<int>(stmMeshExport::Format::FEBio);
}

void stmFEBioWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
}
