// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmXMLArrayEncoder
 * @brief   writes a data array inline in binary form as vtkXMLWriter does, byte for byte, with
 * the compression and the base64 encoding on all threads (private)
 *
 * VTK 9.2's XML writers compress and base64-encode every array on one thread, through an
 * std::ostream three bytes at a time: on the AAL brain mask's 6.9 million tetrahedra that is
 * about 2.5 s, longer than the meshing stages before the smoothing together. The file format
 * is simple (vtkXMLWriter::WriteBinaryData): with a compressor, a base64 header of the block
 * count, the block size, the last block's size and every block's compressed size, then the
 * base64 of the compressed blocks one after another; without one, the base64 of the data's byte
 * count followed by the data. The blocks do not depend on each other, so they are compressed
 * side by side, a batch of blocks at a time to bound the memory, and each batch is encoded in
 * ranges of whole three-byte groups.
 *
 * The same for the arrays' ranges, which the writer computes for every array's attributes.
 *
 * Handled: every vtkDataArray with the standard memory layout, written in the machine's byte
 * order, with VTK's zlib, LZ4 or LZMA compressor or none. Anything else (strings, bit arrays,
 * vtkIdType arrays written as Int32, byte swapping, another compressor) is left to the writer's
 * own path, so the output is always what VTK's writer writes.
 */

#ifndef stmXMLArrayEncoder_h
#define stmXMLArrayEncoder_h

#include "vtkIndent.h"

#include <functional>
#include <iosfwd>

class vtkAbstractArray;
class vtkXMLWriter;

class stmXMLArrayEncoder
{
public:
  struct Outcome
  {
    bool Handled = false;        // false: nothing written, the writer's own path must write it
    unsigned long ErrorCode = 0; // vtkErrorCode's value for the writer, 0 if all went well
  };

  /// Writes the array's inline binary data (the indent, the encoded data, the line end) to the
  /// writer's stream as vtkXMLWriter::WriteInlineData would in binary mode, reporting the
  /// fraction written through `progress`. Writes nothing for what it does not handle (see
  /// above).
  static Outcome WriteInline(vtkXMLWriter* writer, std::ostream& stream, vtkAbstractArray* array,
    vtkIndent indent, const std::function<void(double)>& progress);

  /// The range vtkXMLWriter writes as RangeMin and RangeMax (vtkDataArray::GetRange(-1): the
  /// values' range for one component, the range of the tuples' L2 norms for several), computed
  /// on all threads: VTK 9.2 takes about 18 ns a value for it, as long as the encoding of the
  /// array. Like GetRange(-1), it caches the range of norms in the array's information (which
  /// the writer writes after the data). Returns false for what it leaves to VTK: not a data
  /// array, no values, a value that is not finite, or information keys other than VTK's cached
  /// ranges.
  static bool ComputeRange(vtkAbstractArray* array, double range[2]);
};

#endif
