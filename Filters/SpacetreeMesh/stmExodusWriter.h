// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmExodusWriter
 * @brief   writes a mesh as an Exodus II file (.exo) with one element block per material
 *
 * stmExodusWriter writes Exodus II through the Exodus library that VTK bundles, so that Sierra,
 * MOOSE, Cubit, ParaView and every Exodus reader see the materials as element blocks: one block
 * per material and cell type (an Exodus block holds one element type: TETRA, PYRAMID, WEDGE,
 * HEX8). A material's first block has the material's tag as its id (see stmMeshWriter) and the
 * material's name; a material of several cell types (a hybrid mesh) gets further blocks with
 * ids after the largest tag, and all its blocks are named "<name>_<type>" (tet4, pyra5, penta6,
 * hex8), as FEBio's parts are. The nodes are the points in order (one node set shared by all
 * blocks); the element id map gives the VTK cell id + 1 of each element. The file is the
 * netCDF-4 (HDF5) flavour of Exodus II, which SEACAS, ParaView, Cubit and MOOSE read. Figures on
 * the AAL atlas's 116 materials (5.2 million tetrahedra): 1.2 s; VTK's own vtkExodusIIWriter took
 * 30 s (most of it per block) and cannot name blocks, and the classic netCDF flavour 14 s
 * (its I/O layer writes a block's arrays in small pieces). Solids only.
 *
 * @sa stmMeshWriter vtkExodusIIReader
 */

#ifndef stmExodusWriter_h
#define stmExodusWriter_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "stmMeshWriter.h"

class SPACETREEMESHFILTERS_EXPORT stmExodusWriter : public stmMeshWriter
{
public:
  static stmExodusWriter* New();
  vtkTypeMacro(stmExodusWriter, stmMeshWriter);
  void PrintSelf(ostream& os, vtkIndent indent) override;

protected:
  stmExodusWriter() = default;
  ~stmExodusWriter() override = default;

  int GetExportFormat() override;

private:
  stmExodusWriter(const stmExodusWriter&) = delete;
  void operator=(const stmExodusWriter&) = delete;
};

#endif
