// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmMeditWriter
 * @brief   writes a mesh as a Medit .mesh file whose element references are the materials
 *
 * stmMeditWriter writes Medit's ASCII .mesh format (MeshVersionFormatted 2), which Mmg,
 * TetGen, CGAL, FreeFEM and iso2mesh read. Each element's reference is its material's tag (see
 * stmMeshWriter); comment lines at the top name each reference.
 *
 * @sa stmMeshWriter
 */

#ifndef stmMeditWriter_h
#define stmMeditWriter_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "stmMeshWriter.h"

class SPACETREEMESHFILTERS_EXPORT stmMeditWriter : public stmMeshWriter
{
public:
  static stmMeditWriter* New();
  vtkTypeMacro(stmMeditWriter, stmMeshWriter);
  void PrintSelf(ostream& os, vtkIndent indent) override;

protected:
  stmMeditWriter() = default;
  ~stmMeditWriter() override = default;

  int GetExportFormat() override;

private:
  stmMeditWriter(const stmMeditWriter&) = delete;
  void operator=(const stmMeditWriter&) = delete;
};

#endif
