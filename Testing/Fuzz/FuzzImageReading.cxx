// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for stmesh's image input (Applications/stmesh/Reading): the first byte of
// the fuzz input picks the file's extension (.nii, .nii.gz, .mha, .mhd, .nrrd, .nhdr, .vti),
// the rest is the file, read with stmesh::ReadImage exactly as the command line reads its input
// (the checks before reading, VTK's reader with every error and warning captured, the checks of
// what it read). A Failure, with a message naming the file, is the expected outcome for most
// inputs; a crash, a hang, an out-of-memory or a "successful" read of an image whose values do
// not match its voxels is a bug.
//
// Detached headers (.mhd, .nhdr) may name "data.raw": 64 bytes that lie beside the input.
//
// VTK itself is not instrumented (Debian's libraries), so libFuzzer's coverage guidance sees
// only stmesh's code; the mutations still reach the readers through the seed corpus
// (MakeReaderSeedCorpus.py: valid small images of each format and corrupt variants).

#include "stmeshErrors.h"
#include "stmeshImageInput.h"

#include "vtkDataArray.h"
#include "vtkImageData.h"
#include "vtkType.h"

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

namespace
{

const char* const Extensions[] = { ".nii", ".nii.gz", ".mha", ".mhd", ".nrrd", ".nhdr", ".vti" };

[[noreturn]] void Fail(const std::string& what)
{
  std::fprintf(stderr, "FuzzImageReading: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

/// A directory of this process's own, with data.raw in it, made once.
const std::string& WorkDirectory()
{
  static const std::string directory = []
  {
    const char* base = std::getenv("TMPDIR");
    std::string pattern = std::string(base && *base ? base : "/tmp") + "/stm-fuzz-read-XXXXXX";
    if (!mkdtemp(&pattern[0]))
    {
      Fail("cannot create a temporary directory");
    }
    std::ofstream data(pattern + "/data.raw", std::ios::binary);
    for (int i = 0; i < 64; ++i)
    {
      data.put(static_cast<char>(i % 3));
    }
    stmesh::InstallErrorCapture();
    return pattern;
  }();
  return directory;
}

void WriteFile(const std::string& path, const std::uint8_t* data, std::size_t size)
{
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!file)
  {
    Fail("cannot write " + path);
  }
}

/// What a successful read promises the meshing stages.
void CheckImage(vtkImageData* image, const stmesh::ImageInfo& info)
{
  if (!image)
  {
    Fail("ReadImage returned no image without a failure");
  }
  vtkDataArray* values = stmesh::ImageValues(image, info);
  if (!values || values->GetNumberOfComponents() != 1)
  {
    Fail("ReadImage returned an image without one value per voxel");
  }
  long long voxels = 1;
  for (int axis = 0; axis < 3; ++axis)
  {
    if (info.VoxelDimensions[axis] < 1)
    {
      Fail("ReadImage returned an image with an empty axis");
    }
    voxels *= info.VoxelDimensions[axis];
  }
  if (values->GetNumberOfTuples() != voxels)
  {
    Fail("ReadImage returned " + std::to_string(values->GetNumberOfTuples()) + " values for " +
      std::to_string(voxels) + " voxels");
  }
  // Every value is read (under AddressSanitizer: the array's memory is really there); a
  // non-empty integer array has a range (a floating-point one may be all NaN).
  double range[2] = { 1.0, 0.0 };
  values->GetRange(range, 0);
  const bool floating = values->GetDataType() == VTK_FLOAT || values->GetDataType() == VTK_DOUBLE;
  if (!floating && !(range[0] <= range[1]))
  {
    Fail("ReadImage returned values without a range");
  }
  if (stmesh::Errors().HasErrors())
  {
    Fail("ReadImage succeeded with errors recorded: " + stmesh::Errors().Take());
  }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  const std::string& directory = WorkDirectory();
  const char* extension = Extensions[size > 0 ? data[0] % 7 : 0];
  const std::string path = directory + "/input" + extension;
  WriteFile(path, size > 0 ? data + 1 : data, size > 0 ? size - 1 : 0);
  stmesh::ImageInfo info;
  double seconds = 0.0;
  try
  {
    vtkSmartPointer<vtkImageData> image =
      stmesh::ReadImage(path, stmesh::ImageRole::Labels, info, seconds);
    CheckImage(image, info);
  }
  catch (const stmesh::Failure& failure)
  {
    if (std::string(failure.what()).empty())
    {
      Fail("a Failure without a message");
    }
  }
  stmesh::Errors().Take(); // a failed read may leave messages of later steps
  std::remove(path.c_str());
  return 0;
}
