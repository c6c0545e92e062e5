// SPDX-License-Identifier: BSD-3-Clause
#include "stmXMLPolyDataWriter.h"

#include "stmThreadedXMLWriter.txx"

#include "vtkObjectFactory.h"

template class stmThreadedXMLWriter<vtkXMLPolyDataWriter>;

vtkStandardNewMacro(stmXMLPolyDataWriter);

void stmXMLPolyDataWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "ThreadedArrays: " << this->GetThreadedArrays() << "\n";
}
