// SPDX-License-Identifier: BSD-3-Clause
#include "stmGmshWriter.h"

#include "stmMeshExport.h"

#include "vtkObjectFactory.h"

vtkStandardNewMacro(stmGmshWriter);

int stmGmshWriter::GetExportFormat()
{
  return static_cast<int>(
    this->Binary ? stmMeshExport::Format::GmshBinary : stmMeshExport::Format::GmshAscii);
}

void stmGmshWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Binary: " << (this->Binary ? "On" : "Off") << "\n";
}
