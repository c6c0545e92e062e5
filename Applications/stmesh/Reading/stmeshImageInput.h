// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmeshImageInput_h
#define stmeshImageInput_h

// stmesh's image input: the formats it reads (by extension), the checks before reading (the
// file is there, the header's voxels fit in memory) and the reading itself with VTK's readers,
// whose every error, warning and stray message fails the read with a Failure (stmeshErrors.h).
// Separate from the command line so that Testing/Fuzz/FuzzImageReading.cxx feeds it corrupt
// files.

#include "vtkSmartPointer.h"

#include <string>
#include <vector>

class vtkDataArray;
class vtkImageData;

namespace stmesh
{

enum class ImageFormat
{
  NIfTI,
  MetaImage,
  NRRD,
  VTKImage
};

struct ImageFormatInfo
{
  const char* Extension;
  ImageFormat Format;
};

/// ".nii, .nii.gz, .mha, .mhd, .nrrd, .nhdr, .vti", for messages.
extern const char* const SupportedInputExtensions;

/// The format of a file name's extension (case-insensitive), or null.
const ImageFormatInfo* FindImageFormat(const std::string& path);

const char* ImageFormatName(ImageFormat format);

/// What an image read by ReadImage holds.
struct ImageInfo
{
  int Dimensions[3] = { 0, 0, 0 };
  double Spacing[3] = { 0.0, 0.0, 0.0 };
  std::string ScalarType;
  std::string Format;
  bool CellLabels = false;              // labels are cell data (else point data)
  int VoxelDimensions[3] = { 0, 0, 0 }; // one voxel per point, or per cell
  std::vector<int> SpannedAxes;         // the axes with more than one voxel
};

/// Which image is read: the label image (point or cell scalars) or the gray image of
/// --separating gray (point scalars); the messages name it.
enum class ImageRole
{
  Labels,
  Gray
};

/// The image file is there, readable and not empty, with a supported extension.
void CheckReadableFile(const std::string& path, ImageRole role = ImageRole::Labels);

/// The memory this machine can still give (MemAvailable), or its physical memory where
/// /proc/meminfo is missing; 0 when neither is known.
double AvailableMemoryBytes();

/// "1.5 GiB".
std::string GiB(double bytes);

/// Reads an image with the VTK reader of its format, after CheckReadableFile and a check that
/// the voxels the header promises fit in memory. The image has one scalar value per voxel, as
/// many values as voxels; anything else throws a Failure naming the file. Seconds: the time
/// the reader took. The returned copy no longer depends on the reader.
vtkSmartPointer<vtkImageData> ReadImage(
  const std::string& path, ImageRole role, ImageInfo& info, double& seconds);

/// The scalar array ReadImage found: the point scalars, else the cell scalars.
vtkDataArray* ImageValues(vtkImageData* image, const ImageInfo& info);

} // namespace stmesh

#endif
