// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmNIFTIHeader_h
#define stmNIFTIHeader_h

// What is wrong with a NIfTI file's header, as far as ParaView 5.11's vtkNIFTIImageReader is
// concerned: it indexes a table with the header's datatype without a bound, and crashes on a
// datatype NIfTI does not define (found by stmesh's reader fuzzing, docs/reliability.md). Read
// by stmNIFTIImageReader (the plugin's NIfTI reader) and by stmesh before VTK sees the file.
// VTK-free and header-only, so that the reader fuzz target builds without the module.

#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <iterator>
#include <string>

namespace stm
{

/// "" when the header is fine or not NIfTI at all (VTK refuses those itself), else why it is
/// corrupt: a NIfTI magic with a sizeof_hdr that is neither 348 nor 540, a datatype NIfTI does
/// not define, a bitpix that does not match the datatype, a dim[0] outside 1 to 7, or an axis
/// below it of no positive size. NIfTI-1 and NIfTI-2, either byte order, .nii or .nii.gz.
inline std::string NIFTIHeaderProblem(const std::string& path)
{
  unsigned char header[540] = {};
  const gzFile file = gzopen(path.c_str(), "rb"); // reads plain files as they are
  if (!file)
  {
    return std::string();
  }
  const int length = gzread(file, header, sizeof(header));
  gzclose(file);
  auto integer = [&](int offset, int bytes, bool swap)
  {
    std::uint64_t value = 0;
    for (int b = 0; b < bytes; ++b)
    {
      const int at = swap ? offset + b : offset + bytes - 1 - b;
      value = (value << 8) | header[at];
    }
    // Sign-extend the field.
    const int unused = 64 - 8 * bytes;
    return static_cast<std::int64_t>(value << unused) >> unused;
  };
  int version = 0;
  bool swap = false;
  for (const bool swapped : { false, true })
  {
    const std::int64_t size = length >= 4 ? integer(0, 4, swapped) : 0;
    if (size == 348 || size == 540)
    {
      swap = swapped;
      version = size == 348 ? 1 : 2;
      break;
    }
  }
  if (version == 0)
  {
    // VTK's reader knows NIfTI by its magic, not by sizeof_hdr, and then reads the header as it
    // is (found by fuzzing: sizeof_hdr 490 with the magic "n+1" crashed it).
    auto magic = [&](int offset, char digit)
    {
      return length >= offset + 4 && header[offset] == 'n' &&
        (header[offset + 1] == '+' || header[offset + 1] == 'i') && header[offset + 2] == digit &&
        header[offset + 3] == 0;
    };
    if (magic(344, '1') || magic(4, '2'))
    {
      return "the NIfTI header's sizeof_hdr is " + std::to_string(integer(0, 4, false)) +
        ", not 348 (NIfTI-1) or 540 (NIfTI-2) (a corrupt header)";
    }
    return std::string();
  }
  if (length < (version == 1 ? 348 : 540))
  {
    return std::string();
  }
  const std::int64_t datatype = integer(version == 1 ? 70 : 12, 2, swap);
  const std::int64_t bitpix = integer(version == 1 ? 72 : 14, 2, swap);
  const std::int64_t dimensions = version == 1 ? integer(40, 2, swap) : integer(16, 8, swap);
  struct Type
  {
    int Code;
    int Bits;
  };
  static constexpr Type Types[] = { { 1, 1 }, { 2, 8 }, { 4, 16 }, { 8, 32 }, { 16, 32 },
    { 32, 64 }, { 64, 64 }, { 128, 24 }, { 256, 8 }, { 512, 16 }, { 768, 32 }, { 1024, 64 },
    { 1280, 64 }, { 1536, 128 }, { 1792, 128 }, { 2048, 256 }, { 2304, 32 } };
  const Type* type = std::find_if(
    std::begin(Types), std::end(Types), [&](const Type& known) { return known.Code == datatype; });
  if (type == std::end(Types))
  {
    return "the NIfTI header's datatype " + std::to_string(datatype) +
      " is not a NIfTI type (a corrupt header)";
  }
  if (bitpix != type->Bits)
  {
    return "the NIfTI header's bitpix " + std::to_string(bitpix) + " does not match its datatype " +
      std::to_string(datatype) + " (" + std::to_string(type->Bits) + " bits; a corrupt header)";
  }
  if (dimensions < 1 || dimensions > 7)
  {
    return "the NIfTI header's dim[0] is " + std::to_string(dimensions) +
      ", not 1 to 7 (a corrupt header)";
  }
  // An axis of size 0 below dim[0] made VTK's reader divide by zero (found by fuzzing).
  for (int axis = 1; axis <= dimensions; ++axis)
  {
    const std::int64_t size =
      version == 1 ? integer(40 + 2 * axis, 2, swap) : integer(16 + 8 * axis, 8, swap);
    if (size < 1)
    {
      return "the NIfTI header's dim[" + std::to_string(axis) + "] is " + std::to_string(size) +
        ", not a positive size (a corrupt header)";
    }
  }
  return std::string();
}

} // namespace stm

#endif
