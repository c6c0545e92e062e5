// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmXMLPUnstructuredGridWriter
 * @brief   writes a .pvtu file and its pieces as vtkXMLPUnstructuredGridWriter does, each piece
 * through stmXMLUnstructuredGridWriter
 *
 * The same files byte for byte as vtkXMLPUnstructuredGridWriter's; only the pieces' arrays are
 * compressed and encoded on all threads (see stmXMLUnstructuredGridWriter).
 *
 * @sa stmXMLUnstructuredGridWriter
 */

#ifndef stmXMLPUnstructuredGridWriter_h
#define stmXMLPUnstructuredGridWriter_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkXMLPUnstructuredGridWriter.h"

class SPACETREEMESHFILTERS_EXPORT stmXMLPUnstructuredGridWriter
  : public vtkXMLPUnstructuredGridWriter
{
public:
  static stmXMLPUnstructuredGridWriter* New();
  vtkTypeMacro(stmXMLPUnstructuredGridWriter, vtkXMLPUnstructuredGridWriter);
  void PrintSelf(ostream& os, vtkIndent indent) override;

protected:
  stmXMLPUnstructuredGridWriter() = default;
  ~stmXMLPUnstructuredGridWriter() override = default;

  vtkXMLUnstructuredDataWriter* CreateUnstructuredPieceWriter() override;

private:
  stmXMLPUnstructuredGridWriter(const stmXMLPUnstructuredGridWriter&) = delete;
  void operator=(const stmXMLPUnstructuredGridWriter&) = delete;
};

#endif
