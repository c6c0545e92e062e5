// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmFEBioWriter
 * @brief   writes a mesh as an FEBio 4.0 model (.feb) with one solid domain per material
 *
 * stmFEBioWriter writes an FEBio input file, format 4.0: the nodes, one Elements part per
 * material and cell type (tet4, pyra5, penta6, hex8) named after the material (see
 * stmMeshWriter), one SolidDomain per part, and one placeholder material per material
 * (neo-Hookean, E = 1, v = 0.3, density 1), which FEBio needs to read the model: replace them
 * with the tissues' models in FEBio Studio or in the file. Solids only.
 *
 * @sa stmMeshWriter
 */

#ifndef stmFEBioWriter_h
#define stmFEBioWriter_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "stmMeshWriter.h"

class SPACETREEMESHFILTERS_EXPORT stmFEBioWriter : public stmMeshWriter
{
public:
  static stmFEBioWriter* New();
  vtkTypeMacro(stmFEBioWriter, stmMeshWriter);
  void PrintSelf(ostream& os, vtkIndent indent) override;

protected:
  stmFEBioWriter() = default;
  ~stmFEBioWriter() override = default;

  int GetExportFormat() override;

private:
  stmFEBioWriter(const stmFEBioWriter&) = delete;
  void operator=(const stmFEBioWriter&) = delete;
};

#endif
