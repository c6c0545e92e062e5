// SPDX-License-Identifier: BSD-3-Clause
// The quality bounds of docs/quality-bounds.md: the enumeration of element shapes
// (Tessellate/ElementShapeEnumeration.h) checked against the tessellator itself (its cells on
// random balanced trees all belong to the enumerated set; uniform trees give exactly the
// templates; balance level 1 in 2D gives only right isosceles triangles, as the paper's
// figure 9 says), the bounds growing with L, meshes of the AAL atlas held to the bounds, and
// the committed report equal to what the generator writes now.

#include "stmFilterTestUtilities.h"
#include "stmQualityBounds.h"

#include "Balance/SpacetreeBalance.h"
#include "Common/Execution.h"
#include "Spacetree/SpacetreeBuild.h"
#include "Tessellate/ElementShapeEnumeration.h"
#include "Tessellate/SpacetreeTessellation.h"

#include "vtkExtractVOI.h"
#include "vtkNIFTIImageReader.h"
#include "vtkSMPTools.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iostream>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <unordered_set>
#include <vector>

namespace
{
const char* const AalPath = "/usr/share/mricron/templates/aal.nii.gz";
constexpr double Tolerance = 1e-6;

/// A cell as a set: its shape and its points relative to an origin, sorted.
using CellKey = std::vector<std::int64_t>;

template <int Dim>
CellKey KeyOf(const stm::LatticeIndex<Dim>* points, int shape, const stm::LatticeIndex<Dim>& origin)
{
  std::vector<stm::LatticeIndex<Dim>> relative(points, points + stm::CellPointCount(Dim, shape));
  for (auto& point : relative)
  {
    for (int axis = 0; axis < Dim; ++axis)
    {
      point[axis] -= origin[axis];
    }
  }
  std::sort(relative.begin(), relative.end());
  CellKey key{ shape };
  for (const auto& point : relative)
  {
    key.insert(key.end(), point.begin(), point.end());
  }
  return key;
}

template <int Dim>
std::set<CellKey> KeysOf(const stm::TessellationCells<Dim>& cells)
{
  std::set<CellKey> keys;
  const stm::LatticeIndex<Dim> origin{};
  std::size_t first = 0;
  for (std::uint8_t shape : cells.Shapes)
  {
    keys.insert(KeyOf<Dim>(&cells.Points[first], shape, origin));
    first += stm::CellPointCount(Dim, shape);
  }
  return keys;
}

stm::SpacetreeTessellationOptions TessellationOptions(
  const stm::ElementShapeEnumerationOptions& options)
{
  stm::SpacetreeTessellationOptions tessellation;
  tessellation.Template = options.Template;
  tessellation.Output = options.Output;
  tessellation.Templates = options.Templates;
  tessellation.IncludeBackground = true;
  return tessellation;
}

/// The cells the tessellator gives every leaf, each as a key relative to its leaf's anchor, by
/// leaf level.
template <int Dim>
std::vector<std::set<CellKey>> TessellatorCellsByLevel(
  const stm::Spacetree<Dim>& tree, const stm::ElementShapeEnumerationOptions& options)
{
  std::vector<std::set<CellKey>> cells(static_cast<std::size_t>(tree.MaxLevel) + 1);
  stm::SequentialExecutor executor;
  stm::SpacetreeTessellator<Dim> tessellator;
  const stm::Status status = tessellator.Prepare(tree, TessellationOptions(options), executor);
  EXPECT_TRUE(status.IsOk()) << status.GetMessage();
  if (!status.IsOk())
  {
    return cells;
  }
  typename stm::SpacetreeTessellator<Dim>::Scratch scratch;
  for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
  {
    const int level = tree.LeafLevels[leaf];
    const stm::LatticeIndex<Dim>& size = tree.GetCellSize(level);
    stm::LatticeIndex<Dim> origin;
    for (int axis = 0; axis < Dim; ++axis)
    {
      origin[axis] = 2 * tree.LeafAnchors[leaf][axis];
    }
    stm::TessellationCells<Dim> leafCells;
    if (tessellator.IsRegularLeaf(leaf))
    {
      const int shape = tessellator.RegularCellShape();
      for (std::uint8_t code : tessellator.RegularCellCodes(leaf))
      {
        stm::LatticeIndex<Dim> corner = origin;
        for (int axis = 0; axis < Dim; ++axis)
        {
          corner[axis] += 2 * ((code >> axis) & 1) * size[axis];
        }
        leafCells.Points.push_back(corner);
      }
      leafCells.Shapes.assign(leafCells.Points.size() / stm::CellPointCount(Dim, shape),
        static_cast<std::uint8_t>(shape));
    }
    else
    {
      scratch.LeafCells.Clear();
      tessellator.TessellateLeaf(leaf, scratch);
      leafCells = scratch.LeafCells;
    }
    std::size_t first = 0;
    for (std::uint8_t shape : leafCells.Shapes)
    {
      cells[level].insert(KeyOf<Dim>(&leafCells.Points[first], shape, origin));
      first += stm::CellPointCount(Dim, shape);
    }
  }
  return cells;
}

std::vector<std::string> VariantNames()
{
  std::vector<std::string> names;
  for (const auto& variant : stmTest::BoundVariants())
  {
    names.push_back(variant.Title);
  }
  return names;
}

// ---------------------------------------------------------------------------------------------
// The enumeration against the paper and the tessellator.

/// Paper, figure 9: "a balance level L = 1 results in perfect elements" in 2D.
TEST(QualityBounds, BalanceLevelOneGivesRightIsoscelesTrianglesIn2D)
{
  stmTest::EnumeratedCase<2> enumerated;
  const stm::Status status = stmTest::EnumerateCase<2>(
    stmTest::BoundPattern::Binary, 1, stm::ElementShapeEnumerationOptions{}, enumerated);
  ASSERT_TRUE(status.IsOk()) << status.GetMessage();
  ASSERT_GT(enumerated.Cells.Size(), 0u);
  for (std::size_t cell = 0; cell < enumerated.Cells.Size(); ++cell)
  {
    const auto* p = &enumerated.Cells.Points[3 * cell];
    std::array<std::int64_t, 3> squared;
    for (int edge = 0; edge < 3; ++edge)
    {
      const auto& a = p[edge];
      const auto& b = p[(edge + 1) % 3];
      squared[edge] = (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]);
    }
    std::sort(squared.begin(), squared.end());
    EXPECT_EQ(squared[0], squared[1]) << "cell " << cell;
    EXPECT_EQ(squared[2], 2 * squared[0]) << "cell " << cell;
  }
  const stmTest::QualityBound bound = stmTest::MeasureBound<2>(enumerated);
  EXPECT_EQ(bound.Shapes, 1u);
  EXPECT_NEAR(bound.WorstCondition, 2.0 / std::sqrt(3.0), Tolerance);
  EXPECT_NEAR(bound.Angles.Smallest, 45.0, Tolerance);
  EXPECT_NEAR(bound.Angles.Largest, 90.0, Tolerance);
}

/// Our angles agree with Verdict's where Verdict has them (smallest angles, largest triangle
/// angle).
template <int Dim>
void ExpectAnglesAgreeWithVerdict(stmTest::BoundPattern pattern, int balanceLevel)
{
  stmTest::EnumeratedCase<Dim> enumerated;
  ASSERT_TRUE(stmTest::EnumerateCase<Dim>(
    pattern, balanceLevel, stm::ElementShapeEnumerationOptions{}, enumerated)
                .IsOk());
  auto mesh = stmTest::ToUnstructuredGrid<Dim>(enumerated.Cells);
  const stmTest::AngleRange ours = stmTest::MeasureAngles(mesh);
  auto smallest = stmTest::VerdictValues(mesh,
    [](vtkMeshQuality* quality)
    {
      quality->SetTriangleQualityMeasureToMinAngle();
      quality->SetTetQualityMeasureToMinAngle();
    });
  EXPECT_NEAR(ours.Smallest, smallest->GetRange()[0], Tolerance);
  if (Dim == 2)
  {
    auto largest = stmTest::VerdictValues(
      mesh, [](vtkMeshQuality* quality) { quality->SetTriangleQualityMeasureToMaxAngle(); });
    EXPECT_NEAR(ours.Largest, largest->GetRange()[1], Tolerance);
  }
}

TEST(QualityBounds, AnglesAgreeWithVerdict)
{
  ExpectAnglesAgreeWithVerdict<2>(stmTest::BoundPattern::Ternary, 2);
  ExpectAnglesAgreeWithVerdict<3>(stmTest::BoundPattern::Binary, 3);
  ExpectAnglesAgreeWithVerdict<3>(stmTest::BoundPattern::FlatFinestStep, 2);
}

/// A tree of 2^Dim root cells of one level: every leaf is regular.
template <int Dim>
stm::Spacetree<Dim> UniformTree()
{
  stm::Spacetree<Dim> tree;
  tree.RootGridDimensions.fill(2);
  tree.ImageDimensions.fill(2);
  tree.MaterialLabels = { 0, 1 };
  for (unsigned code = 0; code < (1u << Dim); ++code)
  {
    stm::LatticeIndex<Dim> anchor;
    for (int axis = 0; axis < Dim; ++axis)
    {
      anchor[axis] = (code >> axis) & 1u;
    }
    tree.AddLeaf(0, anchor, 1);
  }
  return tree;
}

/// Balance level 0 leaves no choice: the enumeration is the templates of both parities, exactly
/// what the tessellator gives a uniform tree.
template <int Dim>
void ExpectUniformTreesGiveTheTemplates()
{
  const std::vector<std::size_t> simplicesPerCube = { Dim == 2 ? 2u : 5u, Dim == 2 ? 2u : 6u };
  const auto variants = stmTest::BoundVariants();
  for (std::size_t variant = 0; variant < variants.size(); ++variant)
  {
    SCOPED_TRACE(std::to_string(Dim) + "D, " + variants[variant].Title);
    stm::ElementShapeEnumerationOptions options = variants[variant].Options;
    options.BalanceLevel = 0;
    stm::TessellationCells<Dim> cells;
    const stm::Spacetree<Dim> tree = UniformTree<Dim>();
    const stm::Status status =
      stm::ElementShapeEnumerator<Dim>().Enumerate(tree.CellSizes, 0, options, cells);
    ASSERT_TRUE(status.IsOk()) << status.GetMessage();
    const auto tessellated = TessellatorCellsByLevel<Dim>(tree, options);
    EXPECT_EQ(KeysOf<Dim>(cells), tessellated[0]);
    switch (variant)
    {
      case 0: // checkerboard: both parities
      case 2:
        EXPECT_EQ(cells.Size(), 2 * simplicesPerCube[0]);
        break;
      case 1: // Kuhn: one way only
        EXPECT_EQ(cells.Size(), simplicesPerCube[1]);
        break;
      case 3: // the centre over the midpoint triangulation of the facets
        EXPECT_EQ(cells.Size(), Dim == 2 ? 4u : 24u);
        break;
      default: // the cube itself
        EXPECT_EQ(cells.Size(), 1u);
        break;
    }
  }
}

TEST(QualityBounds, UniformTreesGiveExactlyTheTemplates)
{
  ExpectUniformTreesGiveTheTemplates<2>();
  ExpectUniformTreesGiveTheTemplates<3>();
}

/// A random label image (boxes of three materials and isolated specks, which force level
/// jumps), its spacetree with a pattern, balanced to L.
template <int Dim>
stm::Spacetree<Dim> RandomBalancedTree(
  stmTest::BoundPattern pattern, int balanceLevel, std::int64_t extent, unsigned seed)
{
  stm::LatticeIndex<Dim> dims;
  dims.fill(extent);
  std::vector<stm::MaterialIndex> values(
    static_cast<std::size_t>(stm::NumberOfLatticeCells<Dim>(dims)), 0);
  std::mt19937 random(seed);
  auto voxel = [&](std::size_t index, int axis)
  {
    for (int a = 0; a < axis; ++a)
    {
      index /= static_cast<std::size_t>(extent);
    }
    return static_cast<std::int64_t>(index % static_cast<std::size_t>(extent));
  };
  for (int box = 0; box < 6; ++box)
  {
    stm::LatticeIndex<Dim> lower, upper;
    for (int axis = 0; axis < Dim; ++axis)
    {
      const std::int64_t a = random() % extent, b = random() % extent;
      lower[axis] = std::min(a, b);
      upper[axis] = std::max(a, b) + 1;
    }
    const auto material = static_cast<stm::MaterialIndex>(1 + random() % 3);
    for (std::size_t index = 0; index < values.size(); ++index)
    {
      bool inside = true;
      for (int axis = 0; axis < Dim; ++axis)
      {
        inside = inside && voxel(index, axis) >= lower[axis] && voxel(index, axis) < upper[axis];
      }
      values[index] = inside ? material : values[index];
    }
  }
  for (auto& value : values)
  {
    if (random() % 1000 < 8)
    {
      value = static_cast<stm::MaterialIndex>(random() % 4);
    }
  }
  stm::RefinementPlanOptions<Dim> plan;
  if (pattern == stmTest::BoundPattern::FlatFinestStep)
  {
    plan.Spacing[Dim - 1] = 2.0;
  }
  else
  {
    stm::SplitCounts<Dim> counts;
    counts.fill(pattern == stmTest::BoundPattern::Binary ? 2 : 3);
    plan.Pattern = { counts };
  }
  stm::Spacetree<Dim> tree;
  stm::SequentialExecutor executor;
  stm::Status status = stm::SpacetreeBuilder<Dim>().Build(
    stm::MaterialImage<Dim>{ dims, values.data() }, { 0, 1, 2, 3 }, plan, tree, executor);
  EXPECT_TRUE(status.IsOk()) << status.GetMessage();
  stm::SpacetreeBalanceOptions balance;
  balance.BalanceLevel = balanceLevel;
  status = stm::SpacetreeBalancer<Dim>().Balance(tree, balance, executor);
  EXPECT_TRUE(status.IsOk()) << status.GetMessage();
  return tree;
}

/// The heart of the proof: every cell the tessellator makes belongs to the enumerated set of
/// its leaf's level. With the enumeration for L - 1 instead, cells go missing (the check can
/// fail; asserted at L = 1, where every graded tree needs more than the templates).
template <int Dim>
void ExpectTessellatorCellsEnumerated(std::int64_t extent)
{
  const auto variants = stmTest::BoundVariants();
  for (stmTest::BoundPattern pattern : stmTest::BoundPatterns())
  {
    for (int level = 1; level <= 3; ++level)
    {
      const stm::Spacetree<Dim> tree =
        RandomBalancedTree<Dim>(pattern, level, extent, 11u * level + Dim);
      for (const auto& variant : variants)
      {
        SCOPED_TRACE(std::to_string(Dim) + "D, " + stmTest::PatternName(pattern, Dim) +
          ", L = " + std::to_string(level) + ", " + variant.Title);
        const auto tessellated = TessellatorCellsByLevel<Dim>(tree, variant.Options);
        std::size_t cells = 0, missing = 0, missingBelow = 0;
        for (int leafLevel = 0; leafLevel <= tree.MaxLevel; ++leafLevel)
        {
          stm::ElementShapeEnumerationOptions options = variant.Options;
          options.BalanceLevel = level;
          stm::TessellationCells<Dim> enumerated, below;
          ASSERT_TRUE(stm::ElementShapeEnumerator<Dim>()
                        .Enumerate(tree.CellSizes, leafLevel, options, enumerated)
                        .IsOk());
          options.BalanceLevel = level - 1;
          ASSERT_TRUE(stm::ElementShapeEnumerator<Dim>()
                        .Enumerate(tree.CellSizes, leafLevel, options, below)
                        .IsOk());
          const auto keys = KeysOf<Dim>(enumerated);
          const auto keysBelow = KeysOf<Dim>(below);
          for (const CellKey& key : tessellated[leafLevel])
          {
            ++cells;
            missing += keys.count(key) == 0 ? 1 : 0;
            missingBelow += keysBelow.count(key) == 0 ? 1 : 0;
          }
        }
        EXPECT_GT(cells, 0u);
        EXPECT_EQ(missing, 0u) << "of " << cells << " distinct cells";
        if (level == 1)
        {
          EXPECT_GT(missingBelow, 0u) << "the uniform enumeration holds a graded tree";
        }
      }
    }
  }
}

TEST(QualityBounds, TessellatorCellsAreEnumerated)
{
  ExpectTessellatorCellsEnumerated<2>(48);
  ExpectTessellatorCellsEnumerated<3>(20);
}

// ---------------------------------------------------------------------------------------------
// The report and real meshes.

/// One cell per class of cells equal up to translation (same type, same points in the same
/// order), in physical units: the same Verdict values and angles as the whole mesh, measured on
/// a few hundred cells instead of millions. The points of a tessellation lie on the lattice of
/// half voxels, so a cell's points relative to its first one are exact integers there.
vtkSmartPointer<vtkUnstructuredGrid> DistinctCells(
  vtkUnstructuredGrid* mesh, const double spacing[3])
{
  using Key = std::array<std::int32_t, 1 + 8 * 3>;
  struct KeyHash
  {
    std::size_t operator()(const Key& key) const
    {
      std::uint64_t hash = 1469598103934665603ull;
      for (std::int32_t value : key)
      {
        hash = (hash ^ static_cast<std::uint32_t>(value)) * 1099511628211ull;
      }
      return static_cast<std::size_t>(hash);
    }
  };
  std::unordered_set<Key, KeyHash> seen;
  auto distinct = vtkSmartPointer<vtkUnstructuredGrid>::New();
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  distinct->SetPoints(points);
  distinct->Allocate(1024);
  vtkNew<vtkIdList> ids;
  for (vtkIdType cell = 0; cell < mesh->GetNumberOfCells(); ++cell)
  {
    mesh->GetCellPoints(cell, ids);
    const int count = static_cast<int>(std::min<vtkIdType>(ids->GetNumberOfIds(), 8));
    Key key{};
    key[0] = mesh->GetCellType(cell);
    double first[3], x[3];
    mesh->GetPoint(ids->GetId(0), first);
    for (int p = 1; p < count; ++p)
    {
      mesh->GetPoint(ids->GetId(p), x);
      for (int axis = 0; axis < 3; ++axis)
      {
        key[1 + 3 * p + axis] =
          static_cast<std::int32_t>(std::lround(2.0 * (x[axis] - first[axis]) / spacing[axis]));
      }
    }
    if (!seen.insert(key).second)
    {
      continue;
    }
    std::array<vtkIdType, 8> cellIds{};
    for (int p = 0; p < count; ++p)
    {
      for (int axis = 0; axis < 3; ++axis)
      {
        x[axis] = 0.5 * key[1 + 3 * p + axis] * spacing[axis];
      }
      cellIds[p] = points->InsertNextPoint(x);
    }
    distinct->InsertNextCell(key[0], count, cellIds.data());
  }
  return distinct;
}

/// The report in one test, since it computes every bound (ctest runs each test in its own
/// process): the committed docs/quality-bounds.md equals what the generator writes now, and
/// more freedom never gives better elements (the set for L + 1 contains, up to similarity, the
/// one for L).
TEST(QualityBounds, CommittedReportIsCurrentAndBoundsGrowWithBalanceLevel)
{
  std::vector<stmTest::BoundRow> rows;
  const stm::Status status = stmTest::ComputeAllBounds(rows);
  ASSERT_TRUE(status.IsOk()) << status.GetMessage();
  for (const stmTest::BoundRow& row : rows)
  {
    const stmTest::BoundRow* previous =
      stmTest::FindBound(rows, row.Dimension, row.Variant, row.Pattern, row.BalanceLevel - 1);
    if (!previous)
    {
      continue;
    }
    SCOPED_TRACE(std::to_string(row.Dimension) + "D, " + VariantNames()[row.Variant] + ", " +
      stmTest::PatternName(row.Pattern, row.Dimension) +
      ", L = " + std::to_string(row.BalanceLevel));
    EXPECT_GE(row.Bound.WorstCondition, previous->Bound.WorstCondition - Tolerance);
    EXPECT_LE(row.Bound.Angles.Smallest, previous->Bound.Angles.Smallest + Tolerance);
    EXPECT_GE(row.Bound.Angles.Largest, previous->Bound.Angles.Largest - Tolerance);
    EXPECT_LE(row.Bound.PyramidScaledJacobian, previous->Bound.PyramidScaledJacobian + Tolerance);
    EXPECT_GE(row.Bound.Shapes, previous->Bound.Shapes);
  }

  const std::string path = std::string(SPACETREEMESH_SOURCE_DIR) + "/docs/quality-bounds.md";
  std::ifstream file(path);
  ASSERT_TRUE(file.good()) << path << " is missing; run stmQualityBounds --output " << path;
  std::ostringstream committed;
  committed << file.rdbuf();
  EXPECT_EQ(committed.str(), stmTest::QualityBoundsReport(rows))
    << path << " is out of date; regenerate it: stmQualityBounds --output " << path;
}

class AtlasQualityBounds : public ::testing::Test
{
protected:
  static void SetUpTestSuite()
  {
    // Both cores for the pipeline (the default backend is sequential).
    PreviousBackend = vtkSMPTools::GetBackend();
    vtkSMPTools::SetBackend("STDThread");
  }
  static void TearDownTestSuite() { vtkSMPTools::SetBackend(PreviousBackend.c_str()); }

  /// The bound of a case (cheap for the cases the atlas needs).
  static stmTest::QualityBound Bound(int dim, const stm::ElementShapeEnumerationOptions& options,
    stmTest::BoundPattern pattern, int balanceLevel)
  {
    stmTest::QualityBound bound;
    const stm::Status status = dim == 2
      ? stmTest::ComputeBound<2>(pattern, balanceLevel, options, bound)
      : stmTest::ComputeBound<3>(pattern, balanceLevel, options, bound);
    EXPECT_TRUE(status.IsOk()) << status.GetMessage();
    return bound;
  }

  /// A mesh no worse than the bound: condition, angles and scaled Jacobians.
  static void ExpectWithin(
    vtkUnstructuredGrid* mesh, const double spacing[3], const stmTest::QualityBound& bound)
  {
    ASSERT_GT(mesh->GetNumberOfCells(), 0);
    const auto distinct = DistinctCells(mesh, spacing);
    const stmTest::QualityBound measured = stmTest::MeasureMesh(distinct);
    EXPECT_LE(measured.WorstCondition, bound.WorstCondition + Tolerance);
    EXPECT_GE(measured.Angles.Smallest, bound.Angles.Smallest - Tolerance);
    EXPECT_LE(measured.Angles.Largest, bound.Angles.Largest + Tolerance);
    EXPECT_GE(measured.PyramidScaledJacobian, bound.PyramidScaledJacobian - Tolerance);
    EXPECT_GE(measured.CubeScaledJacobian, bound.CubeScaledJacobian - Tolerance);
    std::cout << "  " << mesh->GetNumberOfCells() << " cells, " << distinct->GetNumberOfCells()
              << " up to translation: condition " << measured.WorstCondition
              << " <= " << bound.WorstCondition << ", angles " << measured.Angles.Smallest << " .. "
              << measured.Angles.Largest << " within " << bound.Angles.Smallest << " .. "
              << bound.Angles.Largest << "\n";
  }

  static std::string PreviousBackend;
};
std::string AtlasQualityBounds::PreviousBackend;

/// The AAL atlas (181 x 217 x 181, 1 mm, 116 labels) at L = 1 and 2, default tessellation, and
/// resampled to 1 x 1 x 2 mm with the automatic pattern (2x2x1 in the finest step) at L = 1.
TEST_F(AtlasQualityBounds, MeshesStayWithinBounds)
{
  if (!std::ifstream(AalPath).good())
  {
    GTEST_SKIP() << AalPath << " is missing; install Debian's mricron-data";
  }
  vtkNew<vtkNIFTIImageReader> reader;
  reader->SetFileName(AalPath);
  reader->Update();
  for (int level : { 1, 2 })
  {
    SCOPED_TRACE("L = " + std::to_string(level));
    stmTest::Pipeline pipeline;
    vtkUnstructuredGrid* mesh = pipeline.Run(reader->GetOutput(), level);
    ExpectWithin(mesh, reader->GetOutput()->GetSpacing(),
      Bound(3, stm::ElementShapeEnumerationOptions{}, stmTest::BoundPattern::Binary, level));
  }
  vtkNew<vtkExtractVOI> resample;
  resample->SetInputConnection(reader->GetOutputPort());
  resample->SetSampleRate(1, 1, 2);
  resample->Update();
  SCOPED_TRACE("1 x 1 x 2 mm, automatic pattern, L = 1");
  stmTest::Pipeline pipeline;
  pipeline.Tree->SetRefinementPattern("auto");
  vtkUnstructuredGrid* mesh = pipeline.Run(resample->GetOutput(), 1);
  ExpectWithin(mesh, resample->GetOutput()->GetSpacing(),
    Bound(3, stm::ElementShapeEnumerationOptions{}, stmTest::BoundPattern::FlatFinestStep, 1));
}

/// Every variant through the VTK filter: an axial slice of the atlas (2D) at L = 1 to 3, and a
/// 72 x 72 x 72 block of it at L = 1 and 2.
TEST_F(AtlasQualityBounds, VariantsStayWithinBounds)
{
  if (!std::ifstream(AalPath).good())
  {
    GTEST_SKIP() << AalPath << " is missing; install Debian's mricron-data";
  }
  vtkNew<vtkNIFTIImageReader> reader;
  reader->SetFileName(AalPath);
  reader->Update();
  int dims[3];
  reader->GetOutput()->GetDimensions(dims);
  vtkNew<vtkExtractVOI> slice;
  slice->SetInputConnection(reader->GetOutputPort());
  slice->SetVOI(0, dims[0] - 1, 0, dims[1] - 1, dims[2] / 2, dims[2] / 2);
  slice->Update();
  vtkNew<vtkExtractVOI> block;
  block->SetInputConnection(reader->GetOutputPort());
  block->SetVOI(54, 125, 72, 143, 54, 125);
  block->Update();
  const auto variants = stmTest::BoundVariants();
  for (std::size_t variant = 0; variant < variants.size(); ++variant)
  {
    const auto& options = variants[variant].Options;
    for (int dim : { 2, 3 })
    {
      for (int level = 1; level <= (dim == 2 ? 3 : 2); ++level)
      {
        SCOPED_TRACE(
          std::to_string(dim) + "D, " + variants[variant].Title + ", L = " + std::to_string(level));
        stmTest::Pipeline pipeline;
        pipeline.Tessellate->SetOutputType(options.Output == stm::TessellationOutput::Hybrid
            ? stmSpacetreeTessellate::HYBRID
            : stmSpacetreeTessellate::SIMPLICIAL);
        pipeline.Tessellate->SetTemplateRule(options.Templates == stm::TemplateRule::Extended
            ? stmSpacetreeTessellate::EXTENDED
            : options.Templates == stm::TemplateRule::MidpointEverywhere
            ? stmSpacetreeTessellate::MIDPOINT_EVERYWHERE
            : stmSpacetreeTessellate::REGULAR_FACES);
        vtkUnstructuredGrid* mesh =
          pipeline.Run(dim == 2 ? slice->GetOutput() : block->GetOutput(), level,
            options.Template == stm::CellTemplate::Kuhn ? stmSpacetreeTessellate::KUHN
                                                        : stmSpacetreeTessellate::CHECKERBOARD);
        ExpectWithin(mesh, reader->GetOutput()->GetSpacing(),
          Bound(dim, options, stmTest::BoundPattern::Binary, level));
      }
    }
  }
}

} // namespace
