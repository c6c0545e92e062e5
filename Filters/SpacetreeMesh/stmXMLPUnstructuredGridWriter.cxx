// SPDX-License-Identifier: BSD-3-Clause
#include "stmXMLPUnstructuredGridWriter.h"

#include "stmXMLUnstructuredGridWriter.h"

#include "vtkObjectFactory.h"

vtkStandardNewMacro(stmXMLPUnstructuredGridWriter);

void stmXMLPUnstructuredGridWriter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
}

vtkXMLUnstructuredDataWriter* stmXMLPUnstructuredGridWriter::CreateUnstructuredPieceWriter()
{
  stmXMLUnstructuredGridWriter* pieceWriter = stmXMLUnstructuredGridWriter::New();
  pieceWriter->SetInputConnection(this->GetInputConnection(0, 0));
  return pieceWriter;
}
