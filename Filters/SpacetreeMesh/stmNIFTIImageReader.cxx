// SPDX-License-Identifier: BSD-3-Clause
#include "stmNIFTIImageReader.h"

#include "stmNIFTIHeader.h"

#include "vtkObjectFactory.h"

vtkStandardNewMacro(stmNIFTIImageReader);

//------------------------------------------------------------------------------
void stmNIFTIImageReader::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
}

//------------------------------------------------------------------------------
int stmNIFTIImageReader::RequestInformation(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  const char* fileName = this->GetFileName();
  if (fileName)
  {
    const std::string problem = stm::NIFTIHeaderProblem(fileName);
    if (!problem.empty())
    {
      vtkErrorMacro(<< "'" << fileName << "': " << problem);
      return 0;
    }
  }
  return this->Superclass::RequestInformation(request, inputVector, outputVector);
}
