// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmThreadedXMLWriter
 * @brief   what stmXMLUnstructuredGridWriter and stmXMLPolyDataWriter add to the VTK XML writer
 * they extend: each array's range, compression and encoding on all threads
 *
 * The member functions are defined in stmThreadedXMLWriter.txx and instantiated for the two
 * writers only, in the library.
 *
 * @sa stmXMLUnstructuredGridWriter, stmXMLPolyDataWriter
 */

#ifndef stmThreadedXMLWriter_h
#define stmThreadedXMLWriter_h

#include "vtkIndent.h" // for vtkIndent
#include "vtkType.h"   // for vtkIdType

class vtkAbstractArray;

template <class VTKWriter>
class stmThreadedXMLWriter : public VTKWriter
{
public:
  /**
   * How many arrays the last Write compressed and encoded on all threads; the others took
   * VTK's own path.
   */
  vtkIdType GetThreadedArrays() const { return this->ThreadedArrays; }

protected:
  stmThreadedXMLWriter() = default;
  ~stmThreadedXMLWriter() override = default;

  int WriteInternal() override;
  void WriteArrayInline(vtkAbstractArray* array, vtkIndent indent, const char* alternateName,
    int writeNumTuples) override;
  void WriteInlineData(vtkAbstractArray* array, vtkIndent indent) override;

private:
  stmThreadedXMLWriter(const stmThreadedXMLWriter&) = delete;
  void operator=(const stmThreadedXMLWriter&) = delete;

  vtkIdType ThreadedArrays = 0;
};

#endif
