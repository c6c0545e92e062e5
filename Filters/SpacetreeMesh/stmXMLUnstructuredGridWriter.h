// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmXMLUnstructuredGridWriter
 * @brief   writes a .vtu file as vtkXMLUnstructuredGridWriter does, byte for byte, compressing and
 * encoding the arrays on all threads
 *
 * vtkXMLUnstructuredGridWriter of VTK 9.2 compresses and base64-encodes every array on one thread,
 * which makes writing a mesh of millions of cells take longer than meshing it.
 * stmXMLUnstructuredGridWriter writes the same file byte for byte (same settings, same format,
 * readable by every VTK and ParaView) but, in inline binary mode, compresses the blocks of each
 * array and encodes them on all of vtkSMPTools' threads. Appended and ASCII modes, string arrays,
 * byte swapping, 32-bit ids from 64-bit ones and compressors other than VTK's own take
 * vtkXMLUnstructuredGridWriter's path unchanged.
 *
 * @sa stmXMLPolyDataWriter, stmXMLPUnstructuredGridWriter
 */

#ifndef stmXMLUnstructuredGridWriter_h
#define stmXMLUnstructuredGridWriter_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "stmThreadedXMLWriter.h"       // for the threaded array writing
#include "vtkXMLUnstructuredGridWriter.h"

// The wrappers see VTK's writer as the base: they cannot wrap the template.
class SPACETREEMESHFILTERS_EXPORT stmXMLUnstructuredGridWriter
#ifndef __VTK_WRAP__
  : public stmThreadedXMLWriter<vtkXMLUnstructuredGridWriter>
#else
  : public vtkXMLUnstructuredGridWriter
#endif
{
public:
  static stmXMLUnstructuredGridWriter* New();
  vtkTypeMacro(stmXMLUnstructuredGridWriter, vtkXMLUnstructuredGridWriter);
  void PrintSelf(ostream& os, vtkIndent indent) override;

protected:
  stmXMLUnstructuredGridWriter() = default;
  ~stmXMLUnstructuredGridWriter() override = default;

private:
  stmXMLUnstructuredGridWriter(const stmXMLUnstructuredGridWriter&) = delete;
  void operator=(const stmXMLUnstructuredGridWriter&) = delete;
};

#endif
