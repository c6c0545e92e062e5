// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreFEBioFormat_h
#define stmCoreFEBioFormat_h

// FEBio's input format 4.0 (.feb, XML; FEBio user's manual, "Mesh section"): a solid module,
// one placeholder material per material group (neo-Hookean, E = 1, v = 0.3, density 1: the
// mesh does not know the tissues; FEBio needs a material per domain to read the model), the
// nodes (id = point id + 1), one Elements part per group and shape (tet4, pyra5, penta6, hex8;
// element id = cell id + 1) named after the group (with the shape's FEBio name appended when a
// group has several shapes) and one SolidDomain per part on its group's material. Solids only.

#include "MeshExport.h"

namespace stm
{

/// Text for an XML attribute value.
inline std::string XMLEscaped(const std::string& text)
{
  std::string escaped;
  for (const char c : text)
  {
    switch (c)
    {
      case '&':
        escaped += "&amp;";
        break;
      case '<':
        escaped += "&lt;";
        break;
      case '>':
        escaped += "&gt;";
        break;
      case '"':
        escaped += "&quot;";
        break;
      default:
        escaped.push_back(c);
    }
  }
  return escaped;
}

template <class IdType, class Executor>
Status WriteFEBio(
  std::ostream& out, const ExportMesh<IdType>& mesh, const ExportBlocks& blocks, Executor& executor)
{
  const Status solids = SolidsOnly(blocks, "FEBio", "tet4, pyra5, penta6, hex8");
  if (!solids.IsOk())
  {
    return solids;
  }
  const std::vector<std::string> names = UniqueWordNames(blocks.Groups);
  const std::vector<std::string> parts = BlockNames(blocks, names);
  TextChunk head;
  head.Put("<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n<febio_spec version=\"4.0\">\n");
  head.Put("\t<Module type=\"solid\"/>\n\t<Material>\n");
  head.Put("\t\t<!-- placeholders, one per material group: set each tissue's model -->\n");
  for (std::size_t g = 0; g < blocks.Groups.size(); ++g)
  {
    head.Put("\t\t<material id=\"").Put(static_cast<std::int64_t>(g + 1)).Put("\" name=\"");
    head.Put(names[g]).Put("\" type=\"neo-Hookean\">\n");
    head.Put("\t\t\t<!-- ").Put(XMLEscaped(blocks.Groups[g].Name)).Put(", label ");
    head.Put(blocks.Groups[g].Label).Put(", ").Put(blocks.Groups[g].Cells).Put(" elements -->\n");
    head.Put("\t\t\t<density>1</density>\n\t\t\t<E>1</E>\n\t\t\t<v>0.3</v>\n\t\t</material>\n");
  }
  head.Put("\t</Material>\n\t<Mesh>\n\t\t<Nodes name=\"AllNodes\">\n");
  out.write(head.Text.data(), static_cast<std::streamsize>(head.Text.size()));
  ExportProgress progress;
  progress.Total = mesh.NumberOfPoints + mesh.NumberOfCells;
  auto fail = [&]()
  {
    return executor.ShouldAbort() ? Status::Aborted()
                                  : Status::Invalid("writing the FEBio file failed (disk full?)");
  };
  if (!WriteChunked(
        out, mesh.NumberOfPoints, executor,
        [&mesh](TextChunk& text, std::int64_t p)
        {
          const double* x = mesh.Points + 3 * p;
          text.Put("\t\t\t<node id=\"").Put(p + 1).Put("\">");
          text.Put(x[0]).Put(',').Put(x[1]).Put(',').Put(x[2]).Put("</node>\n");
        },
        progress))
  {
    return fail();
  }
  out << "\t\t</Nodes>\n";
  for (std::size_t b = 0; b < blocks.Blocks.size(); ++b)
  {
    const ExportBlock& block = blocks.Blocks[b];
    out << "\t\t<Elements type=\"" << FEBioElementType(block.Shape) << "\" name=\"" << parts[b]
        << "\">\n";
    const int corners = ShapeCorners(block.Shape);
    const std::uint8_t value = block.Shape;
    if (!WriteChunked(
          out, block.End - block.Begin, executor,
          [&, corners, value](TextChunk& text, std::int64_t i)
          {
            const std::int64_t cell = blocks.Cells[block.Begin + i];
            const IdType* ids = mesh.Connectivity + mesh.Offsets[cell];
            text.Put("\t\t\t<elem id=\"").Put(cell + 1).Put("\">");
            for (int v = 0; v < corners; ++v)
            {
              text.Put(v > 0 ? "," : "")
                .Put(static_cast<std::int64_t>(ids[FiniteElementCorner(value, v)]) + 1);
            }
            text.Put("</elem>\n");
          },
          progress))
    {
      return fail();
    }
    out << "\t\t</Elements>\n";
  }
  out << "\t</Mesh>\n\t<MeshDomains>\n";
  for (std::size_t b = 0; b < blocks.Blocks.size(); ++b)
  {
    out << "\t\t<SolidDomain name=\"" << parts[b] << "\" mat=\"" << names[blocks.Blocks[b].Group]
        << "\"/>\n";
  }
  out << "\t</MeshDomains>\n</febio_spec>\n";
  out.flush();
  return out ? Status::Ok() : fail();
}

} // namespace stm

#endif
