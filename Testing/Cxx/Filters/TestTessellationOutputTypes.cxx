// SPDX-License-Identifier: BSD-3-Clause
// The output types and template rules of stmSpacetreeTessellate on the AAL atlas (1 mm voxels)
// and on a synthetic 2D image: HYBRID meshes (hexahedra, pyramids and tetrahedra; quads and
// triangles) are valid and exact; EXTENDED templates need fewer tetrahedra than REGULAR_FACES;
// LEAVES gives one hexahedron per body leaf and marks the hanging nodes; BoundaryLayers adds
// background cells without changing the body. The measured figures are asserted exactly, so
// that a change of the tessellation shows up here.

#include "stmFilterTestUtilities.h"

#include "vtkNIFTIImageReader.h"
#include "vtkSMPTools.h"

#include <gtest/gtest.h>

#include <fstream>
#include <future>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <string>

namespace
{
const char* const AalPath = "/usr/share/mricron/templates/aal.nii.gz";

/// The atlas, its spacetree and the trees balanced at L = 1 and 2, built once for all tests.
struct AalTrees
{
  vtkNew<vtkNIFTIImageReader> Reader;
  vtkNew<stmImageToSpacetree> Tree;
  vtkNew<stmSpacetreeBalance> Balance[2];
  std::map<long long, long long> Counts; // body labels only

  AalTrees()
  {
    this->Reader->SetFileName(AalPath);
    this->Reader->Update();
    this->Tree->SetInputConnection(this->Reader->GetOutputPort());
    // Staircase meshes (no function): the counts below are those of voxel-sized leaves.
    this->Tree->SetThinPartRefinement(stmImageToSpacetree::NO_THIN_PARTS);
    for (int level = 1; level <= 2; ++level)
    {
      this->Balance[level - 1]->SetInputConnection(this->Tree->GetOutputPort());
      this->Balance[level - 1]->SetBalanceLevel(level);
      this->Balance[level - 1]->Update();
    }
    this->Counts = stmTest::CountLabels(this->Reader->GetOutput());
    this->Counts.erase(0);
  }

  static AalTrees& Get()
  {
    static std::unique_ptr<AalTrees> trees;
    if (!trees)
    {
      trees = std::make_unique<AalTrees>();
    }
    return *trees;
  }

  /// A tessellation of the tree balanced at the given level, updated.
  vtkSmartPointer<stmSpacetreeTessellate> Tessellate(int level, int outputType,
    int templateRule = stmSpacetreeTessellate::REGULAR_FACES, int boundaryLayers = 0)
  {
    auto tessellate = vtkSmartPointer<stmSpacetreeTessellate>::New();
    tessellate->SetInputConnection(this->Balance[level - 1]->GetOutputPort());
    tessellate->SetOutputType(outputType);
    tessellate->SetTemplateRule(templateRule);
    tessellate->SetBoundaryLayers(boundaryLayers);
    tessellate->SetSeparatingFunction(stmSpacetreeTessellate::NO_FUNCTION);
    tessellate->Update();
    return tessellate;
  }
};

/// Every body label's volume equals its voxel count (1 mm^3 voxels) up to 1e-9 relative;
/// volumes of other materials (the background) are ignored when allowBackground.
void ExpectExactVolumes(const std::map<std::int64_t, double>& volumes,
  const std::map<long long, long long>& counts, bool allowBackground = false)
{
  ASSERT_EQ(volumes.size(), counts.size() + (allowBackground ? 1 : 0));
  for (const auto& entry : counts)
  {
    const double expected = static_cast<double>(entry.second);
    ASSERT_EQ(volumes.count(entry.first), 1u) << "label " << entry.first;
    EXPECT_NEAR(volumes.at(entry.first), expected, 1e-9 * expected) << "label " << entry.first;
  }
}

/// Volume of an axis-aligned cell from its bounds (hexahedra of the leaves).
double BoxVolume(vtkUnstructuredGrid* mesh, vtkIdType cell)
{
  double b[6];
  mesh->GetCellBounds(cell, b);
  return (b[1] - b[0]) * (b[3] - b[2]) * (b[5] - b[4]);
}

class AalOutputTypes : public ::testing::Test
{
protected:
  static void SetUpTestSuite()
  {
    PreviousBackend = vtkSMPTools::GetBackend();
    vtkSMPTools::SetBackend("STDThread");
  }
  static void TearDownTestSuite() { vtkSMPTools::SetBackend(PreviousBackend.c_str()); }
  void SetUp() override
  {
    if (!std::ifstream(AalPath).good())
    {
      GTEST_SKIP() << AalPath << " is missing; install Debian's mricron-data";
    }
  }
  static std::string PreviousBackend;
};
std::string AalOutputTypes::PreviousBackend;

class AalHybrid
  : public AalOutputTypes
  , public ::testing::WithParamInterface<int>
{
};

/// HYBRID at L = 1 and 2: valid, exact, with all three cell types; the share of the volume in
/// hexahedra falls with the balance level (more leaves meet finer neighbours).
TEST_P(AalHybrid, ValidExactMixedMesh)
{
  const int level = GetParam();
  AalTrees& aal = AalTrees::Get();
  auto tessellate = aal.Tessellate(level, stmSpacetreeTessellate::HYBRID);
  vtkUnstructuredGrid* mesh = tessellate->GetOutput();
  const int axes[3] = { 0, 1, 2 };
  const auto report = stmTest::CheckMesh<3>(mesh, axes, 1e-6);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  ExpectExactVolumes(report.VolumePerMaterial, aal.Counts);

  std::map<int, vtkIdType> types;
  double hexahedronVolume = 0.0;
  for (vtkIdType c = 0; c < mesh->GetNumberOfCells(); ++c)
  {
    const int type = mesh->GetCellType(c);
    ++types[type];
    if (type == VTK_HEXAHEDRON)
    {
      hexahedronVolume += BoxVolume(mesh, c);
    }
  }
  EXPECT_EQ(types.size(), 3u);
  EXPECT_GT(types[VTK_HEXAHEDRON], 0);
  EXPECT_GT(types[VTK_PYRAMID], 0);
  EXPECT_GT(types[VTK_TETRA], 0);
  const double share = hexahedronVolume / report.TotalVolume;
  std::cout << "AAL L=" << level << " HYBRID: " << mesh->GetNumberOfCells() << " cells ("
            << types[VTK_HEXAHEDRON] << " hexahedra, " << types[VTK_PYRAMID] << " pyramids, "
            << types[VTK_TETRA] << " tetrahedra), " << mesh->GetNumberOfPoints()
            << " points, share of volume in hexahedra " << std::setprecision(17) << share
            << std::endl;
  const double expectedShare = level == 1 ? 0.38566280780205531 : 0.21852417179008479;
  EXPECT_NEAR(share, expectedShare, 1e-9);
}

INSTANTIATE_TEST_SUITE_P(BalanceLevels, AalHybrid, ::testing::Values(1, 2),
  [](const ::testing::TestParamInfo<int>& info) { return "L" + std::to_string(info.param); });

/// SIMPLICIAL with EXTENDED templates at L = 1: valid, exact, and fewer tetrahedra than with
/// templates for regular faces only.
TEST_F(AalOutputTypes, ExtendedTemplatesNeedFewerCells)
{
  AalTrees& aal = AalTrees::Get();
  auto regular = aal.Tessellate(1, stmSpacetreeTessellate::SIMPLICIAL);
  const vtkIdType regularCells = regular->GetOutput()->GetNumberOfCells();
  const vtkIdType regularInserted = regular->GetNumberOfInsertedPoints();
  regular = nullptr;
  auto extended =
    aal.Tessellate(1, stmSpacetreeTessellate::SIMPLICIAL, stmSpacetreeTessellate::EXTENDED);
  vtkUnstructuredGrid* mesh = extended->GetOutput();
  std::cout << "AAL L=1 SIMPLICIAL: REGULAR_FACES " << regularCells << " cells, " << regularInserted
            << " inserted points; EXTENDED " << mesh->GetNumberOfCells() << " cells, "
            << extended->GetNumberOfInsertedPoints() << " inserted points" << std::endl;
  EXPECT_EQ(regularCells, 4650454);
  EXPECT_EQ(regularInserted, 269709);
  EXPECT_EQ(mesh->GetNumberOfCells(), 3291087);
  EXPECT_EQ(extended->GetNumberOfInsertedPoints(), 28445);
  EXPECT_LT(mesh->GetNumberOfCells(), regularCells);
  EXPECT_LE(extended->GetNumberOfInsertedPoints(), regularInserted);
  for (vtkIdType c = 0; c < mesh->GetNumberOfCells(); ++c)
  {
    ASSERT_EQ(mesh->GetCellType(c), VTK_TETRA);
  }
  const int axes[3] = { 0, 1, 2 };
  const auto report = stmTest::CheckMesh<3>(mesh, axes, 1e-6);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  ExpectExactVolumes(report.VolumePerMaterial, aal.Counts);
}

/// LEAVES at L = 1: one hexahedron per body leaf, exact volumes, and the hanging nodes marked.
TEST_F(AalOutputTypes, LeavesMarkHangingNodes)
{
  AalTrees& aal = AalTrees::Get();
  auto leaves = aal.Tessellate(1, stmSpacetreeTessellate::LEAVES);
  vtkUnstructuredGrid* mesh = leaves->GetOutput();
  vtkUnstructuredGrid* tree = aal.Balance[0]->GetOutput();
  vtkDataArray* treeMaterials = tree->GetCellData()->GetArray("Material");
  ASSERT_NE(treeMaterials, nullptr);
  vtkIdType bodyLeaves = 0;
  for (vtkIdType c = 0; c < tree->GetNumberOfCells(); ++c)
  {
    bodyLeaves += treeMaterials->GetComponent(c, 0) != 0 ? 1 : 0;
  }
  EXPECT_EQ(mesh->GetNumberOfCells(), bodyLeaves);

  vtkDataArray* materials = mesh->GetCellData()->GetArray("Material");
  ASSERT_NE(materials, nullptr);
  std::map<std::int64_t, double> volumes;
  for (vtkIdType c = 0; c < mesh->GetNumberOfCells(); ++c)
  {
    ASSERT_EQ(mesh->GetCellType(c), VTK_HEXAHEDRON);
    volumes[static_cast<std::int64_t>(materials->GetComponent(c, 0))] += BoxVolume(mesh, c);
  }
  ExpectExactVolumes(volumes, aal.Counts);

  vtkDataArray* hanging = mesh->GetPointData()->GetArray("HangingNode");
  ASSERT_NE(hanging, nullptr);
  ASSERT_EQ(hanging->GetNumberOfTuples(), mesh->GetNumberOfPoints());
  vtkIdType hangingNodes = 0;
  for (vtkIdType p = 0; p < hanging->GetNumberOfTuples(); ++p)
  {
    const double value = hanging->GetComponent(p, 0);
    ASSERT_TRUE(value == 0.0 || value == 1.0) << "point " << p << ": " << value;
    hangingNodes += value == 1.0 ? 1 : 0;
  }
  std::cout << "AAL L=1 LEAVES: " << mesh->GetNumberOfCells() << " hexahedra, "
            << mesh->GetNumberOfPoints() << " points, " << hangingNodes << " hanging nodes"
            << std::endl;
  EXPECT_EQ(hangingNodes, 354891);
}

/// BoundaryLayers = 1 at L = 1: background cells (Material 0) around the body, the body's
/// labels unchanged, the whole mesh valid.
TEST_F(AalOutputTypes, BoundaryLayerKeepsTheBody)
{
  AalTrees& aal = AalTrees::Get();
  auto tessellate =
    aal.Tessellate(1, stmSpacetreeTessellate::SIMPLICIAL, stmSpacetreeTessellate::REGULAR_FACES, 1);
  vtkUnstructuredGrid* mesh = tessellate->GetOutput();
  const int axes[3] = { 0, 1, 2 };
  const auto report = stmTest::CheckMesh<3>(mesh, axes, 1e-6);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  ASSERT_EQ(report.VolumePerMaterial.count(0), 1u);
  EXPECT_GT(report.VolumePerMaterial.at(0), 0.0);
  ExpectExactVolumes(report.VolumePerMaterial, aal.Counts, true);
  std::cout << "AAL L=1 BoundaryLayers=1: " << mesh->GetNumberOfCells()
            << " cells, background volume " << report.VolumePerMaterial.at(0) << std::endl;
}

/// 2D HYBRID on the synthetic nested ellipses at L = 1 and 2: quads and triangles, valid,
/// exact areas.
TEST(TessellationOutputTypes, Hybrid2D)
{
  const int dims[3] = { 37, 29, 1 };
  const double spacing[3] = { 0.5, 0.75, 1.25 };
  const double origin[3] = { -3.0, 2.0, 7.5 };
  auto image = stmTest::MakeLabelImage(dims, spacing, origin,
    [&](int i, int j, int k) { return stmTest::NestedEllipsoids(i, j, k, dims); });
  auto counts = stmTest::CountLabels(image);
  counts.erase(0);
  const double voxel = spacing[0] * spacing[1];
  for (int level : { 1, 2 })
  {
    SCOPED_TRACE("L=" + std::to_string(level));
    stmTest::Pipeline pipeline;
    pipeline.Tessellate->SetOutputType(stmSpacetreeTessellate::HYBRID);
    vtkUnstructuredGrid* mesh = pipeline.Run(image, level);
    std::map<int, vtkIdType> types;
    for (vtkIdType c = 0; c < mesh->GetNumberOfCells(); ++c)
    {
      ++types[mesh->GetCellType(c)];
    }
    EXPECT_EQ(types.size(), 2u);
    EXPECT_GT(types[VTK_QUAD], 0);
    EXPECT_GT(types[VTK_TRIANGLE], 0);
    const int axes[2] = { 0, 1 };
    const auto report = stmTest::CheckMesh<2>(mesh, axes, 1e-6);
    EXPECT_TRUE(report.IsValid()) << report.Summary();
    ASSERT_EQ(report.VolumePerMaterial.size(), counts.size());
    for (const auto& entry : counts)
    {
      const double expected = static_cast<double>(entry.second) * voxel;
      EXPECT_NEAR(report.VolumePerMaterial.at(entry.first), expected, 1e-9 * expected)
        << "label " << entry.first;
    }
  }
}

} // namespace
