// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreMeshExport_h
#define stmCoreMeshExport_h

// What the finite-element exports (GmshFormat.h, MeditFormat.h, AbaqusFormat.h, FEBioFormat.h)
// share: a read-only view of a mesh of linear cells with a material label per cell; its
// material groups (one per label, each with a positive tag and a name) and its cells in blocks
// of one group and one shape; the formats' corner orders; and a chunked text writer that formats
// numbers on the executor's threads and writes the chunks in order.
//
// Tags: a solver's group numbers must be positive, so a label of 1 or more is its own tag and
// the labels of 0 or less (the background, 0, around the body) take the tags after the largest
// label, in ascending order. Names come from a label table (an atlas's .txt file) or are
// "Material_<label>".

#include "../Common/Status.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <map>
#include <ostream>
#include <string>
#include <type_traits>
#include <vector>

namespace stm
{

/// Linear cell shapes, numbered as VTK's cell types (VTK_TRIANGLE, VTK_QUAD, VTK_TETRA,
/// VTK_HEXAHEDRON, VTK_WEDGE, VTK_PYRAMID), so that a VTK cell-types array is a shapes array.
enum class ElementShape : std::uint8_t
{
  Triangle = 5,
  Quad = 9,
  Tetra = 10,
  Hexahedron = 12,
  Wedge = 13,
  Pyramid = 14
};

/// The shapes in the order the exports write their blocks: solids, then planar cells.
constexpr ElementShape ExportShapeOrder[6] = { ElementShape::Tetra, ElementShape::Pyramid,
  ElementShape::Wedge, ElementShape::Hexahedron, ElementShape::Triangle, ElementShape::Quad };

/// Corners of a shape; 0 for a value that is none of the shapes.
constexpr int ShapeCorners(std::uint8_t shape)
{
  switch (static_cast<ElementShape>(shape))
  {
    case ElementShape::Triangle:
      return 3;
    case ElementShape::Quad:
    case ElementShape::Tetra:
      return 4;
    case ElementShape::Pyramid:
      return 5;
    case ElementShape::Wedge:
      return 6;
    case ElementShape::Hexahedron:
      return 8;
  }
  return 0;
}

/// 2 for triangles and quads, 3 for the solids, 0 for a value that is none of the shapes.
constexpr int ShapeDimension(std::uint8_t shape)
{
  const auto value = static_cast<ElementShape>(shape);
  return value == ElementShape::Triangle || value == ElementShape::Quad ? 2
    : ShapeCorners(shape) > 0                                           ? 3
                                                                        : 0;
}

/// The corner of the VTK cell written at each position of a format's cell. VTK's wedge has its
/// first triangle turned away from the second (its normal points out of the cell); Gmsh's,
/// Medit's, Abaqus's and FEBio's turn it toward the second, as every shape's first face is in
/// VTK too, so only wedges are reordered.
constexpr int FiniteElementCorner(std::uint8_t shape, int position)
{
  constexpr int Wedge[6] = { 0, 2, 1, 3, 5, 4 };
  return static_cast<ElementShape>(shape) == ElementShape::Wedge ? Wedge[position] : position;
}

/// A view of the mesh to export (nothing is copied). IdType: the integer type of the offsets
/// and the connectivity.
template <class IdType>
struct ExportMesh
{
  std::int64_t NumberOfPoints = 0;
  const double* Points = nullptr; // x, y, z per point
  std::int64_t NumberOfCells = 0;
  const IdType* Offsets = nullptr;      // NumberOfCells + 1: cell c is [Offsets[c], Offsets[c+1])
  const IdType* Connectivity = nullptr; // point ids
  const std::uint8_t* Shapes = nullptr; // ElementShape per cell
  const std::int64_t* Materials = nullptr; // label per cell; nullptr: one group, label 1
};

/// A label's name from a label table.
struct MaterialName
{
  std::int64_t Label = 0;
  std::string Name;
};

/// One material: its label, its tag (positive, see the header), its name and its cell count.
struct MaterialGroup
{
  std::int64_t Label = 0;
  std::int64_t Tag = 0;
  std::string Name;
  std::int64_t Cells = 0;
};

/// The cells of one group and one shape: [Begin, End) of ExportBlocks::Cells.
struct ExportBlock
{
  std::int32_t Group = 0;
  std::uint8_t Shape = 0;
  std::int64_t Begin = 0;
  std::int64_t End = 0;
};

/// The groups in ascending label order and every cell once, in blocks of one group and one
/// shape (groups ascending, shapes in ExportShapeOrder, cells ascending within a block).
struct ExportBlocks
{
  std::vector<MaterialGroup> Groups;
  std::vector<std::int64_t> Cells;
  std::vector<ExportBlock> Blocks;
  int Dimension = 0; // of the cells: 2 or 3 (0 without cells)
};

/// FEBio's element type of a solid shape; also the suffix of the block names of a material of
/// several shapes (BlockNames).
inline const char* FEBioElementType(std::uint8_t shape)
{
  switch (static_cast<ElementShape>(shape))
  {
    case ElementShape::Tetra:
      return "tet4";
    case ElementShape::Pyramid:
      return "pyra5";
    case ElementShape::Wedge:
      return "penta6";
    case ElementShape::Hexahedron:
      return "hex8";
    default:
      return "";
  }
}

/// Checks the mesh (shapes, corner counts, point ids, finite coordinates; cells of one
/// dimension) and makes its groups and blocks. `names` may name any labels, present or not.
template <class IdType>
Status MakeExportBlocks(
  const ExportMesh<IdType>& mesh, const std::vector<MaterialName>& names, ExportBlocks& blocks)
{
  blocks = ExportBlocks();
  if (mesh.NumberOfPoints < 0 || mesh.NumberOfCells < 0 ||
    (mesh.NumberOfPoints > 0 && !mesh.Points) ||
    (mesh.NumberOfCells > 0 && (!mesh.Offsets || !mesh.Connectivity || !mesh.Shapes)))
  {
    return Status::Invalid("the mesh to export is incomplete (points, cells or cell types "
                           "missing)");
  }
  for (std::int64_t i = 0; i < 3 * mesh.NumberOfPoints; ++i)
  {
    if (!std::isfinite(mesh.Points[i]))
    {
      return Status::Invalid(
        "point " + std::to_string(i / 3) + " has a non-finite coordinate; nothing was written");
    }
  }
  for (std::int64_t c = 0; c < mesh.NumberOfCells; ++c)
  {
    const int corners = ShapeCorners(mesh.Shapes[c]);
    if (corners == 0)
    {
      return Status::Invalid("cell " + std::to_string(c) + " has VTK cell type " +
        std::to_string(mesh.Shapes[c]) +
        "; the finite-element exports write linear triangles, quads, tetrahedra, pyramids, "
        "wedges and hexahedra");
    }
    const int dimension = ShapeDimension(mesh.Shapes[c]);
    if (blocks.Dimension != 0 && dimension != blocks.Dimension)
    {
      return Status::Invalid("the mesh mixes planar cells and solids; export one or the other");
    }
    blocks.Dimension = dimension;
    if (static_cast<std::int64_t>(mesh.Offsets[c + 1]) -
        static_cast<std::int64_t>(mesh.Offsets[c]) !=
      corners)
    {
      return Status::Invalid("cell " + std::to_string(c) + " has the wrong number of points");
    }
    for (auto k = static_cast<std::int64_t>(mesh.Offsets[c]); k < mesh.Offsets[c + 1]; ++k)
    {
      const auto id = static_cast<std::int64_t>(mesh.Connectivity[k]);
      if (id < 0 || id >= mesh.NumberOfPoints)
      {
        return Status::Invalid(
          "cell " + std::to_string(c) + " refers to a point id outside the mesh");
      }
    }
  }

  // The groups, by label.
  std::map<std::int64_t, std::int64_t> counts;
  for (std::int64_t c = 0; c < mesh.NumberOfCells; ++c)
  {
    ++counts[mesh.Materials ? mesh.Materials[c] : 1];
  }
  std::map<std::int64_t, std::string> named;
  for (const MaterialName& entry : names)
  {
    named[entry.Label] = entry.Name;
  }
  std::int64_t nextTag = 1;
  for (const auto& entry : counts)
  {
    nextTag = std::max(nextTag, entry.first + 1);
  }
  std::map<std::int64_t, std::int32_t> groupOf;
  for (const auto& entry : counts)
  {
    MaterialGroup group;
    group.Label = entry.first;
    group.Cells = entry.second;
    auto name = named.find(entry.first);
    group.Name = name != named.end() && !name->second.empty()
      ? name->second
      : "Material_" + std::to_string(entry.first);
    groupOf[entry.first] = static_cast<std::int32_t>(blocks.Groups.size());
    blocks.Groups.push_back(group);
  }
  for (MaterialGroup& group : blocks.Groups)
  {
    group.Tag = group.Label >= 1 ? group.Label : nextTag++;
  }

  // The blocks, by a counting sort on (group, shape rank).
  auto shapeRank = [](std::uint8_t shape)
  {
    int rank = 0;
    while (static_cast<std::uint8_t>(ExportShapeOrder[rank]) != shape)
    {
      ++rank;
    }
    return rank;
  };
  constexpr int Ranks = 6;
  const std::size_t keys = blocks.Groups.size() * Ranks;
  std::vector<std::int64_t> starts(keys + 1, 0);
  std::vector<std::int32_t> cellKeys(static_cast<std::size_t>(mesh.NumberOfCells));
  for (std::int64_t c = 0; c < mesh.NumberOfCells; ++c)
  {
    const std::int32_t group = groupOf[mesh.Materials ? mesh.Materials[c] : 1];
    cellKeys[c] = group * Ranks + shapeRank(mesh.Shapes[c]);
    ++starts[cellKeys[c] + 1];
  }
  for (std::size_t k = 0; k < keys; ++k)
  {
    starts[k + 1] += starts[k];
    if (starts[k + 1] > starts[k])
    {
      blocks.Blocks.push_back({ static_cast<std::int32_t>(k / Ranks),
        static_cast<std::uint8_t>(ExportShapeOrder[k % Ranks]), starts[k], starts[k + 1] });
    }
  }
  blocks.Cells.resize(static_cast<std::size_t>(mesh.NumberOfCells));
  for (std::int64_t c = 0; c < mesh.NumberOfCells; ++c)
  {
    blocks.Cells[starts[cellKeys[c]]++] = c;
  }
  return Status::Ok();
}

/// The refusal of a format that holds solid elements only (`elements` lists its types) for a
/// planar mesh; Ok for solids.
inline Status SolidsOnly(const ExportBlocks& blocks, const char* format, const char* elements)
{
  if (blocks.Dimension != 2)
  {
    return Status::Ok();
  }
  return Status::Invalid(std::string("the ") + format + " export writes solid elements (" +
    elements + "), but the mesh is planar (triangles or quads); export it to Gmsh or Medit");
}

/// A name per block: its group's entry of groupNames, with "_" and the shape's FEBio type
/// appended when the group has blocks of several shapes (FEBio's parts, Exodus's blocks).
inline std::vector<std::string> BlockNames(
  const ExportBlocks& blocks, const std::vector<std::string>& groupNames)
{
  std::vector<int> shapesPerGroup(blocks.Groups.size(), 0);
  for (const ExportBlock& block : blocks.Blocks)
  {
    ++shapesPerGroup[block.Group];
  }
  std::vector<std::string> names;
  for (const ExportBlock& block : blocks.Blocks)
  {
    names.push_back(groupNames[block.Group] +
      (shapesPerGroup[block.Group] > 1 ? std::string("_") + FEBioElementType(block.Shape) : ""));
  }
  return names;
}

/// Appends numbers and text to a string: integers exactly, doubles in the shortest form that
/// reads back to the same bits (std::to_chars).
class TextChunk
{
public:
  std::string Text;

  TextChunk& Put(std::int64_t value)
  {
    char buffer[24];
    const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
    this->Text.append(buffer, result.ptr);
    return *this;
  }
  TextChunk& Put(double value)
  {
    char buffer[32];
    const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
    this->Text.append(buffer, result.ptr);
    return *this;
  }
  TextChunk& Put(const char* text)
  {
    this->Text.append(text);
    return *this;
  }
  TextChunk& Put(const std::string& text)
  {
    this->Text.append(text);
    return *this;
  }
  TextChunk& Put(char c)
  {
    this->Text.push_back(c);
    return *this;
  }
  template <class T>
  TextChunk& Raw(const T& value)
  {
    this->Text.append(reinterpret_cast<const char*>(&value), sizeof(T));
    return *this;
  }
};

/// The items a writer has written of all it writes, for the executor's progress.
struct ExportProgress
{
  std::int64_t Done = 0;
  std::int64_t Total = 0;
};

/// Writes items [0, count) in order, formatted by format(chunk, item) in chunks of `grain`
/// items on the executor's threads, a window of chunks at a time (bounded memory), and adds
/// them to `progress`. False if the stream failed or the executor was aborted.
template <class Executor, class Format>
bool WriteChunked(std::ostream& out, std::int64_t count, Executor& executor, Format&& format,
  ExportProgress& progress, std::int64_t grain = 16384)
{
  constexpr std::int64_t Window = 32;
  std::vector<TextChunk> chunks(static_cast<std::size_t>(Window));
  for (std::int64_t first = 0; first < count; first += Window * grain)
  {
    if (executor.ShouldAbort())
    {
      return false;
    }
    const std::int64_t windowChunks = std::min(Window, (count - first + grain - 1) / grain);
    struct Kernel
    {
      struct Scratch
      {
      };
      std::vector<TextChunk>* Chunks;
      std::int64_t First, Count, Grain;
      std::remove_reference_t<Format>* Formatter;
      void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
      {
        for (std::int64_t chunk = begin; chunk < end; ++chunk)
        {
          TextChunk& text = (*this->Chunks)[chunk];
          text.Text.clear();
          const std::int64_t start = this->First + chunk * this->Grain;
          const std::int64_t stop = std::min(this->Count, start + this->Grain);
          for (std::int64_t item = start; item < stop; ++item)
          {
            (*this->Formatter)(text, item);
          }
        }
      }
    };
    Kernel kernel{ &chunks, first, count, grain, &format };
    executor.For(0, windowChunks, 1, kernel);
    for (std::int64_t chunk = 0; chunk < windowChunks; ++chunk)
    {
      out.write(chunks[chunk].Text.data(), static_cast<std::streamsize>(chunks[chunk].Text.size()));
    }
    if (!out)
    {
      return false;
    }
    const std::int64_t done = progress.Done + std::min(count, first + Window * grain);
    executor.ReportProgress(
      static_cast<double>(done) / static_cast<double>(std::max(progress.Total, done)));
  }
  progress.Done += count;
  return static_cast<bool>(out);
}

/// A name as a word of letters, digits and underscores that starts with a letter (Abaqus set
/// names, FEBio part names): other characters become underscores, "M_" leads otherwise.
inline std::string WordName(const std::string& name)
{
  std::string word;
  for (const char c : name)
  {
    const bool plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9');
    word.push_back(plain ? c : '_');
  }
  if (word.empty() || !((word[0] >= 'a' && word[0] <= 'z') || (word[0] >= 'A' && word[0] <= 'Z')))
  {
    word = "M_" + word;
  }
  return word;
}

/// WordName of every group, made unique ignoring case (Abaqus folds names to upper case) by
/// appending "_<tag>" to a repeated one.
inline std::vector<std::string> UniqueWordNames(const std::vector<MaterialGroup>& groups)
{
  std::vector<std::string> words;
  std::map<std::string, int> seen;
  auto upper = [](std::string text)
  {
    for (char& c : text)
    {
      c = (c >= 'a' && c <= 'z') ? static_cast<char>(c - 'a' + 'A') : c;
    }
    return text;
  };
  for (const MaterialGroup& group : groups)
  {
    std::string word = WordName(group.Name);
    if (seen.count(upper(word)) != 0)
    {
      word += "_" + std::to_string(group.Tag);
    }
    seen[upper(word)] = 1;
    words.push_back(word);
  }
  return words;
}

} // namespace stm

#endif
