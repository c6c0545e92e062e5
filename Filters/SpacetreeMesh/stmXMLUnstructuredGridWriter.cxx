// SPDX-License-Identifier: BSD-3-Clause
#include "stmXMLUnstructuredGridWriter.h"

#include "stmThreadedXMLWriter.txx"

#include "vtkObjectFactory.h"

template class stmThreadedXMLWriter<vtkXMLUnstructuredGridWriter>;

vtkStandardNewMacro(stmXMLUnstructuredGridWriter);

void stmXMLUnstructuredGridWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "ThreadedArrays: " << this->GetThreadedArrays() << "\n";
}
