// SPDX-License-Identifier: BSD-3-Clause
// The finite-element exports: their tables, the material groups and blocks, and the exact text
// (and bytes) each format writes for a small mixed mesh, read back by a parser of the test's own.

#include "Common/Execution.h"
#include "Export/AbaqusFormat.h"
#include "Export/FEBioFormat.h"
#include "Export/GmshFormat.h"
#include "Export/LabelTable.h"
#include "Export/MeditFormat.h"
#include "Export/MeshExport.h"

#include <gtest/gtest.h>

#include <cstring>
#include <sstream>
#include <string>
#include <vector>

namespace
{
using stm::ElementShape;

// Two tetrahedra of label 3 and 0 (the background) on a shared facet, and a pyramid and a wedge
// of label 3: every rule of the exports (tags, shape order, wedge corners, collapsed pyramids).
struct SmallMesh
{
  std::vector<double> Points = { 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1, 1, 1, 0, 0.5, 0.5, 1,
    0, 0, -0.25, 1, 0, -0.25, 0, 1, -0.25 };
  std::vector<std::int32_t> Offsets = { 0, 4, 8, 13, 19 };
  // Each cell positive in VTK's orientation (the wedge's first triangle faces away from its
  // second), so Gmsh's check finds no negative volume in the file (TestExport.py).
  std::vector<std::int32_t> Connectivity = { 0, 1, 2, 3, 1, 2, 3, 4, 0, 1, 5, 2, 6, 0, 1, 2, 7, 8,
    9 };
  std::vector<std::uint8_t> Shapes = { 10, 10, 14, 13 };
  std::vector<std::int64_t> Materials = { 3, 0, 3, 3 };

  stm::ExportMesh<std::int32_t> View() const
  {
    stm::ExportMesh<std::int32_t> mesh;
    mesh.NumberOfPoints = 10;
    mesh.Points = this->Points.data();
    mesh.NumberOfCells = 4;
    mesh.Offsets = this->Offsets.data();
    mesh.Connectivity = this->Connectivity.data();
    mesh.Shapes = this->Shapes.data();
    mesh.Materials = this->Materials.data();
    return mesh;
  }
};

const std::vector<stm::MaterialName> Names = { { 3, "Left \"A\" region" }, { 7, "absent" } };

stm::ExportBlocks Blocks(const SmallMesh& small)
{
  stm::ExportBlocks blocks;
  const stm::Status status = stm::MakeExportBlocks(small.View(), Names, blocks);
  EXPECT_TRUE(status.IsOk()) << status.GetMessage();
  return blocks;
}

TEST(MeshExport, ShapeTables)
{
  // VTK's numbers: VTK_TRIANGLE 5, VTK_QUAD 9, VTK_TETRA 10, VTK_HEXAHEDRON 12, VTK_WEDGE 13,
  // VTK_PYRAMID 14 (checked against VTK's own constants by the filters' tests).
  EXPECT_EQ(stm::ShapeCorners(5), 3);
  EXPECT_EQ(stm::ShapeCorners(9), 4);
  EXPECT_EQ(stm::ShapeCorners(10), 4);
  EXPECT_EQ(stm::ShapeCorners(12), 8);
  EXPECT_EQ(stm::ShapeCorners(13), 6);
  EXPECT_EQ(stm::ShapeCorners(14), 5);
  for (int value : { 0, 1, 3, 7, 11, 15, 24, 255 })
  {
    EXPECT_EQ(stm::ShapeCorners(static_cast<std::uint8_t>(value)), 0) << value;
    EXPECT_EQ(stm::ShapeDimension(static_cast<std::uint8_t>(value)), 0) << value;
  }
  EXPECT_EQ(stm::ShapeDimension(5), 2);
  EXPECT_EQ(stm::ShapeDimension(9), 2);
  for (int value : { 10, 12, 13, 14 })
  {
    EXPECT_EQ(stm::ShapeDimension(static_cast<std::uint8_t>(value)), 3) << value;
  }
  // Only the wedge's first triangle turns (toward the second).
  const int wedge[6] = { 0, 2, 1, 3, 5, 4 };
  for (int v = 0; v < 8; ++v)
  {
    for (int value : { 5, 9, 10, 12, 14 })
    {
      if (v < stm::ShapeCorners(static_cast<std::uint8_t>(value)))
      {
        EXPECT_EQ(stm::FiniteElementCorner(static_cast<std::uint8_t>(value), v), v);
      }
    }
    if (v < 6)
    {
      EXPECT_EQ(stm::FiniteElementCorner(13, v), wedge[v]);
    }
  }
  EXPECT_EQ(stm::GmshElementType(5), 2);
  EXPECT_EQ(stm::GmshElementType(9), 3);
  EXPECT_EQ(stm::GmshElementType(10), 4);
  EXPECT_EQ(stm::GmshElementType(12), 5);
  EXPECT_EQ(stm::GmshElementType(13), 6);
  EXPECT_EQ(stm::GmshElementType(14), 7);
  EXPECT_STREQ(stm::MeditKeyword(13), "Prisms");
  EXPECT_STREQ(stm::FEBioElementType(14), "pyra5");
}

TEST(MeshExport, GroupsAndBlocks)
{
  const SmallMesh small;
  const stm::ExportBlocks blocks = Blocks(small);
  ASSERT_EQ(blocks.Groups.size(), 2u);
  EXPECT_EQ(blocks.Dimension, 3);
  // Label 0 takes the tag after the largest label (3); label 3 keeps its own.
  EXPECT_EQ(blocks.Groups[0].Label, 0);
  EXPECT_EQ(blocks.Groups[0].Tag, 4);
  EXPECT_EQ(blocks.Groups[0].Name, "Material_0");
  EXPECT_EQ(blocks.Groups[0].Cells, 1);
  EXPECT_EQ(blocks.Groups[1].Label, 3);
  EXPECT_EQ(blocks.Groups[1].Tag, 3);
  EXPECT_EQ(blocks.Groups[1].Name, "Left \"A\" region");
  EXPECT_EQ(blocks.Groups[1].Cells, 3);
  // Groups ascending, then tetrahedra, pyramids, wedges.
  ASSERT_EQ(blocks.Blocks.size(), 4u);
  const std::int32_t groups[4] = { 0, 1, 1, 1 };
  const int shapes[4] = { 10, 10, 14, 13 };
  for (int b = 0; b < 4; ++b)
  {
    EXPECT_EQ(blocks.Blocks[b].Group, groups[b]);
    EXPECT_EQ(blocks.Blocks[b].Shape, shapes[b]);
    EXPECT_EQ(blocks.Blocks[b].End - blocks.Blocks[b].Begin, 1);
  }
  EXPECT_EQ(blocks.Cells, (std::vector<std::int64_t>{ 1, 0, 2, 3 }));
  const std::vector<std::string> words = stm::UniqueWordNames(blocks.Groups);
  EXPECT_EQ(words, (std::vector<std::string>{ "Material_0", "Left__A__region" }));
  // Negative labels and 0 after the largest positive one, in ascending order; names that fold
  // to the same upper-case word get their tag.
  std::vector<stm::MaterialGroup> clash(2);
  clash[0].Name = "a-b";
  clash[0].Tag = 1;
  clash[1].Name = "A_B";
  clash[1].Tag = 2;
  EXPECT_EQ(stm::UniqueWordNames(clash), (std::vector<std::string>{ "a_b", "A_B_2" }));
  EXPECT_EQ(stm::WordName("3rd ventricle"), "M_3rd_ventricle");
  SmallMesh negative;
  negative.Materials = { -2, 0, 5, -2 };
  stm::ExportBlocks negativeBlocks;
  ASSERT_TRUE(stm::MakeExportBlocks(negative.View(), {}, negativeBlocks).IsOk());
  ASSERT_EQ(negativeBlocks.Groups.size(), 3u);
  EXPECT_EQ(negativeBlocks.Groups[0].Tag, 6);
  EXPECT_EQ(negativeBlocks.Groups[1].Tag, 7);
  EXPECT_EQ(negativeBlocks.Groups[2].Tag, 5);
  EXPECT_EQ(negativeBlocks.Groups[0].Name, "Material_-2");
}

TEST(MeshExport, RefusesBadMeshes)
{
  auto refuse = [](const SmallMesh& bad, const std::string& expected)
  {
    stm::ExportBlocks blocks;
    const stm::Status status = stm::MakeExportBlocks(bad.View(), {}, blocks);
    EXPECT_FALSE(status.IsOk()) << expected;
    EXPECT_NE(status.GetMessage().find(expected), std::string::npos) << status.GetMessage();
  };
  SmallMesh shape;
  shape.Shapes[2] = 7; // VTK_POLYGON
  refuse(shape, "VTK cell type 7");
  SmallMesh count;
  count.Shapes[2] = 12; // a hexahedron of five points
  refuse(count, "wrong number of points");
  SmallMesh id;
  id.Connectivity[5] = 10;
  refuse(id, "point id outside");
  SmallMesh nan;
  nan.Points[4] = std::nan("");
  refuse(nan, "non-finite");
  SmallMesh mixed;
  mixed.Shapes[0] = 9; // a quad among solids
  refuse(mixed, "mixes planar cells and solids");
  SmallMesh planar;
  planar.Shapes = { 9, 9, 14, 13 };
  planar.Shapes[2] = 5;
  planar.Offsets = { 0, 4, 8, 11, 14 };
  planar.Shapes[3] = 5;
  stm::ExportBlocks blocks;
  ASSERT_TRUE(stm::MakeExportBlocks(planar.View(), {}, blocks).IsOk());
  EXPECT_EQ(blocks.Dimension, 2);
  std::ostringstream out;
  stm::SequentialExecutor executor;
  const stm::Status abaqus = stm::WriteAbaqus(out, planar.View(), blocks, executor);
  EXPECT_FALSE(abaqus.IsOk());
  EXPECT_NE(abaqus.GetMessage().find("planar"), std::string::npos);
  EXPECT_FALSE(stm::WriteFEBio(out, planar.View(), blocks, executor).IsOk());
}

const char* const ExpectedGmsh = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
2
3 4 "Material_0"
3 3 "Left 'A' region"
$EndPhysicalNames
$Entities
0 0 0 2
1 0 0 0 1 1 1 1 4 0
2 0 0 -0.25 1 1 1 1 3 0
$EndEntities
$Nodes
1 10 1 10
3 1 0 10
1
2
3
4
5
6
7
8
9
10
0 0 0
1 0 0
0 1 0
0 0 1
1 1 1
1 1 0
0.5 0.5 1
0 0 -0.25
1 0 -0.25
0 1 -0.25
$EndNodes
$Elements
4 4 1 4
3 1 4 1
2 2 3 4 5
3 2 4 1
1 1 2 3 4
3 2 7 1
3 1 2 6 3 7
3 2 6 1
4 1 3 2 8 10 9
$EndElements
)";

TEST(MeshExport, GmshAscii)
{
  const SmallMesh small;
  std::ostringstream out;
  stm::SequentialExecutor executor;
  ASSERT_TRUE(stm::WriteGmsh(out, small.View(), Blocks(small), false, executor).IsOk());
  EXPECT_EQ(out.str(), ExpectedGmsh);
}

// Reads the binary file back: the same numbers as the ASCII one, in 8-byte size_t, 4-byte int
// and double.
TEST(MeshExport, GmshBinary)
{
  const SmallMesh small;
  std::ostringstream out;
  stm::SequentialExecutor executor;
  ASSERT_TRUE(stm::WriteGmsh(out, small.View(), Blocks(small), true, executor).IsOk());
  const std::string file = out.str();
  std::size_t at = 0;
  auto expectText = [&](const std::string& text)
  {
    ASSERT_EQ(file.compare(at, text.size(), text), 0) << "at " << at << ": " << text;
    at += text.size();
  };
  auto read = [&](auto value)
  {
    decltype(value) result;
    std::memcpy(&result, file.data() + at, sizeof(result));
    at += sizeof(result);
    return result;
  };
  expectText("$MeshFormat\n4.1 1 8\n");
  EXPECT_EQ(read(std::int32_t{}), 1);
  expectText("\n$EndMeshFormat\n$PhysicalNames\n2\n3 4 \"Material_0\"\n3 3 \"Left 'A' "
             "region\"\n$EndPhysicalNames\n$Entities\n");
  for (std::uint64_t count : { 0, 0, 0, 2 })
  {
    EXPECT_EQ(read(std::uint64_t{}), count);
  }
  const double boxes[2][6] = { { 0, 0, 0, 1, 1, 1 }, { 0, 0, -0.25, 1, 1, 1 } };
  for (int entity = 0; entity < 2; ++entity)
  {
    EXPECT_EQ(read(std::int32_t{}), entity + 1);
    for (double bound : boxes[entity])
    {
      EXPECT_EQ(read(double{}), bound);
    }
    EXPECT_EQ(read(std::uint64_t{}), 1u);
    EXPECT_EQ(read(std::int32_t{}), entity == 0 ? 4 : 3);
    EXPECT_EQ(read(std::uint64_t{}), 0u);
  }
  expectText("\n$EndEntities\n$Nodes\n");
  for (std::uint64_t value : { 1, 10, 1, 10 })
  {
    EXPECT_EQ(read(std::uint64_t{}), value);
  }
  EXPECT_EQ(read(std::int32_t{}), 3);
  EXPECT_EQ(read(std::int32_t{}), 1);
  EXPECT_EQ(read(std::int32_t{}), 0);
  EXPECT_EQ(read(std::uint64_t{}), 10u);
  for (std::uint64_t tag = 1; tag <= 10; ++tag)
  {
    EXPECT_EQ(read(std::uint64_t{}), tag);
  }
  for (double x : small.Points)
  {
    EXPECT_EQ(read(double{}), x);
  }
  expectText("\n$EndNodes\n$Elements\n");
  for (std::uint64_t value : { 4, 4, 1, 4 })
  {
    EXPECT_EQ(read(std::uint64_t{}), value);
  }
  const std::vector<std::vector<std::uint64_t>> elements = { { 2, 2, 3, 4, 5 }, { 1, 1, 2, 3, 4 },
    { 3, 1, 2, 6, 3, 7 }, { 4, 1, 3, 2, 8, 10, 9 } };
  const int types[4] = { 4, 4, 7, 6 };
  const int entities[4] = { 1, 2, 2, 2 };
  for (int b = 0; b < 4; ++b)
  {
    EXPECT_EQ(read(std::int32_t{}), 3);
    EXPECT_EQ(read(std::int32_t{}), entities[b]);
    EXPECT_EQ(read(std::int32_t{}), types[b]);
    EXPECT_EQ(read(std::uint64_t{}), 1u);
    for (std::uint64_t value : elements[b])
    {
      EXPECT_EQ(read(std::uint64_t{}), value);
    }
  }
  expectText("\n$EndElements\n");
  EXPECT_EQ(at, file.size());
}

TEST(MeshExport, Medit)
{
  const SmallMesh small;
  std::ostringstream out;
  stm::SequentialExecutor executor;
  ASSERT_TRUE(stm::WriteMedit(out, small.View(), Blocks(small), executor).IsOk());
  EXPECT_EQ(out.str(), R"(MeshVersionFormatted 2
# SpacetreeMesh: element references are material tags
# reference 4: Material_0 (label 0, 1 elements)
# reference 3: Left "A" region (label 3, 3 elements)
Dimension 3
Vertices
10
0 0 0 0
1 0 0 0
0 1 0 0
0 0 1 0
1 1 1 0
1 1 0 0
0.5 0.5 1 0
0 0 -0.25 0
1 0 -0.25 0
0 1 -0.25 0
Tetrahedra
2
2 3 4 5 4
1 2 3 4 3
Pyramids
1
1 2 6 3 7 3
Prisms
1
1 3 2 8 10 9 3
End
)");
}

TEST(MeshExport, Abaqus)
{
  const SmallMesh small;
  std::ostringstream out;
  stm::SequentialExecutor executor;
  ASSERT_TRUE(stm::WriteAbaqus(out, small.View(), Blocks(small), executor).IsOk());
  EXPECT_EQ(out.str(), R"(*HEADING
SpacetreeMesh mesh: 10 nodes, 4 elements, 2 element sets
** ELSET Material_0: label 0, 1 elements
** ELSET Left__A__region: label 3, 3 elements
*NODE, NSET=ALLNODES
1, 0, 0, 0
2, 1, 0, 0
3, 0, 1, 0
4, 0, 0, 1
5, 1, 1, 1
6, 1, 1, 0
7, 0.5, 0.5, 1
8, 0, 0, -0.25
9, 1, 0, -0.25
10, 0, 1, -0.25
*ELEMENT, TYPE=C3D4, ELSET=Material_0
2, 2, 3, 4, 5
*ELEMENT, TYPE=C3D4, ELSET=Left__A__region
1, 1, 2, 3, 4
*ELEMENT, TYPE=C3D8, ELSET=Left__A__region
3, 1, 2, 6, 3, 7, 7, 7, 7
*ELEMENT, TYPE=C3D6, ELSET=Left__A__region
4, 1, 3, 2, 8, 10, 9
)");
}

TEST(MeshExport, FEBio)
{
  const SmallMesh small;
  std::ostringstream out;
  stm::SequentialExecutor executor;
  ASSERT_TRUE(stm::WriteFEBio(out, small.View(), Blocks(small), executor).IsOk());
  const std::string text = out.str();
  EXPECT_EQ(text.rfind("<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n<febio_spec "
                       "version=\"4.0\">\n\t<Module type=\"solid\"/>\n",
              0),
    0u);
  for (const char* part :
    { "<material id=\"1\" name=\"Material_0\" type=\"neo-Hookean\">",
      "<!-- Left &quot;A&quot; region, label 3, 3 elements -->",
      "<Nodes name=\"AllNodes\">\n\t\t\t<node id=\"1\">0,0,0</node>\n",
      "<node id=\"10\">0,1,-0.25</node>\n\t\t</Nodes>\n",
      "<Elements type=\"tet4\" name=\"Material_0\">\n\t\t\t<elem id=\"2\">2,3,4,5</elem>\n",
      "<Elements type=\"tet4\" name=\"Left__A__region_tet4\">\n\t\t\t<elem id=\"1\">1,2,3,4</elem>",
      "<Elements type=\"pyra5\" name=\"Left__A__region_pyra5\">\n\t\t\t<elem "
      "id=\"3\">1,2,6,3,7</elem>",
      "<Elements type=\"penta6\" name=\"Left__A__region_penta6\">\n\t\t\t<elem "
      "id=\"4\">1,3,2,8,10,9</elem>",
      "<MeshDomains>\n\t\t<SolidDomain name=\"Material_0\" mat=\"Material_0\"/>\n\t\t<SolidDomain "
      "name=\"Left__A__region_tet4\" mat=\"Left__A__region\"/>\n",
      "</MeshDomains>\n</febio_spec>\n" })
  {
    EXPECT_NE(text.find(part), std::string::npos) << part;
  }
  // Material before Mesh before MeshDomains, as FEBio reads them.
  EXPECT_LT(text.find("<Material>"), text.find("<Mesh>"));
  EXPECT_LT(text.find("</Mesh>"), text.find("<MeshDomains>"));
}

// Chunks are formatted on the threads and written in order: the same bytes as one thread,
// across several windows of chunks.
TEST(MeshExport, ChunksInOrder)
{
  std::ostringstream serial, parallel;
  stm::SequentialExecutor one;
  stm::ThreadPoolExecutor two(2);
  auto format = [](stm::TextChunk& text, std::int64_t i)
  { text.Put(i).Put(' ').Put(static_cast<double>(i) / 7.0).Put('\n'); };
  stm::ExportProgress serialProgress, parallelProgress;
  ASSERT_TRUE(stm::WriteChunked(serial, 100000, one, format, serialProgress, 1000));
  ASSERT_TRUE(stm::WriteChunked(parallel, 100000, two, format, parallelProgress, 1000));
  EXPECT_EQ(serialProgress.Done, 100000);
  EXPECT_EQ(serial.str(), parallel.str());
  EXPECT_EQ(serial.str().substr(0, 27), "0 0\n1 0.14285714285714285\n2");
}
} // namespace

namespace
{
TEST(LabelTable, ReadsTheAtlasFormats)
{
  // MRIcron (aal.nii.txt), FreeSurfer's colour table, ITK-SNAP's label description; comments,
  // blank lines and Windows line ends.
  std::istringstream in("# a comment\n\n1 Precentral_L 2001\r\n  17 Left-Hippocampus 220 216 "
                        "20 0\n5  0 0 255 1 1 1 \"Third ventricle\"\n-3 Outside\n");
  std::vector<stm::MaterialName> names;
  const stm::Status status = stm::ParseLabelTable(in, names);
  ASSERT_TRUE(status.IsOk()) << status.GetMessage();
  ASSERT_EQ(names.size(), 4u);
  EXPECT_EQ(names[0].Label, 1);
  EXPECT_EQ(names[0].Name, "Precentral_L");
  EXPECT_EQ(names[1].Label, 17);
  EXPECT_EQ(names[1].Name, "Left-Hippocampus");
  EXPECT_EQ(names[2].Label, 5);
  EXPECT_EQ(names[2].Name, "Third ventricle");
  EXPECT_EQ(names[3].Label, -3);
  EXPECT_EQ(names[3].Name, "Outside");
}

TEST(LabelTable, RefusesMalformedLines)
{
  auto refuse = [](const std::string& text, const std::string& expected)
  {
    std::istringstream in(text);
    std::vector<stm::MaterialName> names;
    const stm::Status status = stm::ParseLabelTable(in, names);
    EXPECT_FALSE(status.IsOk()) << text;
    EXPECT_NE(status.GetMessage().find(expected), std::string::npos) << status.GetMessage();
  };
  refuse("1 a\nx b\n", "line 2 of the label table does not start with an integer");
  refuse("1.5 a\n", "line 1");
  refuse("99999999999999999999 a\n", "line 1");
  refuse("1 a\n2\n", "line 2 of the label table has no name");
  refuse("1 a\n1 b\n", "label 1 is named twice");
}
} // namespace
