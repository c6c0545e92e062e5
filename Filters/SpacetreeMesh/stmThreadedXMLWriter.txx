// SPDX-License-Identifier: BSD-3-Clause
// The member functions of stmThreadedXMLWriter, included by the writers that instantiate it.

#include "stmThreadedXMLWriter.h"

#include "stmXMLArrayEncoder.h"

#include "vtkAbstractArray.h"
#include "vtkInformation.h"

template <class VTKWriter>
int stmThreadedXMLWriter<VTKWriter>::WriteInternal()
{
  this->ThreadedArrays = 0;
  return this->VTKWriter::WriteInternal();
}

template <class VTKWriter>
void stmThreadedXMLWriter<VTKWriter>::WriteArrayInline(
  vtkAbstractArray* array, vtkIndent indent, const char* alternateName, int writeNumTuples)
{
  // vtkXMLWriter::WriteArrayInline, with the range computed on all threads (and cached in
  // the array's information as GetRange does, which the writer writes after the data).
  double range[2];
  if (!stmXMLArrayEncoder::ComputeRange(array, range))
  {
    this->VTKWriter::WriteArrayInline(array, indent, alternateName, writeNumTuples);
    return;
  }
  this->WriteArrayHeader(array, indent, alternateName, writeNumTuples, 0);
  this->WriteScalarAttribute("RangeMin", range[0]);
  this->WriteScalarAttribute("RangeMax", range[1]);
  *this->Stream << ">\n";
  this->WriteInlineData(array, indent.GetNextIndent());
  if (array->HasInformation() && array->GetInformation()->GetNumberOfKeys() > 0)
  {
    this->WriteInformation(array->GetInformation(), indent);
  }
  this->WriteArrayFooter(*this->Stream, indent, array, 0);
}

template <class VTKWriter>
void stmThreadedXMLWriter<VTKWriter>::WriteInlineData(vtkAbstractArray* array, vtkIndent indent)
{
  const stmXMLArrayEncoder::Outcome outcome = stmXMLArrayEncoder::WriteInline(this, *this->Stream,
    array, indent, [this](double fraction) { this->SetProgressPartial(fraction); });
  if (!outcome.Handled)
  {
    this->VTKWriter::WriteInlineData(array, indent);
  }
  else
  {
    ++this->ThreadedArrays;
    if (outcome.ErrorCode != 0)
    {
      this->SetErrorCode(outcome.ErrorCode);
    }
  }
}
