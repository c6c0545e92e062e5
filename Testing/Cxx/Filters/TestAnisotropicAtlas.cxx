// SPDX-License-Identifier: BSD-3-Clause
// The automatic refinement pattern on a real anisotropic image: the AAL atlas resampled to
// 1 x 1 x 2 mm voxels (every second axial slice), meshed with "auto" and with isotropic 2x2x2
// refinement at L = 1, 2 and 3 (Checkerboard). Both meshes are valid and exact; "auto" picks
// cubic cells down to 2 mm, needs fewer leaves and has the better worst element, and at L = 3
// also fewer tetrahedra (docs/refinement-patterns.md has the full comparison).

#include "stmFilterTestUtilities.h"
#include "stmVerdictQuality.h"

#include "vtkExtractVOI.h"
#include "vtkFieldData.h"
#include "vtkNIFTIImageReader.h"
#include "vtkSMPTools.h"

#include <gtest/gtest.h>

#include <fstream>
#include <future>
#include <iostream>
#include <map>
#include <string>
#include <vector>

namespace
{

std::vector<int> CellSizes(vtkUnstructuredGrid* tree)
{
  std::vector<int> sizes;
  vtkDataArray* array = tree->GetFieldData()->GetArray("SpacetreeCellSizes");
  for (vtkIdType i = 0; array && i < array->GetNumberOfTuples(); ++i)
  {
    sizes.push_back(static_cast<int>(array->GetComponent(i, 0)));
  }
  return sizes;
}

long long BodyLeaves(vtkUnstructuredGrid* tree)
{
  vtkDataArray* materials = tree->GetCellData()->GetArray("Material");
  long long count = 0;
  for (vtkIdType c = 0; materials && c < tree->GetNumberOfCells(); ++c)
  {
    count += materials->GetComponent(c, 0) != 0 ? 1 : 0;
  }
  return count;
}

/// The core's invariants, and every label's volume equal to its voxel count times the voxel
/// volume (2 mm^3) up to 1e-9 relative.
void ExpectValidExactMesh(const stm::MeshInvariantReport& report,
  const std::map<long long, long long>& counts, double voxel, const char* pattern)
{
  SCOPED_TRACE(pattern);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  ASSERT_EQ(report.VolumePerMaterial.size(), counts.size());
  for (const auto& entry : counts)
  {
    const double expected = static_cast<double>(entry.second) * voxel;
    EXPECT_NEAR(report.VolumePerMaterial.at(entry.first), expected, 1e-9 * expected)
      << "label " << entry.first;
  }
}

class AnisotropicAtlas : public ::testing::TestWithParam<int>
{
protected:
  static void SetUpTestSuite()
  {
    // Both cores for the pipeline and vtkMeshQuality (the default backend is sequential).
    PreviousBackend = vtkSMPTools::GetBackend();
    vtkSMPTools::SetBackend("STDThread");
    Reader = vtkNIFTIImageReader::New();
    Reader->SetFileName(stmTest::AalAtlasPath);
    Resample = vtkExtractVOI::New();
    Resample->SetInputConnection(Reader->GetOutputPort());
    Resample->SetSampleRate(1, 1, 2);
    Resample->Update();
  }
  static void TearDownTestSuite()
  {
    Resample->Delete();
    Resample = nullptr;
    Reader->Delete();
    Reader = nullptr;
    vtkSMPTools::SetBackend(PreviousBackend.c_str());
  }
  static vtkNIFTIImageReader* Reader;
  static vtkExtractVOI* Resample;
  static std::string PreviousBackend;
};
vtkNIFTIImageReader* AnisotropicAtlas::Reader = nullptr;
vtkExtractVOI* AnisotropicAtlas::Resample = nullptr;
std::string AnisotropicAtlas::PreviousBackend;

/// AAL at 1 x 1 x 2 mm: "auto" against 2x2x2 with the Checkerboard template.
TEST_P(AnisotropicAtlas, AutomaticPatternBeatsIsotropicRefinement)
{
  if (!std::ifstream(stmTest::AalAtlasPath).good())
  {
    GTEST_SKIP() << stmTest::AalAtlasPath << " is missing; install Debian's mricron-data";
  }
  vtkImageData* image = Resample->GetOutput();
  int dims[3];
  double spacing[3];
  image->GetDimensions(dims);
  image->GetSpacing(spacing);
  ASSERT_EQ(dims[0], 181);
  ASSERT_EQ(dims[1], 217);
  ASSERT_EQ(dims[2], 91);
  ASSERT_EQ(spacing[0], 1.0);
  ASSERT_EQ(spacing[1], 1.0);
  ASSERT_EQ(spacing[2], 2.0);
  auto counts = stmTest::CountLabels(image);
  counts.erase(0);
  EXPECT_EQ(counts.size(), 116u);

  stmTest::Pipeline automatic, isotropic;
  automatic.Tree->SetRefinementPattern("auto");
  isotropic.Tree->SetRefinementPattern("2x2x2");
  vtkUnstructuredGrid* automaticMesh = automatic.Run(image, GetParam());
  vtkUnstructuredGrid* isotropicMesh = isotropic.Run(image, GetParam());

  // The invariant check is sequential and the slowest part: check both meshes at once.
  const int axes[3] = { 0, 1, 2 };
  auto isotropicCheck = std::async(
    std::launch::async, [&] { return stmTest::CheckMesh<3>(isotropicMesh, axes, 1e-6); });
  const auto automaticReport = stmTest::CheckMesh<3>(automaticMesh, axes, 1e-6);
  const auto isotropicReport = isotropicCheck.get();
  ExpectValidExactMesh(automaticReport, counts, 2.0, "auto");
  ExpectValidExactMesh(isotropicReport, counts, 2.0, "2x2x2");
  ASSERT_FALSE(HasFatalFailure());

  // The level table: cubes of 16, 8, 4 and 2 mm, then 2x2x1 into the voxels; balancing keeps it.
  const std::vector<int> automaticSizes{ 16, 16, 8, 8, 8, 4, 4, 4, 2, 2, 2, 1, 1, 1, 1 };
  EXPECT_EQ(CellSizes(automatic.Tree->GetOutput()), automaticSizes);
  EXPECT_EQ(CellSizes(automatic.Balance->GetOutput()), automaticSizes);
  EXPECT_EQ(CellSizes(isotropic.Tree->GetOutput()),
    (std::vector<int>{ 16, 16, 16, 8, 8, 8, 4, 4, 4, 2, 2, 2, 1, 1, 1 }));

  const long long automaticLeaves = BodyLeaves(automatic.Balance->GetOutput());
  const long long isotropicLeaves = BodyLeaves(isotropic.Balance->GetOutput());
  const auto automaticQuality = stmTest::MeasureVerdictQuality(automaticMesh);
  const auto isotropicQuality = stmTest::MeasureVerdictQuality(isotropicMesh);
  EXPECT_LT(automaticLeaves, isotropicLeaves);
  EXPECT_LT(automaticQuality.WorstCondition, isotropicQuality.WorstCondition);
  EXPECT_GT(automaticQuality.SmallestAngle, isotropicQuality.SmallestAngle);
  if (GetParam() == 3)
  {
    EXPECT_LT(automaticMesh->GetNumberOfCells(), isotropicMesh->GetNumberOfCells());
  }
  std::cout << "L = " << GetParam() << ", auto / 2x2x2: body leaves " << automaticLeaves << " / "
            << isotropicLeaves << ", tetrahedra " << automaticMesh->GetNumberOfCells() << " / "
            << isotropicMesh->GetNumberOfCells() << ", worst condition "
            << automaticQuality.WorstCondition << " / " << isotropicQuality.WorstCondition
            << ", smallest angle " << automaticQuality.SmallestAngle << " / "
            << isotropicQuality.SmallestAngle << "\n";
}

INSTANTIATE_TEST_SUITE_P(BalanceLevels, AnisotropicAtlas, ::testing::Values(1, 2, 3),
  [](const ::testing::TestParamInfo<int>& info) { return "L" + std::to_string(info.param); });

} // namespace
