// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmXMLPolyDataWriter
 * @brief   writes a .vtp file as vtkXMLPolyDataWriter does, byte for byte, compressing and encoding
 * the arrays on all threads
 *
 * vtkXMLPolyDataWriter of VTK 9.2 compresses and base64-encodes every array on one thread, which
 * makes writing a mesh of millions of cells take longer than meshing it. stmXMLPolyDataWriter
 * writes the same file byte for byte (same settings, same format, readable by every VTK and
 * ParaView) but, in inline binary mode, compresses the blocks of each array and encodes them on all
 * of vtkSMPTools' threads. Appended and ASCII modes, string arrays, byte swapping, 32-bit ids from
 * 64-bit ones and compressors other than VTK's own take vtkXMLPolyDataWriter's path unchanged.
 *
 * @sa stmXMLUnstructuredGridWriter
 */

#ifndef stmXMLPolyDataWriter_h
#define stmXMLPolyDataWriter_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "stmThreadedXMLWriter.h"       // for the threaded array writing
#include "vtkXMLPolyDataWriter.h"

// The wrappers see VTK's writer as the base: they cannot wrap the template.
class SPACETREEMESHFILTERS_EXPORT stmXMLPolyDataWriter
#ifndef __VTK_WRAP__
  : public stmThreadedXMLWriter<vtkXMLPolyDataWriter>
#else
  : public vtkXMLPolyDataWriter
#endif
{
public:
  static stmXMLPolyDataWriter* New();
  vtkTypeMacro(stmXMLPolyDataWriter, vtkXMLPolyDataWriter);
  void PrintSelf(ostream& os, vtkIndent indent) override;

protected:
  stmXMLPolyDataWriter() = default;
  ~stmXMLPolyDataWriter() override = default;

private:
  stmXMLPolyDataWriter(const stmXMLPolyDataWriter&) = delete;
  void operator=(const stmXMLPolyDataWriter&) = delete;
};

#endif
