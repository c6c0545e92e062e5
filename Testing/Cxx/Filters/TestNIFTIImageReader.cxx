// SPDX-License-Identifier: BSD-3-Clause
// stmNIFTIImageReader (the plugin's NIfTI reader): the atlas read exactly as VTK's reader reads
// it, and corrupt headers that crash VTK's reader refused with an error instead.

#include "stmFilterTestUtilities.h"
#include "stmNIFTIImageReader.h"

#include "vtkDataArray.h"
#include "vtkImageData.h"
#include "vtkNIFTIImageReader.h"
#include "vtkNew.h"
#include "vtkPointData.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace
{

/// The atlas's bytes, uncompressed.
std::vector<char> AtlasBytes()
{
  std::vector<char> bytes;
  const gzFile file = gzopen(stmTest::AalAtlasPath, "rb");
  EXPECT_NE(file, nullptr);
  char buffer[1 << 16];
  int count = 0;
  while (file && (count = gzread(file, buffer, sizeof(buffer))) > 0)
  {
    bytes.insert(bytes.end(), buffer, buffer + count);
  }
  if (file)
  {
    gzclose(file);
  }
  return bytes;
}

std::string WriteTemporary(const std::string& name, const std::vector<char>& bytes, bool gzip)
{
  const std::string path = testing::TempDir() + name;
  if (gzip)
  {
    const gzFile file = gzopen(path.c_str(), "wb1");
    gzwrite(file, bytes.data(), static_cast<unsigned>(bytes.size()));
    gzclose(file);
  }
  else
  {
    std::ofstream(path, std::ios::binary).write(bytes.data(), bytes.size());
  }
  return path;
}

void SetShort(std::vector<char>& bytes, int offset, short value)
{
  std::memcpy(bytes.data() + offset, &value, sizeof(value)); // NIfTI-1, little endian
}

} // namespace

TEST(NIFTIImageReader, ReadsTheAtlasAsVTKDoes)
{
  vtkNew<vtkNIFTIImageReader> reference;
  reference->SetFileName(stmTest::AalAtlasPath);
  reference->Update();
  vtkNew<stmNIFTIImageReader> reader;
  reader->SetFileName(stmTest::AalAtlasPath);
  reader->Update();
  vtkImageData* expected = reference->GetOutput();
  vtkImageData* image = reader->GetOutput();
  int dimensions[3], expectedDimensions[3];
  image->GetDimensions(dimensions);
  expected->GetDimensions(expectedDimensions);
  EXPECT_EQ(dimensions[0], 181);
  EXPECT_EQ(dimensions[1], 217);
  EXPECT_EQ(dimensions[2], 181);
  for (int axis = 0; axis < 3; ++axis)
  {
    EXPECT_EQ(dimensions[axis], expectedDimensions[axis]);
    EXPECT_EQ(image->GetSpacing()[axis], expected->GetSpacing()[axis]);
    EXPECT_EQ(image->GetOrigin()[axis], expected->GetOrigin()[axis]);
  }
  vtkDataArray* values = image->GetPointData()->GetScalars();
  vtkDataArray* expectedValues = expected->GetPointData()->GetScalars();
  ASSERT_NE(values, nullptr);
  ASSERT_EQ(values->GetDataType(), expectedValues->GetDataType());
  ASSERT_EQ(values->GetNumberOfValues(), expectedValues->GetNumberOfValues());
  EXPECT_EQ(std::memcmp(values->GetVoidPointer(0), expectedValues->GetVoidPointer(0),
              values->GetNumberOfValues() * values->GetDataTypeSize()),
    0);
}

TEST(NIFTIImageReader, RefusesCorruptHeadersWithAnError)
{
  const std::vector<char> atlas = AtlasBytes();
  ASSERT_GT(atlas.size(), 352u);
  struct Case
  {
    const char* Name;
    short Datatype;
    short Bitpix;
    short Dimensions;
    int EmptyAxis; // an axis set to size 0 (0: none)
    const char* Expected;
  };
  // The atlas is datatype 2 (unsigned char), bitpix 8, dim 3 181 217 181 1 1 1 1.
  const Case cases[] = {
    { "datatype.nii", 28261, 8, 3, 0, "the NIfTI header's datatype 28261 is not a NIfTI type" },
    { "bitpix.nii", 2, 16, 3, 0,
      "the NIfTI header's bitpix 16 does not match its datatype 2 (8 bits" },
    { "dimensions.nii", 2, 8, 9, 0, "the NIfTI header's dim[0] is 9, not 1 to 7" },
    // VTK's reader divided by zero on an axis of size 0 below dim[0] (here dim[0] = 5).
    { "empty-axis.nii", 2, 8, 5, 5, "the NIfTI header's dim[5] is 0, not a positive size" },
  };
  for (const Case& c : cases)
  {
    std::vector<char> bytes = atlas;
    SetShort(bytes, 40, c.Dimensions);
    if (c.EmptyAxis > 0)
    {
      SetShort(bytes, 40 + 2 * c.EmptyAxis, 0);
    }
    SetShort(bytes, 70, c.Datatype);
    SetShort(bytes, 72, c.Bitpix);
    for (const bool gzip : { false, true })
    {
      const std::string path =
        WriteTemporary(std::string(c.Name) + (gzip ? ".gz" : ""), bytes, gzip);
      vtkNew<stmNIFTIImageReader> reader;
      reader->SetFileName(path.c_str());
      SCOPED_TRACE(path);
      stmTest::ExpectErrorAndEmptyOutput(reader, c.Expected);
      std::remove(path.c_str());
    }
  }
}
