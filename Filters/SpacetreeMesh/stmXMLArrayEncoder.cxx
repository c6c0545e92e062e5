// SPDX-License-Identifier: BSD-3-Clause
#include "stmXMLArrayEncoder.h"

#include "vtkArrayDispatch.h"
#include "vtkBase64Utilities.h"
#include "vtkDataArray.h"
#include "vtkDataArrayRange.h"
#include "vtkDataCompressor.h"
#include "vtkErrorCode.h"
#include "vtkInformation.h"
#include "vtkInformationDoubleVectorKey.h"
#include "vtkInformationInformationVectorKey.h"
#include "vtkLZ4DataCompressor.h"
#include "vtkSMPThreadLocal.h"
#include "vtkSMPTools.h"
#include "vtkSmartPointer.h"
#include "vtkXMLWriter.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

namespace
{
/// Three bytes make four base64 characters; this many groups make one range of a thread.
constexpr vtkIdType GroupsPerRange = 1 << 16;

/// What the writer's settings and the array say about how to write it; Handled is false when
/// the writer's own path must write it.
struct ArrayLayout
{
  bool Handled = false;
  const unsigned char* Data = nullptr;
  std::size_t TotalBytes = 0;
  std::size_t BlockSize = 0;
  std::size_t HeaderWordSize = 8;
  vtkDataCompressor* Compressor = nullptr;
};

/// VTK's own compressors, not subclasses of them: their copies compress alike on every thread.
bool IsVTKCompressor(vtkDataCompressor* compressor)
{
  const std::string name = compressor->GetClassName();
  return name == "vtkZLibDataCompressor" || name == "vtkLZ4DataCompressor" ||
    name == "vtkLZMADataCompressor";
}

ArrayLayout LayoutOf(vtkXMLWriter* writer, vtkAbstractArray* array)
{
  ArrayLayout layout;
  vtkDataArray* data = vtkDataArray::SafeDownCast(array);
  if (!data || !data->HasStandardMemoryLayout() || data->GetDataType() == VTK_BIT)
  {
    return layout;
  }
#ifdef VTK_WORDS_BIGENDIAN
  const int nativeOrder = vtkXMLWriter::BigEndian;
#else
  const int nativeOrder = vtkXMLWriter::LittleEndian;
#endif
  const std::size_t wordSize = static_cast<std::size_t>(data->GetDataTypeSize());
  const bool convertsIds = data->GetDataType() == VTK_ID_TYPE &&
    writer->GetIdType() == vtkXMLWriter::Int32 && sizeof(vtkIdType) != 4;
  // In the other byte order even one-byte data have their headers swapped.
  if (writer->GetByteOrder() != nativeOrder || convertsIds || wordSize == 0)
  {
    return layout;
  }
  vtkDataCompressor* compressor = writer->GetCompressor();
  if (compressor && !IsVTKCompressor(compressor))
  {
    return layout;
  }
  layout.BlockSize = writer->GetBlockSize();
  layout.TotalBytes = static_cast<std::size_t>(data->GetNumberOfValues()) * wordSize;
  layout.HeaderWordSize = writer->GetHeaderType() == vtkXMLWriter::UInt32 ? 4 : 8;
  if (layout.BlockSize == 0 || layout.BlockSize % wordSize != 0)
  {
    return layout;
  }
  // Sizes a 32-bit header cannot hold are the writer's own path's error to report.
  const std::size_t largest = compressor
    ? std::max(layout.TotalBytes, compressor->GetMaximumCompressionSpace(layout.BlockSize))
    : layout.TotalBytes;
  if (layout.HeaderWordSize == 4 && largest > std::numeric_limits<std::uint32_t>::max())
  {
    return layout;
  }
  layout.Data = static_cast<const unsigned char*>(data->GetVoidPointer(0));
  layout.Compressor = compressor;
  layout.Handled = true;
  return layout;
}

/// The words of a header (vtkXMLWriter's HeaderType), in the machine's byte order.
class HeaderWords
{
public:
  HeaderWords(std::size_t wordSize, std::size_t count)
    : WordSize(wordSize)
    , Bytes(wordSize * count, 0)
  {
  }

  void Set(std::size_t index, std::uint64_t value)
  {
    if (this->WordSize == 4)
    {
      const std::uint32_t narrow = static_cast<std::uint32_t>(value);
      std::memcpy(&this->Bytes[4 * index], &narrow, 4);
    }
    else
    {
      std::memcpy(&this->Bytes[8 * index], &value, 8);
    }
  }

  const std::vector<unsigned char>& GetBytes() const { return this->Bytes; }

private:
  std::size_t WordSize;
  std::vector<unsigned char> Bytes;
};

/// Base64 of whole three-byte groups, two characters per table look-up: vtkBase64Utilities
/// encodes a group per call of a function in another library, three times slower, which was a
/// quarter of the write's time even on two threads. Its alphabet and order; the padded end of a
/// stream is still encoded by vtkBase64Utilities.
class Base64Groups
{
public:
  static const Base64Groups& Get()
  {
    static const Base64Groups table;
    return table;
  }

  void Encode(const unsigned char* input, std::size_t groups, unsigned char* output) const
  {
    for (std::size_t group = 0; group < groups; ++group, input += 3, output += 4)
    {
      const unsigned bits = (unsigned{ input[0] } << 16) | (unsigned{ input[1] } << 8) | input[2];
      std::memcpy(output, &this->Pairs[2 * (bits >> 12)], 2);
      std::memcpy(output + 2, &this->Pairs[2 * (bits & 4095)], 2);
    }
  }

private:
  Base64Groups()
  {
    const char alphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (unsigned twelveBits = 0; twelveBits < 4096; ++twelveBits)
    {
      this->Pairs[2 * twelveBits] = static_cast<unsigned char>(alphabet[twelveBits >> 6]);
      this->Pairs[2 * twelveBits + 1] = static_cast<unsigned char>(alphabet[twelveBits & 63]);
    }
  }

  unsigned char Pairs[2 * 4096];
};

/// Base64 of a byte sequence that arrives in parts: each part's whole three-byte groups are
/// encoded on all threads and written, the one or two bytes left over wait for the next part,
/// and Finish pads the last group as vtkBase64OutputStream::EndWriting does.
class StreamingBase64
{
public:
  explicit StreamingBase64(std::ostream& stream)
    : Stream(stream)
  {
  }

  std::vector<unsigned char>& GetPending() { return this->Pending; }

  bool Flush()
  {
    const std::size_t groups = this->Pending.size() / 3;
    this->Encoded.resize(4 * groups);
    const unsigned char* input = this->Pending.data();
    unsigned char* output = this->Encoded.data();
    const Base64Groups& table = Base64Groups::Get();
    vtkSMPTools::For(0, static_cast<vtkIdType>(groups), GroupsPerRange,
      [input, output, &table](vtkIdType begin, vtkIdType end) {
        table.Encode(input + 3 * begin, static_cast<std::size_t>(end - begin), output + 4 * begin);
      });
    this->Pending.erase(this->Pending.begin(), this->Pending.begin() + 3 * groups);
    return this->Write(this->Encoded.size());
  }

  bool Finish()
  {
    if (!this->Flush())
    {
      return false;
    }
    if (this->Pending.empty())
    {
      return true;
    }
    unsigned char last[4];
    vtkBase64Utilities::Encode(
      this->Pending.data(), static_cast<unsigned long>(this->Pending.size()), last, 0);
    this->Encoded.assign(last, last + 4);
    this->Pending.clear();
    return this->Write(4);
  }

private:
  bool Write(std::size_t count)
  {
    this->Stream.write(
      reinterpret_cast<const char*>(this->Encoded.data()), static_cast<std::streamsize>(count));
    return !this->Stream.fail();
  }

  std::ostream& Stream;
  std::vector<unsigned char> Pending;
  std::vector<unsigned char> Encoded;
};

/// Writes a header as its own base64 stream (vtkXMLWriter starts and ends the data stream for
/// it, so it is padded on its own).
bool WriteHeader(std::ostream& stream, const HeaderWords& header)
{
  StreamingBase64 encoder(stream);
  encoder.GetPending() = header.GetBytes();
  return encoder.Finish();
}

/// Blocks compressed side by side, one batch at a time, each thread with its own compressor
/// made like the writer's.
class BlockCompressor
{
public:
  BlockCompressor(vtkDataCompressor* prototype, std::size_t blockSize)
    : Prototype(prototype)
    , Space(prototype->GetMaximumCompressionSpace(blockSize))
  {
  }

  /// Compresses `count` blocks starting at `first`; returns false if one failed.
  bool Compress(const ArrayLayout& layout, std::size_t first, std::size_t count)
  {
    if (this->Buffers.size() < count)
    {
      this->Buffers.resize(count);
      this->Sizes.resize(count);
    }
    std::atomic<bool> failed(false);
    vtkSMPTools::For(0, static_cast<vtkIdType>(count), 1,
      [&](vtkIdType begin, vtkIdType end)
      {
        vtkDataCompressor* compressor = this->LocalCompressor();
        for (vtkIdType slot = begin; slot < end; ++slot)
        {
          const std::size_t offset = (first + slot) * layout.BlockSize;
          const std::size_t length = std::min(layout.BlockSize, layout.TotalBytes - offset);
          std::vector<unsigned char>& buffer = this->Buffers[slot];
          buffer.resize(this->Space);
          this->Sizes[slot] =
            compressor->Compress(layout.Data + offset, length, buffer.data(), this->Space);
          if (this->Sizes[slot] == 0)
          {
            failed = true;
          }
        }
      });
    return !failed;
  }

  const unsigned char* Block(std::size_t slot) const { return this->Buffers[slot].data(); }
  std::size_t Size(std::size_t slot) const { return this->Sizes[slot]; }

private:
  vtkDataCompressor* LocalCompressor()
  {
    vtkSmartPointer<vtkDataCompressor>& local = this->Compressors.Local();
    if (!local)
    {
      local.TakeReference(this->Prototype->NewInstance());
      local->SetCompressionLevel(this->Prototype->GetCompressionLevel());
      if (auto* lz4 = vtkLZ4DataCompressor::SafeDownCast(this->Prototype))
      {
        vtkLZ4DataCompressor::SafeDownCast(local)->SetAccelerationLevel(
          lz4->GetAccelerationLevel());
      }
    }
    return local;
  }

  vtkDataCompressor* Prototype;
  std::size_t Space;
  vtkSMPThreadLocal<vtkSmartPointer<vtkDataCompressor>> Compressors;
  std::vector<std::vector<unsigned char>> Buffers;
  std::vector<std::size_t> Sizes;
};

/// Blocks in one batch: enough to keep every thread busy, few enough to bound the memory.
std::size_t BlocksPerBatch()
{
  return static_cast<std::size_t>(std::max(1, vtkSMPTools::GetEstimatedNumberOfThreads())) * 8;
}

bool WriteCompressed(
  std::ostream& stream, const ArrayLayout& layout, const std::function<void(double)>& progress)
{
  const std::size_t blockCount = (layout.TotalBytes + layout.BlockSize - 1) / layout.BlockSize;
  HeaderWords header(layout.HeaderWordSize, 3 + blockCount);
  header.Set(0, blockCount);
  header.Set(1, layout.BlockSize);
  header.Set(2, layout.TotalBytes % layout.BlockSize);
  // Written now to hold the place (its length does not depend on the sizes), again at the end.
  const std::streampos headerPosition = stream.tellp();
  if (!WriteHeader(stream, header))
  {
    return false;
  }
  StreamingBase64 encoder(stream);
  BlockCompressor compressor(layout.Compressor, layout.BlockSize);
  const std::size_t batch = BlocksPerBatch();
  for (std::size_t first = 0; first < blockCount; first += batch)
  {
    const std::size_t count = std::min(batch, blockCount - first);
    if (!compressor.Compress(layout, first, count))
    {
      return false;
    }
    std::vector<unsigned char>& pending = encoder.GetPending();
    for (std::size_t slot = 0; slot < count; ++slot)
    {
      header.Set(3 + first + slot, compressor.Size(slot));
      pending.insert(
        pending.end(), compressor.Block(slot), compressor.Block(slot) + compressor.Size(slot));
    }
    if (!encoder.Flush())
    {
      return false;
    }
    progress(static_cast<double>(first + count) / static_cast<double>(blockCount));
  }
  if (!encoder.Finish())
  {
    return false;
  }
  const std::streampos endPosition = stream.tellp();
  return stream.seekp(headerPosition) && WriteHeader(stream, header) && stream.seekp(endPosition);
}

bool WriteUncompressed(
  std::ostream& stream, const ArrayLayout& layout, const std::function<void(double)>& progress)
{
  // The byte count and the data are one base64 stream.
  HeaderWords header(layout.HeaderWordSize, 1);
  header.Set(0, layout.TotalBytes);
  StreamingBase64 encoder(stream);
  encoder.GetPending() = header.GetBytes();
  const std::size_t batchBytes = BlocksPerBatch() * layout.BlockSize;
  for (std::size_t offset = 0; offset < layout.TotalBytes; offset += batchBytes)
  {
    const std::size_t length = std::min(batchBytes, layout.TotalBytes - offset);
    std::vector<unsigned char>& pending = encoder.GetPending();
    pending.insert(pending.end(), layout.Data + offset, layout.Data + offset + length);
    if (!encoder.Flush())
    {
      return false;
    }
    progress(static_cast<double>(offset + length) / static_cast<double>(layout.TotalBytes));
  }
  return encoder.Finish();
}
/// Whether the array's information holds nothing but the ranges VTK caches there.
bool HasOnlyCachedRanges(vtkAbstractArray* array)
{
  if (!array->HasInformation())
  {
    return true;
  }
  vtkInformation* information = array->GetInformation();
  const int cached = information->Has(vtkDataArray::L2_NORM_RANGE()) +
    information->Has(vtkDataArray::L2_NORM_FINITE_RANGE()) +
    information->Has(vtkAbstractArray::PER_COMPONENT()) +
    information->Has(vtkAbstractArray::PER_FINITE_COMPONENT());
  return information->GetNumberOfKeys() == cached;
}

/// The smallest and largest value (one component) or squared L2 norm (several) of a range of
/// tuples, and whether all were finite.
struct Extremes
{
  double Smallest = std::numeric_limits<double>::infinity();
  double Largest = -std::numeric_limits<double>::infinity();
  bool Finite = true;
};

struct RangeWorker
{
  Extremes Result;

  template <class ArrayT>
  void operator()(ArrayT* array)
  {
    const auto tuples = vtk::DataArrayTupleRange(array);
    const int components = array->GetNumberOfComponents();
    vtkSMPThreadLocal<Extremes> local;
    vtkSMPTools::For(0, array->GetNumberOfTuples(),
      [&](vtkIdType begin, vtkIdType end)
      {
        Extremes& extremes = local.Local();
        for (vtkIdType tuple = begin; tuple < end; ++tuple)
        {
          double measure = 0.0;
          if (components == 1)
          {
            measure = static_cast<double>(tuples[tuple][0]);
          }
          else
          {
            // In component order, in double, as VTK sums the squares.
            for (int component = 0; component < components; ++component)
            {
              const double value = static_cast<double>(tuples[tuple][component]);
              measure += value * value;
            }
          }
          if (!std::isfinite(measure))
          {
            extremes.Finite = false;
          }
          extremes.Smallest = std::min(extremes.Smallest, measure);
          extremes.Largest = std::max(extremes.Largest, measure);
        }
      });
    for (const Extremes& extremes : local)
    {
      this->Result.Smallest = std::min(this->Result.Smallest, extremes.Smallest);
      this->Result.Largest = std::max(this->Result.Largest, extremes.Largest);
      this->Result.Finite = this->Result.Finite && extremes.Finite;
    }
    if (components > 1)
    {
      this->Result.Smallest = std::sqrt(this->Result.Smallest);
      this->Result.Largest = std::sqrt(this->Result.Largest);
    }
  }
};
} // namespace

bool stmXMLArrayEncoder::ComputeRange(vtkAbstractArray* array, double range[2])
{
  vtkDataArray* data = vtkDataArray::SafeDownCast(array);
  if (!data || data->GetNumberOfTuples() == 0 || data->GetNumberOfComponents() < 1 ||
    !HasOnlyCachedRanges(array))
  {
    return false;
  }
  RangeWorker worker;
  if (!vtkArrayDispatch::Dispatch::Execute(data, worker) || !worker.Result.Finite)
  {
    return false;
  }
  range[0] = worker.Result.Smallest;
  range[1] = worker.Result.Largest;
  if (data->GetNumberOfComponents() > 1)
  {
    // GetRange(-1) caches the norms' range in the array's information, and vtkXMLWriter writes
    // that information after the data; the components' ranges it caches are not written.
    data->GetInformation()->Set(vtkDataArray::L2_NORM_RANGE(), range, 2);
  }
  return true;
}

stmXMLArrayEncoder::Outcome stmXMLArrayEncoder::WriteInline(vtkXMLWriter* writer,
  std::ostream& stream, vtkAbstractArray* array, vtkIndent indent,
  const std::function<void(double)>& progress)
{
  Outcome outcome;
  if (writer->GetDataMode() != vtkXMLWriter::Binary)
  {
    return outcome;
  }
  const ArrayLayout layout = LayoutOf(writer, array);
  if (!layout.Handled)
  {
    return outcome;
  }
  outcome.Handled = true;
  stream << indent;
  const bool written = layout.Compressor ? WriteCompressed(stream, layout, progress)
                                         : WriteUncompressed(stream, layout, progress);
  stream << "\n";
  if (stream.fail())
  {
    outcome.ErrorCode = vtkErrorCode::GetLastSystemError();
  }
  else if (!written)
  {
    outcome.ErrorCode = vtkErrorCode::UnknownError;
  }
  return outcome;
}
