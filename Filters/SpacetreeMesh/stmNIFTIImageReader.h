// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmNIFTIImageReader
 * @brief   VTK's NIfTI reader, refusing the corrupt headers it would crash on
 *
 * vtkNIFTIImageReader as it is, except that RequestInformation first reads the header itself
 * and reports an error (and produces nothing) where the header's datatype is not a NIfTI type,
 * its bitpix does not match the datatype, or dim[0] is outside 1 to 7: ParaView 5.11's reader
 * indexes a table with the datatype without a bound and takes the process down with it (found
 * by stmesh's reader fuzzing, docs/reliability.md), which in the GUI loses the user's session.
 * The plugin's "NIfTI Reader (SpacetreeMesh)" is this class; stmesh makes the same check
 * (stmNIFTIHeader.h) before it reads.
 *
 * @sa vtkNIFTIImageReader stmImageToSpacetree
 */

#ifndef stmNIFTIImageReader_h
#define stmNIFTIImageReader_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkNIFTIImageReader.h"

class SPACETREEMESHFILTERS_EXPORT stmNIFTIImageReader : public vtkNIFTIImageReader
{
public:
  static stmNIFTIImageReader* New();
  vtkTypeMacro(stmNIFTIImageReader, vtkNIFTIImageReader);
  void PrintSelf(ostream& os, vtkIndent indent) override;

protected:
  stmNIFTIImageReader() = default;
  ~stmNIFTIImageReader() override = default;

  int RequestInformation(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

private:
  stmNIFTIImageReader(const stmNIFTIImageReader&) = delete;
  void operator=(const stmNIFTIImageReader&) = delete;
};

#endif
