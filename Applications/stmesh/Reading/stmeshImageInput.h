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

class vtkAlgorithm;
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

/// An image that the ranks of a run under MPI read in pieces: the reader, set up and checked
/// as ReadImage does, stays in the pipeline, so that the spacetree filter asks it for each
/// rank's extent only. Sample: the image's first voxel or two along each axis, read to check
/// the values (one per voxel, their type, point or cell labels) and to find the arrays.
struct ImageSource
{
  vtkSmartPointer<vtkAlgorithm> Reader;
  vtkSmartPointer<vtkImageData> Sample;
};

/// Opens an image for reading in pieces; info describes the whole image, seconds is the
/// sample's read time. Fails as ReadImage does on a file that is not a readable image.
ImageSource OpenImage(const std::string& path, ImageRole role, ImageInfo& info, double& seconds);

/// After the reader produced a piece: it has one value per voxel (a truncated file may not).
/// Returns its number of voxels.
long long CheckImagePiece(
  const ImageSource& source, const ImageInfo& info, const std::string& path);

/// The scalar array ReadImage found: the point scalars, else the cell scalars.
vtkDataArray* ImageValues(vtkImageData* image, const ImageInfo& info);

} // namespace stmesh

#endif
