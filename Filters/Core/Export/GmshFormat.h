// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreGmshFormat_h
#define stmCoreGmshFormat_h

// Gmsh's MSH file format, version 4.1, ASCII or binary (Gmsh reference manual, "MSH file format
// version 4"). One volume entity (surface entity in 2D) per material group, each the only
// member of a physical group whose tag is the group's tag and whose name ($PhysicalNames) is the
// group's name; its bounding box is that of its cells. Every node in one block (node tag = point
// id + 1) and one element block per group and shape (element tag = cell id + 1), so a solver's
// numbers map back to the VTK mesh. Binary files use 8-byte size_t, 4-byte int and little-endian
// data (the machine's, which the "1" after the format line tells the reader).

#include "MeshExport.h"

namespace stm
{

/// Gmsh's element type of a shape (2: 3-node triangle, 3: 4-node quad, 4: 4-node tetrahedron,
/// 5: 8-node hexahedron, 6: 6-node prism, 7: 5-node pyramid).
constexpr int GmshElementType(std::uint8_t shape)
{
  switch (static_cast<ElementShape>(shape))
  {
    case ElementShape::Triangle:
      return 2;
    case ElementShape::Quad:
      return 3;
    case ElementShape::Tetra:
      return 4;
    case ElementShape::Hexahedron:
      return 5;
    case ElementShape::Wedge:
      return 6;
    case ElementShape::Pyramid:
      return 7;
  }
  return 0;
}

/// A name inside Gmsh's double quotes: a double quote becomes a single one, line breaks spaces.
inline std::string GmshQuotedName(const std::string& name)
{
  std::string quoted = "\"";
  for (const char c : name)
  {
    quoted.push_back(c == '"' ? '\'' : (c == '\n' || c == '\r') ? ' ' : c);
  }
  return quoted + "\"";
}

template <class IdType, class Executor>
Status WriteGmsh(std::ostream& out, const ExportMesh<IdType>& mesh, const ExportBlocks& blocks,
  bool binary, Executor& executor)
{
  const int dimension = blocks.Dimension == 0 ? 3 : blocks.Dimension;
  const auto groups = static_cast<std::int64_t>(blocks.Groups.size());
  using SizeT = std::uint64_t;
  TextChunk head;
  head.Put("$MeshFormat\n4.1 ").Put(std::int64_t{ binary ? 1 : 0 }).Put(" 8\n");
  if (binary)
  {
    head.Raw(std::int32_t{ 1 }).Put('\n');
  }
  head.Put("$EndMeshFormat\n$PhysicalNames\n").Put(groups).Put('\n');
  for (const MaterialGroup& group : blocks.Groups)
  {
    head.Put(std::int64_t{ dimension })
      .Put(' ')
      .Put(group.Tag)
      .Put(' ')
      .Put(GmshQuotedName(group.Name))
      .Put('\n');
  }
  head.Put("$EndPhysicalNames\n$Entities\n");

  // The entities' bounding boxes.
  std::vector<double> boxes(static_cast<std::size_t>(6 * groups), 0.0);
  std::vector<char> boxSet(static_cast<std::size_t>(groups), 0);
  for (const ExportBlock& block : blocks.Blocks)
  {
    double* box = boxes.data() + 6 * block.Group;
    for (std::int64_t i = block.Begin; i < block.End; ++i)
    {
      const std::int64_t cell = blocks.Cells[i];
      for (auto k = static_cast<std::int64_t>(mesh.Offsets[cell]); k < mesh.Offsets[cell + 1]; ++k)
      {
        const double* x = mesh.Points + 3 * static_cast<std::int64_t>(mesh.Connectivity[k]);
        for (int c = 0; c < 3; ++c)
        {
          box[c] = boxSet[block.Group] ? std::min(box[c], x[c]) : x[c];
          box[3 + c] = boxSet[block.Group] ? std::max(box[3 + c], x[c]) : x[c];
        }
        boxSet[block.Group] = 1;
      }
    }
  }
  // The four size_t counts that open the entities, nodes and elements sections: raw, or one line.
  auto putCounts = [binary](TextChunk& text, const SizeT(&counts)[4])
  {
    for (int i = 0; i < 4; ++i)
    {
      binary ? (void)text.Raw(counts[i])
             : (void)text.Put(static_cast<std::int64_t>(counts[i])).Put(i < 3 ? ' ' : '\n');
    }
  };
  SizeT counts[4] = { 0, 0, 0, 0 };
  counts[dimension] = static_cast<SizeT>(groups);
  putCounts(head, counts);
  for (std::int64_t g = 0; g < groups; ++g)
  {
    const double* box = boxes.data() + 6 * g;
    const auto physical = static_cast<std::int32_t>(blocks.Groups[g].Tag);
    if (binary)
    {
      head.Raw(static_cast<std::int32_t>(g + 1));
      for (int c = 0; c < 6; ++c)
      {
        head.Raw(box[c]);
      }
      head.Raw(SizeT{ 1 }).Raw(physical).Raw(SizeT{ 0 });
    }
    else
    {
      head.Put(g + 1);
      for (int c = 0; c < 6; ++c)
      {
        head.Put(' ').Put(box[c]);
      }
      head.Put(" 1 ").Put(std::int64_t{ physical }).Put(" 0\n");
    }
  }
  if (binary)
  {
    head.Put('\n');
  }
  head.Put("$EndEntities\n$Nodes\n");
  const std::int64_t points = mesh.NumberOfPoints;
  const auto blocksOfNodes = static_cast<SizeT>(points > 0 ? 1 : 0);
  const SizeT nodeRange[4] = { blocksOfNodes, static_cast<SizeT>(points),
    static_cast<SizeT>(points > 0 ? 1 : 0), static_cast<SizeT>(points) };
  putCounts(head, nodeRange);
  if (points > 0)
  {
    // The nodes sit on the first entity: Gmsh needs every node on one, not on the entity of
    // each element that uses it.
    if (binary)
    {
      head.Raw(std::int32_t{ dimension }).Raw(std::int32_t{ 1 }).Raw(std::int32_t{ 0 });
      head.Raw(static_cast<SizeT>(points));
    }
    else
    {
      head.Put(std::int64_t{ dimension }).Put(" 1 0 ").Put(points).Put('\n');
    }
  }
  out.write(head.Text.data(), static_cast<std::streamsize>(head.Text.size()));
  ExportProgress progress;
  progress.Total = 2 * mesh.NumberOfPoints + mesh.NumberOfCells;
  auto fail = [&]()
  {
    return executor.ShouldAbort() ? Status::Aborted()
                                  : Status::Invalid("writing the Gmsh file failed (disk full?)");
  };
  const bool tagsWritten = WriteChunked(
    out, points, executor,
    [binary](TextChunk& text, std::int64_t p)
    { binary ? (void)text.Raw(static_cast<SizeT>(p + 1)) : (void)text.Put(p + 1).Put('\n'); },
    progress);
  if (!tagsWritten)
  {
    return fail();
  }
  const bool pointsWritten = WriteChunked(
    out, points, executor,
    [binary, &mesh](TextChunk& text, std::int64_t p)
    {
      const double* x = mesh.Points + 3 * p;
      if (binary)
      {
        text.Raw(x[0]).Raw(x[1]).Raw(x[2]);
      }
      else
      {
        text.Put(x[0]).Put(' ').Put(x[1]).Put(' ').Put(x[2]).Put('\n');
      }
    },
    progress);
  if (!pointsWritten)
  {
    return fail();
  }
  TextChunk middle;
  if (binary)
  {
    middle.Put('\n');
  }
  middle.Put("$EndNodes\n$Elements\n");
  const std::int64_t cells = mesh.NumberOfCells;
  const SizeT elementRange[4] = { static_cast<SizeT>(blocks.Blocks.size()),
    static_cast<SizeT>(cells), static_cast<SizeT>(cells > 0 ? 1 : 0), static_cast<SizeT>(cells) };
  putCounts(middle, elementRange);
  out.write(middle.Text.data(), static_cast<std::streamsize>(middle.Text.size()));
  for (const ExportBlock& block : blocks.Blocks)
  {
    TextChunk header;
    const std::int64_t count = block.End - block.Begin;
    if (binary)
    {
      header.Raw(std::int32_t{ dimension })
        .Raw(static_cast<std::int32_t>(block.Group + 1))
        .Raw(static_cast<std::int32_t>(GmshElementType(block.Shape)))
        .Raw(static_cast<SizeT>(count));
    }
    else
    {
      header.Put(std::int64_t{ dimension })
        .Put(' ')
        .Put(std::int64_t{ block.Group + 1 })
        .Put(' ')
        .Put(std::int64_t{ GmshElementType(block.Shape) })
        .Put(' ')
        .Put(count)
        .Put('\n');
    }
    out.write(header.Text.data(), static_cast<std::streamsize>(header.Text.size()));
    const int corners = ShapeCorners(block.Shape);
    const std::uint8_t shape = block.Shape;
    const bool written = WriteChunked(
      out, count, executor,
      [&, corners, shape](TextChunk& text, std::int64_t i)
      {
        const std::int64_t cell = blocks.Cells[block.Begin + i];
        const IdType* ids = mesh.Connectivity + mesh.Offsets[cell];
        if (binary)
        {
          text.Raw(static_cast<SizeT>(cell + 1));
          for (int v = 0; v < corners; ++v)
          {
            text.Raw(static_cast<SizeT>(ids[FiniteElementCorner(shape, v)] + 1));
          }
        }
        else
        {
          text.Put(cell + 1);
          for (int v = 0; v < corners; ++v)
          {
            text.Put(' ').Put(static_cast<std::int64_t>(ids[FiniteElementCorner(shape, v)]) + 1);
          }
          text.Put('\n');
        }
      },
      progress);
    if (!written)
    {
      return fail();
    }
  }
  TextChunk tail;
  if (binary)
  {
    tail.Put('\n');
  }
  tail.Put("$EndElements\n");
  out.write(tail.Text.data(), static_cast<std::streamsize>(tail.Text.size()));
  out.flush();
  return out ? Status::Ok() : fail();
}

} // namespace stm

#endif
