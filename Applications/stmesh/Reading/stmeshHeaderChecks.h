// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmeshHeaderChecks_h
#define stmeshHeaderChecks_h

// Checks of image headers that stmesh makes before VTK's readers see the file. ParaView 5.11's
// readers crash, hang, overflow their buffers or misread silently on headers that bend their
// formats (each case found by Testing/Fuzz/FuzzImageReading.cxx and listed in
// docs/reliability.md), so the headers are held to what those readers read correctly. Each
// check throws a Failure (stmeshErrors.h) whose message starts with `context` and names the
// field at fault.

#include <string>

namespace stmesh
{

/// NIfTI-1 or NIfTI-2 (either byte order, .nii or .nii.gz): a datatype NIfTI defines, the
/// bitpix of that datatype, dim[0] from 1 to 7. A file that is neither is left to VTK.
void CheckNiftiHeader(const std::string& path, const std::string& context);

/// MetaImage: NDims from 1 to 3, and the voxels in the file or in one readable data file.
void CheckMetaImageHeader(const std::string& path, const std::string& context);

/// NRRD: the magic line, known fields written "field: value" once each (comments and
/// "key:=value" pairs aside) up to a blank line, dimension 3 or 4 before the per-axis fields,
/// as many sizes, spacings and space directions as axes, a first axis VTK does not take for
/// the components of a 2D image, file patterns VTK can expand, a readable data file, and
/// ASCII data that holds a number for every voxel.
void CheckNrrdHeader(const std::string& path, const std::string& context);

} // namespace stmesh

#endif
