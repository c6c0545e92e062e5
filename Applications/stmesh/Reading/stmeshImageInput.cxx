// SPDX-License-Identifier: BSD-3-Clause
#include "stmeshImageInput.h"

#include "stmeshErrors.h"
#include "stmeshHeaderChecks.h"
#include "stmeshText.h"

#include "vtkAlgorithm.h"
#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDataObject.h"
#include "vtkDataSetAttributes.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkMetaImageReader.h"
#include "vtkNIFTIImageReader.h"
#include "vtkNrrdReader.h"
#include "vtkPointData.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkType.h"
#include "vtkXMLImageDataReader.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <type_traits>

namespace stmesh
{

namespace
{

// Longest extensions first, so that ".nii.gz" wins over any shorter match.
const ImageFormatInfo ImageExtensions[] = { { ".nii.gz", ImageFormat::NIfTI },
  { ".nii", ImageFormat::NIfTI }, { ".mha", ImageFormat::MetaImage },
  { ".mhd", ImageFormat::MetaImage }, { ".nrrd", ImageFormat::NRRD },
  { ".nhdr", ImageFormat::NRRD }, { ".vti", ImageFormat::VTKImage } };

// Deflate (gzip, zlib: .nii.gz, compressed MetaImage, NRRD's gzip encoding) compresses at most
// 1032 to 1, so a file of n bytes holds at most 1032 n bytes of voxels. VTK's XML files may use
// LZMA, which reaches several thousand to 1 on constant data: a generous bound for them.
constexpr double MaximumDeflateRatio = 1032.0;
constexpr double MaximumXMLCompressionRatio = 1e5;

/// "X x Y x Z" of a whole extent, in 64 bits: a corrupt header's extent may span 2^31 voxels
/// (found by FuzzImageReading: the int sum overflowed).
std::string ExtentSizes(const int (&extent)[6])
{
  std::ostringstream text;
  for (int axis = 0; axis < 3; ++axis)
  {
    text << (axis > 0 ? " x " : "")
         << static_cast<long long>(extent[2 * axis + 1]) - extent[2 * axis] + 1;
  }
  return text.str();
}

/// Refuses, before any voxel is read, an image whose header promises more voxels than memory
/// holds, or than the file could hold: VTK's readers allocate the whole image first, and abort
/// the process when that fails (a NIfTI header of 30000^3 voxels), or allocate gigabytes for a
/// corrupt header of a few bytes and only then find the file short. The memory estimate is the
/// image itself plus the spacetree stage's label copy (2 bytes per voxel), the least any run
/// needs. A detached header (.mhd, .nhdr) says nothing about its data file's size.
void CheckImageSize(
  vtkAlgorithm* reader, ImageFormat format, const std::string& path, const std::string& context)
{
  try
  {
    reader->UpdateInformation();
  }
  catch (const std::exception& error)
  {
    throw Failure(context + ": the reader failed on a corrupt header (" + error.what() + ")");
  }
  if (Errors().HasErrors())
  {
    return; // the header's own errors are reported by the update
  }
  vtkInformation* outInfo = reader->GetOutputInformation(0);
  int extent[6] = { 0, -1, 0, -1, 0, -1 };
  if (!outInfo || !outInfo->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()))
  {
    return;
  }
  outInfo->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent);
  double voxels = 1.0;
  for (int axis = 0; axis < 3; ++axis)
  {
    const double size = static_cast<double>(extent[2 * axis + 1]) - extent[2 * axis] + 1.0;
    if (!(size >= 1.0))
    {
      // MetaIO allocates a negative size (std::bad_alloc) where others read nothing.
      std::ostringstream message;
      message << context << ": the header gives axis " << axis << " a size of " << size
              << " (a corrupt header)";
      throw Failure(message.str());
    }
    voxels *= size;
  }
  int scalarType = VTK_DOUBLE;
  int components = 1;
  if (vtkInformation* scalars = vtkDataObject::GetActiveFieldInformation(
        outInfo, vtkDataObject::FIELD_ASSOCIATION_POINTS, vtkDataSetAttributes::SCALARS))
  {
    scalarType = scalars->Has(vtkDataObject::FIELD_ARRAY_TYPE())
      ? scalars->Get(vtkDataObject::FIELD_ARRAY_TYPE())
      : scalarType;
    components = scalars->Has(vtkDataObject::FIELD_NUMBER_OF_COMPONENTS())
      ? std::max(1, scalars->Get(vtkDataObject::FIELD_NUMBER_OF_COMPONENTS()))
      : components;
  }
  const double voxelBytes = voxels * vtkDataArray::GetDataTypeSize(scalarType) * components;
  const double needed = voxels * 2.0 + voxelBytes;
  const double available = AvailableMemoryBytes();
  if (available > 0.0 && needed > available)
  {
    std::ostringstream message;
    message << context << ": the header promises " << ExtentSizes(extent)
            << " voxels; reading and meshing them needs at least " << GiB(needed)
            << ", and this machine has " << GiB(available)
            << " available (crop or downsample the image)";
    throw Failure(message.str());
  }
  const std::string lower = ToLower(path);
  const bool detached = EndsWith(lower, ".mhd") || EndsWith(lower, ".nhdr");
  const double ratio =
    format == ImageFormat::VTKImage ? MaximumXMLCompressionRatio : MaximumDeflateRatio;
  struct stat file;
  if (!detached && stat(path.c_str(), &file) == 0 &&
    voxelBytes > ratio * static_cast<double>(file.st_size))
  {
    std::ostringstream message;
    message << context << ": the header promises " << ExtentSizes(extent) << " voxels ("
            << std::fixed << std::setprecision(0) << voxelBytes << " bytes), more than a file of "
            << file.st_size << " bytes can hold even compressed (corrupt header or truncated file)";
    throw Failure(message.str());
  }
}

/// A MetaImage header is text: "Key = Value" lines, with NDims among them and ElementDataFile
/// last, before the voxels (.mha) or alone (.mhd).
bool LooksLikeMetaImageHeader(const std::string& path)
{
  std::ifstream file(path, std::ios::binary);
  std::string header(8192, '\0');
  file.read(&header[0], static_cast<std::streamsize>(header.size()));
  header.resize(static_cast<std::size_t>(file.gcount()));
  const std::size_t dataFile = header.find("ElementDataFile");
  const std::size_t dimensions = header.find("NDims");
  return dataFile != std::string::npos && dimensions != std::string::npos &&
    dimensions < dataFile && header.find('\0') > dataFile;
}

template <class Reader>
vtkSmartPointer<vtkAlgorithm> CreateCheckedReader(
  const std::string& path, const char* formatName, const std::string& context)
{
  vtkSmartPointer<Reader> reader = vtkSmartPointer<Reader>::New();
  Watch(reader);
  // vtkMetaImageReader::CanReadFile wants a lower-case .mha or .mhd, which stmesh does not.
  const bool canRead = (std::is_same<Reader, vtkMetaImageReader>::value &&
                         !EndsWith(path, ".mha") && !EndsWith(path, ".mhd"))
    ? LooksLikeMetaImageHeader(path)
    : reader->CanReadFile(path.c_str()) != 0;
  if (!canRead)
  {
    std::string details = Errors().HasErrors() ? "\n" + Errors().Take() : std::string();
    throw Failure(context + ": not a valid " + formatName + " file (" + reader->GetClassName() +
      " cannot read it)" + details);
  }
  ThrowIfFailed(context);
  reader->SetFileName(path.c_str());
  return reader;
}

} // namespace

const char* const SupportedInputExtensions = ".nii, .nii.gz, .mha, .mhd, .nrrd, .nhdr, .vti";

const ImageFormatInfo* FindImageFormat(const std::string& path)
{
  const std::string lower = ToLower(FileName(path));
  for (const ImageFormatInfo& info : ImageExtensions)
  {
    if (EndsWith(lower, info.Extension) && lower.size() > std::strlen(info.Extension))
    {
      return &info;
    }
  }
  return nullptr;
}

const char* ImageFormatName(ImageFormat format)
{
  switch (format)
  {
    case ImageFormat::NIfTI:
      return "NIfTI";
    case ImageFormat::MetaImage:
      return "MetaImage";
    case ImageFormat::NRRD:
      return "NRRD";
    case ImageFormat::VTKImage:
      return "VTK XML image";
  }
  return "?";
}

void CheckReadableFile(const std::string& path, ImageRole role)
{
  const bool gray = role == ImageRole::Gray;
  const std::string prefix = gray ? "--separating: " : "";
  const std::string what = gray ? "gray image" : "input";
  if (!FindImageFormat(path))
  {
    throw Failure(prefix + what + " '" + path + "' has an unsupported extension; stmesh reads " +
      SupportedInputExtensions);
  }
  struct stat info;
  if (stat(path.c_str(), &info) != 0)
  {
    throw Failure(prefix + "cannot read " + what + " '" + path + "': " + std::strerror(errno));
  }
  if (S_ISDIR(info.st_mode))
  {
    throw Failure(prefix + what + " '" + path + "' is a directory, not an image file");
  }
  if (access(path.c_str(), R_OK) != 0)
  {
    throw Failure(prefix + "cannot read " + what + " '" + path + "': " + std::strerror(errno));
  }
  if (info.st_size == 0)
  {
    throw Failure(prefix + what + " '" + path + "' is empty");
  }
}

double AvailableMemoryBytes()
{
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  double kibibytes = 0.0;
  std::string unit;
  while (meminfo >> key >> kibibytes >> unit)
  {
    if (key == "MemAvailable:")
    {
      return kibibytes * 1024.0;
    }
  }
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long pageSize = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && pageSize > 0 ? static_cast<double>(pages) * pageSize : 0.0;
}

std::string GiB(double bytes)
{
  std::ostringstream text;
  text << std::fixed << std::setprecision(1) << bytes / (1024.0 * 1024 * 1024) << " GiB";
  return text.str();
}

namespace
{

/// The reader of the file's format, checked and set up, its information updated.
vtkSmartPointer<vtkAlgorithm> CreateImageReader(
  const std::string& path, ImageRole role, ImageInfo& info, const std::string& context)
{
  CheckReadableFile(path, role);
  const ImageFormatInfo* format = FindImageFormat(path);
  vtkSmartPointer<vtkAlgorithm> reader;
  StandardErrorCapture strayMessages;
  switch (format->Format)
  {
    case ImageFormat::NIfTI:
      reader = CreateCheckedReader<vtkNIFTIImageReader>(path, "NIfTI", context);
      CheckNiftiHeader(path, context);
      break;
    case ImageFormat::MetaImage:
      reader = CreateCheckedReader<vtkMetaImageReader>(path, "MetaImage", context);
      CheckMetaImageHeader(path, context);
      break;
    case ImageFormat::NRRD:
      reader = CreateCheckedReader<vtkNrrdReader>(path, "NRRD", context);
      CheckNrrdHeader(path, context);
      break;
    case ImageFormat::VTKImage:
      reader = CreateCheckedReader<vtkXMLImageDataReader>(path, "VTK XML image", context);
      break;
  }
  info.Format = ImageFormatName(format->Format);
  CheckImageSize(reader, format->Format, path, context);
  const std::string strayText = strayMessages.GetText();
  if (!strayText.empty())
  {
    Errors().Record(strayText, false);
  }
  return reader;
}

/// Runs the reader for its whole image (extent null) or for an extent of it, and returns its
/// output; seconds: the time the reader took.
vtkImageData* UpdateImageReader(
  vtkAlgorithm* reader, const int* extent, const std::string& context, double& seconds)
{
  StandardErrorCapture strayMessages;
  const auto start = std::chrono::steady_clock::now();
  try
  {
    if (extent)
    {
      reader->UpdateExtent(extent);
    }
    else
    {
      reader->Update();
    }
  }
  catch (const std::exception& error)
  {
    // MetaIO and the XML parser throw on some corrupt files (std::bad_alloc, std::length_error)
    // where VTK's own code would report an error.
    throw Failure(context + ": the reader failed on a corrupt file (" + error.what() + ")");
  }
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::string strayText = strayMessages.GetText();
  if (!strayText.empty())
  {
    Errors().Record(strayText, false);
  }
  ThrowIfFailed(context);
  vtkImageData* image = vtkImageData::SafeDownCast(reader->GetOutputDataObject(0));
  if (!image || image->GetNumberOfPoints() == 0)
  {
    throw Failure(context + ": the file holds no image data");
  }
  return image;
}

/// Checks that the image (the whole image or a piece of it) has one scalar value per voxel and
/// describes the whole image in info (from the reader's whole extent).
void DescribeImage(vtkAlgorithm* reader, vtkImageData* image, ImageRole role, ImageInfo& info,
  const std::string& context)
{
  const bool labelImage = role == ImageRole::Labels;
  int whole[6];
  reader->GetOutputInformation(0)->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
  for (int axis = 0; axis < 3; ++axis)
  {
    info.Dimensions[axis] = whole[2 * axis + 1] - whole[2 * axis] + 1;
  }
  image->GetSpacing(info.Spacing);
  // The spacetree filter reads the active scalars, point data first; stmSeparatingFunction the
  // active point scalars only.
  vtkDataArray* values = image->GetPointData()->GetScalars();
  vtkIdType expectedValues = image->GetNumberOfPoints();
  if (!values && !labelImage)
  {
    throw Failure(context + ": the gray image has no point scalars (one gray value per voxel)");
  }
  info.CellLabels = false;
  if (!values)
  {
    values = image->GetCellData()->GetScalars();
    expectedValues = image->GetNumberOfCells();
    info.CellLabels = true;
  }
  info.SpannedAxes.clear();
  for (int axis = 0; axis < 3; ++axis)
  {
    info.VoxelDimensions[axis] =
      info.CellLabels ? std::max(1, info.Dimensions[axis] - 1) : info.Dimensions[axis];
    if (info.VoxelDimensions[axis] > 1)
    {
      info.SpannedAxes.push_back(axis);
    }
  }
  if (!values)
  {
    throw Failure(context + ": the image has no scalar (label) array");
  }
  if (values->GetNumberOfTuples() != expectedValues)
  {
    throw Failure(context + ": the image has " + std::to_string(expectedValues) + " voxels but " +
      std::to_string(values->GetNumberOfTuples()) + " values (truncated file?)");
  }
  info.ScalarType = values->GetDataTypeAsString();
  if (values->GetNumberOfComponents() != 1)
  {
    throw Failure(context + ": the image has " + std::to_string(values->GetNumberOfComponents()) +
      " components per voxel; stmesh needs one " + (labelImage ? "integer label" : "gray value") +
      " per voxel");
  }
  if (auto* nifti = vtkNIFTIImageReader::SafeDownCast(reader))
  {
    const double slope = nifti->GetRescaleSlope();
    const double intercept = nifti->GetRescaleIntercept();
    if ((slope != 0.0 && slope != 1.0) || intercept != 0.0)
    {
      Diagnostics() << "stmesh: warning: " << nifti->GetFileName() << ": scl_slope " << slope
                    << " and scl_inter " << intercept << " are ignored; the "
                    << (labelImage ? "labels" : "gray values") << " are the stored values\n";
    }
  }
}

} // namespace

vtkSmartPointer<vtkImageData> ReadImage(
  const std::string& path, ImageRole role, ImageInfo& info, double& seconds)
{
  const std::string context = "reading '" + path + "'";
  vtkSmartPointer<vtkAlgorithm> reader = CreateImageReader(path, role, info, context);
  vtkImageData* image = UpdateImageReader(reader, nullptr, context, seconds);
  DescribeImage(reader, image, role, info, context);
  vtkSmartPointer<vtkImageData> copy = vtkSmartPointer<vtkImageData>::New();
  copy->ShallowCopy(image);
  return copy;
}

ImageSource OpenImage(const std::string& path, ImageRole role, ImageInfo& info, double& seconds)
{
  const std::string context = "reading '" + path + "'";
  ImageSource source;
  source.Reader = CreateImageReader(path, role, info, context);
  ThrowIfFailed(context);
  int extent[6];
  source.Reader->GetOutputInformation(0)->Get(
    vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent);
  for (int axis = 0; axis < 3; ++axis)
  {
    // Two points per axis: one voxel of cell labels.
    extent[2 * axis + 1] = std::min(extent[2 * axis + 1], extent[2 * axis] + 1);
  }
  vtkImageData* sample = UpdateImageReader(source.Reader, extent, context, seconds);
  DescribeImage(source.Reader, sample, role, info, context);
  // A copy of its own: the reader's next update fills its output anew.
  source.Sample = vtkSmartPointer<vtkImageData>::New();
  source.Sample->DeepCopy(sample);
  return source;
}

long long CheckImagePiece(const ImageSource& source, const ImageInfo& info, const std::string& path)
{
  vtkImageData* piece = vtkImageData::SafeDownCast(source.Reader->GetOutputDataObject(0));
  const vtkIdType voxels = !piece ? 0
    : info.CellLabels             ? piece->GetNumberOfCells()
                                  : piece->GetNumberOfPoints();
  vtkDataArray* values = piece ? ImageValues(piece, info) : nullptr;
  if (voxels > 0 && (!values || values->GetNumberOfTuples() != voxels))
  {
    throw Failure("reading '" + path + "': the piece of the image has " + std::to_string(voxels) +
      " voxels but " + std::to_string(values ? values->GetNumberOfTuples() : 0) +
      " values (truncated file?)");
  }
  return static_cast<long long>(voxels);
}

vtkDataArray* ImageValues(vtkImageData* image, const ImageInfo& info)
{
  return info.CellLabels ? image->GetCellData()->GetScalars() : image->GetPointData()->GetScalars();
}

} // namespace stmesh
