// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmMeshWriter
 * @brief   the common part of the finite-element writers: the file, the material array, and a
 *          write that leaves no partial file
 *
 * stmGmshWriter, stmMeditWriter, stmAbaqusWriter and stmFEBioWriter write a vtkUnstructuredGrid
 * of linear cells (tetrahedra, pyramids, wedges, hexahedra; triangles and quads for the
 * formats that take them) with one group per material: the integer cell array
 * MaterialArrayName (default "Material"). A label of 1 or more is its group's tag; the labels
 * of 0 or less (the background 0) take the tags after the largest label. A group's name is the
 * label's name in the mesh's label table (stmLabelTable, field data "MaterialNames" and
 * "MaterialNameLabels", as stmesh --label-names sets it), else "Material_<label>". Node numbers
 * are point ids + 1, element numbers cell ids + 1 (where the format numbers elements).
 *
 * The file is written under a temporary name beside it and renamed when complete, so a failed
 * or aborted write leaves no partial file and keeps an older file of that name. Nodes and
 * elements are formatted on vtkSMPTools' threads and written in order: the file does not
 * depend on the number of threads. A mesh a format cannot hold (other cell types, planar cells
 * in Abaqus or FEBio, non-finite points) gets a vtkErrorMacro and no file.
 *
 * @sa stmGmshWriter stmMeditWriter stmAbaqusWriter stmFEBioWriter stmLabelTable
 */

#ifndef stmMeshWriter_h
#define stmMeshWriter_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkWriter.h"

#include <string>

class SPACETREEMESHFILTERS_EXPORT stmMeshWriter : public vtkWriter
{
public:
  vtkTypeMacro(stmMeshWriter, vtkWriter);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * The file to write. No default.
   */
  vtkSetStdStringFromCharMacro(FileName);
  vtkGetCharFromStdStringMacro(FileName);
  ///@}

  ///@{
  /**
   * The integer cell array of the materials. Default "Material" (the pipeline's). Without it,
   * every cell is one material, label 1.
   */
  vtkSetStdStringFromCharMacro(MaterialArrayName);
  vtkGetCharFromStdStringMacro(MaterialArrayName);
  ///@}

protected:
  stmMeshWriter() = default;
  ~stmMeshWriter() override = default;

  /// The format (stmMeshExport::Format) this writer writes.
  virtual int GetExportFormat() = 0;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  void WriteData() override;

private:
  stmMeshWriter(const stmMeshWriter&) = delete;
  void operator=(const stmMeshWriter&) = delete;

  std::string FileName;
  std::string MaterialArrayName = "Material";
};

#endif
