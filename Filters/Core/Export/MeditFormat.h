// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreMeditFormat_h
#define stmCoreMeditFormat_h

// Medit's ASCII .mesh format (MeshVersionFormatted 2: double precision), as Mmg, TetGen,
// CGAL and iso2mesh read it: Vertices (reference 0), then one section per shape (Tetrahedra,
// Pyramids, Prisms, Hexahedra, Triangles, Quadrilaterals) whose elements carry their material
// group's tag as reference. The format has no names; comment lines before the data list each
// reference with its name and label.

#include "MeshExport.h"

namespace stm
{

/// Medit's section keyword of a shape.
inline const char* MeditKeyword(std::uint8_t shape)
{
  switch (static_cast<ElementShape>(shape))
  {
    case ElementShape::Triangle:
      return "Triangles";
    case ElementShape::Quad:
      return "Quadrilaterals";
    case ElementShape::Tetra:
      return "Tetrahedra";
    case ElementShape::Hexahedron:
      return "Hexahedra";
    case ElementShape::Wedge:
      return "Prisms";
    case ElementShape::Pyramid:
      return "Pyramids";
  }
  return "";
}

template <class IdType, class Executor>
Status WriteMedit(
  std::ostream& out, const ExportMesh<IdType>& mesh, const ExportBlocks& blocks, Executor& executor)
{
  TextChunk head;
  head.Put("MeshVersionFormatted 2\n");
  head.Put("# SpacetreeMesh: element references are material tags\n");
  for (const MaterialGroup& group : blocks.Groups)
  {
    std::string name = group.Name;
    std::replace(name.begin(), name.end(), '\n', ' ');
    head.Put("# reference ").Put(group.Tag).Put(": ").Put(name).Put(" (label ");
    head.Put(group.Label).Put(", ").Put(group.Cells).Put(" elements)\n");
  }
  head.Put("Dimension 3\nVertices\n").Put(mesh.NumberOfPoints).Put('\n');
  out.write(head.Text.data(), static_cast<std::streamsize>(head.Text.size()));
  ExportProgress progress;
  progress.Total = mesh.NumberOfPoints + mesh.NumberOfCells;
  auto fail = [&]()
  {
    return executor.ShouldAbort() ? Status::Aborted()
                                  : Status::Invalid("writing the Medit file failed (disk full?)");
  };
  if (!WriteChunked(
        out, mesh.NumberOfPoints, executor,
        [&mesh](TextChunk& text, std::int64_t p)
        {
          const double* x = mesh.Points + 3 * p;
          text.Put(x[0]).Put(' ').Put(x[1]).Put(' ').Put(x[2]).Put(" 0\n");
        },
        progress))
  {
    return fail();
  }
  for (const ElementShape shape : ExportShapeOrder)
  {
    const auto value = static_cast<std::uint8_t>(shape);
    std::int64_t count = 0;
    for (const ExportBlock& block : blocks.Blocks)
    {
      count += block.Shape == value ? block.End - block.Begin : 0;
    }
    if (count == 0)
    {
      continue;
    }
    TextChunk header;
    header.Put(MeditKeyword(value)).Put('\n').Put(count).Put('\n');
    out.write(header.Text.data(), static_cast<std::streamsize>(header.Text.size()));
    const int corners = ShapeCorners(value);
    for (const ExportBlock& block : blocks.Blocks)
    {
      if (block.Shape != value)
      {
        continue;
      }
      const std::int64_t tag = blocks.Groups[block.Group].Tag;
      if (!WriteChunked(
            out, block.End - block.Begin, executor,
            [&, corners, value, tag](TextChunk& text, std::int64_t i)
            {
              const std::int64_t cell = blocks.Cells[block.Begin + i];
              const IdType* ids = mesh.Connectivity + mesh.Offsets[cell];
              for (int v = 0; v < corners; ++v)
              {
                text.Put(static_cast<std::int64_t>(ids[FiniteElementCorner(value, v)]) + 1)
                  .Put(' ');
              }
              text.Put(tag).Put('\n');
            },
            progress))
      {
        return fail();
      }
    }
  }
  out << "End\n";
  out.flush();
  return out ? Status::Ok() : fail();
}

} // namespace stm

#endif
