// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmAbaqusWriter
 * @brief   writes a mesh as an Abaqus input file (.inp): nodes, elements, one element set per
 * material
 *
 * stmAbaqusWriter writes the mesh part of an Abaqus input file: *NODE and one *ELEMENT block
 * per material and cell type with ELSET = the material's name (see stmMeshWriter) as an Abaqus
 * word, unique ignoring case. Tetrahedra are C3D4, wedges C3D6, hexahedra C3D8, and pyramids
 * C3D8 with the apex repeated (Abaqus/Standard has no pyramid). Materials and sections are the
 * model's: assign them per ELSET. Solids only.
 *
 * @sa stmMeshWriter
 */

#ifndef stmAbaqusWriter_h
#define stmAbaqusWriter_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "stmMeshWriter.h"

class SPACETREEMESHFILTERS_EXPORT stmAbaqusWriter : public stmMeshWriter
{
public:
  static stmAbaqusWriter* New();
  vtkTypeMacro(stmAbaqusWriter, stmMeshWriter);
  void PrintSelf(ostream& os, vtkIndent indent) override;

protected:
  stmAbaqusWriter() = default;
  ~stmAbaqusWriter() override = default;

  int GetExportFormat() override;

private:
  stmAbaqusWriter(const stmAbaqusWriter&) = delete;
  void operator=(const stmAbaqusWriter&) = delete;
};

#endif
