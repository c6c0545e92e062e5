// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreAbaqusFormat_h
#define stmCoreAbaqusFormat_h

// Abaqus input (.inp), the mesh part: *NODE (node number = point id + 1, in the set ALLNODES),
// then one *ELEMENT block per material group and shape with ELSET = the group's name (as an
// Abaqus word, unique ignoring case: UniqueWordNames) and element number = cell id + 1: C3D4
// tetrahedra, C3D6 wedges, C3D8 hexahedra, and pyramids as C3D8 with the apex repeated four
// times (Abaqus/Standard has no pyramid; the collapsed brick is the usual stand-in). Solids
// only: a planar mesh gets an error. No *MATERIAL or *SECTION: those are the model's, not the
// mesh's; a comment lists each set with its label and element count.

#include "MeshExport.h"

namespace stm
{

template <class IdType, class Executor>
Status WriteAbaqus(
  std::ostream& out, const ExportMesh<IdType>& mesh, const ExportBlocks& blocks, Executor& executor)
{
  const Status solids = SolidsOnly(blocks, "Abaqus", "C3D4, C3D6, C3D8");
  if (!solids.IsOk())
  {
    return solids;
  }
  const std::vector<std::string> names = UniqueWordNames(blocks.Groups);
  TextChunk head;
  head.Put("*HEADING\nSpacetreeMesh mesh: ").Put(mesh.NumberOfPoints).Put(" nodes, ");
  head.Put(mesh.NumberOfCells).Put(" elements, ");
  head.Put(static_cast<std::int64_t>(blocks.Groups.size())).Put(" element sets\n");
  for (std::size_t g = 0; g < blocks.Groups.size(); ++g)
  {
    head.Put("** ELSET ").Put(names[g]).Put(": label ").Put(blocks.Groups[g].Label);
    head.Put(", ").Put(blocks.Groups[g].Cells).Put(" elements\n");
  }
  head.Put("*NODE, NSET=ALLNODES\n");
  out.write(head.Text.data(), static_cast<std::streamsize>(head.Text.size()));
  ExportProgress progress;
  progress.Total = mesh.NumberOfPoints + mesh.NumberOfCells;
  auto fail = [&]()
  {
    return executor.ShouldAbort() ? Status::Aborted()
                                  : Status::Invalid("writing the Abaqus file failed (disk full?)");
  };
  if (!WriteChunked(
        out, mesh.NumberOfPoints, executor,
        [&mesh](TextChunk& text, std::int64_t p)
        {
          const double* x = mesh.Points + 3 * p;
          text.Put(p + 1).Put(", ").Put(x[0]).Put(", ").Put(x[1]).Put(", ").Put(x[2]).Put('\n');
        },
        progress))
  {
    return fail();
  }
  for (const ExportBlock& block : blocks.Blocks)
  {
    const auto shape = static_cast<ElementShape>(block.Shape);
    const char* type = shape == ElementShape::Tetra ? "C3D4"
      : shape == ElementShape::Wedge                ? "C3D6"
                                                    : "C3D8";
    TextChunk header;
    header.Put("*ELEMENT, TYPE=").Put(type).Put(", ELSET=").Put(names[block.Group]).Put('\n');
    out.write(header.Text.data(), static_cast<std::streamsize>(header.Text.size()));
    const int corners = ShapeCorners(block.Shape);
    const std::uint8_t value = block.Shape;
    if (!WriteChunked(
          out, block.End - block.Begin, executor,
          [&, corners, value, shape](TextChunk& text, std::int64_t i)
          {
            const std::int64_t cell = blocks.Cells[block.Begin + i];
            const IdType* ids = mesh.Connectivity + mesh.Offsets[cell];
            text.Put(cell + 1);
            for (int v = 0; v < corners; ++v)
            {
              text.Put(", ").Put(static_cast<std::int64_t>(ids[FiniteElementCorner(value, v)]) + 1);
            }
            for (int v = 0; shape == ElementShape::Pyramid && v < 3; ++v)
            {
              text.Put(", ").Put(static_cast<std::int64_t>(ids[4]) + 1);
            }
            text.Put('\n');
          },
          progress))
    {
      return fail();
    }
  }
  out.flush();
  return out ? Status::Ok() : fail();
}

} // namespace stm

#endif
