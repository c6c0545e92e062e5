// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   the shared part of the finite-element writers (private to the module)
 *
 * Views a vtkUnstructuredGrid as the core's ExportMesh (its points as doubles, its cell array's
 * 32- or 64-bit offsets and connectivity, its cell types as shapes, no copy except of points
 * that are not doubles and of the material array as 64-bit labels), checks it, and writes it in
 * a format of Filters/Core/Export through a temporary file beside the target that is renamed
 * onto it only when everything was written: a failed or aborted write leaves no partial file
 * and keeps an older file of that name.
 *
 * The groups' names come from the label table in the mesh's field data (stmLabelTable).
 */

#ifndef stmMeshExport_h
#define stmMeshExport_h

#include "Export/MeshExport.h"

#include <string>
#include <vector>

class vtkAlgorithm;
class vtkUnstructuredGrid;

namespace stmMeshExport
{
enum class Format
{
  GmshAscii,
  GmshBinary,
  Medit,
  Abaqus,
  FEBio,
  Exodus // through the Exodus library VTK bundles
};

/// Writes `input` to `fileName`; false with a message. `writer` gets the progress and is asked
/// whether to abort. materialArray: the cell array of the labels (integers); an absent array
/// makes every cell one group, label 1.
bool Write(vtkAlgorithm* writer, vtkUnstructuredGrid* input, const std::string& fileName,
  Format format, const std::string& materialArray, std::string& error);
}

#endif
