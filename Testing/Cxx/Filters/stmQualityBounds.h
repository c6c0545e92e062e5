// SPDX-License-Identifier: BSD-3-Clause
// Quality bounds of the tessellation, proven by enumeration: every element shape a leaf can get
// in an L-balanced tree (Tessellate/ElementShapeEnumeration.h), measured with Verdict through
// vtkMeshQuality. Shared by the report generator (Benchmarks/stmQualityBounds.cxx, which writes
// docs/quality-bounds.md) and the test that holds real meshes to the bounds.

#ifndef stmQualityBounds_h
#define stmQualityBounds_h

#include "Spacetree/RefinementPlan.h"
#include "Tessellate/ElementShapeEnumeration.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCellType.h"
#include "vtkDataArray.h"
#include "vtkIdList.h"
#include "vtkMeshQuality.h"
#include "vtkNew.h"
#include "vtkPoints.h"
#include "vtkSmartPointer.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <numeric>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace stmTest
{

/// The refinement patterns the bounds cover.
enum class BoundPattern
{
  /// 2^d: every level halves every axis.
  Binary,
  /// 3^d: every level splits every axis in three.
  Ternary,
  /// The automatic pattern on voxels twice as long along the last axis (1 x 1 x 2 mm): the
  /// finest step splits the other axes only (2x2x1, 2x1 in 2D), every coarser step all axes.
  FlatFinestStep
};

inline const char* PatternName(BoundPattern pattern, int dim)
{
  switch (pattern)
  {
    case BoundPattern::Binary:
      return dim == 2 ? "2x2" : "2x2x2";
    case BoundPattern::Ternary:
      return dim == 2 ? "3x3" : "3x3x3";
    default:
      return dim == 2 ? "2x1 (auto, 1 x 2 voxels)" : "2x2x1 (auto, 1 x 1 x 2 voxels)";
  }
}

/// The enumerated cells of one case, in physical half units (integers).
template <int Dim>
struct EnumeratedCase
{
  stm::TessellationCells<Dim> Cells;
};

/// The level table of a pattern for balance level L, and the leaf levels whose cells make up
/// every shape: with isotropic patterns the shapes do not depend on the level, so one leaf
/// with L levels below it suffices; with the flat finest step every leaf level counts, and the
/// table is deep enough (L + 2 levels) that some leaf sees isotropic levels only.
template <int Dim>
stm::Status PatternLevels(BoundPattern pattern, int balanceLevel,
  std::vector<stm::LatticeIndex<Dim>>& sizes, std::vector<int>& leafLevels,
  std::array<std::int64_t, Dim>& spacing)
{
  spacing.fill(1);
  if (pattern != BoundPattern::FlatFinestStep)
  {
    sizes = stm::IsotropicCellSizes<Dim>(pattern == BoundPattern::Binary ? 2 : 3, balanceLevel + 1);
    leafLevels = { 0 };
    return stm::Status::Ok();
  }
  spacing[Dim - 1] = 2;
  stm::RefinementPlanOptions<Dim> options;
  for (int axis = 0; axis < Dim; ++axis)
  {
    options.Spacing[axis] = static_cast<double>(spacing[axis]);
  }
  options.MaxCellSize = std::int64_t{ 1 } << (balanceLevel + 1);
  stm::LatticeIndex<Dim> imageDimensions;
  imageDimensions.fill(1024);
  stm::RefinementPlan<Dim> plan;
  const stm::Status status = stm::PlanRefinement<Dim>(imageDimensions, options, plan);
  if (!status.IsOk())
  {
    return status;
  }
  sizes = plan.CellSizes;
  leafLevels.resize(sizes.size());
  std::iota(leafLevels.begin(), leafLevels.end(), 0);
  return stm::Status::Ok();
}

template <int Dim>
stm::Status EnumerateCase(BoundPattern pattern, int balanceLevel,
  const stm::ElementShapeEnumerationOptions& options, EnumeratedCase<Dim>& result)
{
  std::vector<stm::LatticeIndex<Dim>> sizes;
  std::vector<int> leafLevels;
  std::array<std::int64_t, Dim> spacing;
  stm::Status status = PatternLevels<Dim>(pattern, balanceLevel, sizes, leafLevels, spacing);
  stm::ElementShapeEnumerationOptions caseOptions = options;
  caseOptions.BalanceLevel = balanceLevel;
  result.Cells.Clear();
  for (std::size_t i = 0; i < leafLevels.size() && status.IsOk(); ++i)
  {
    status =
      stm::ElementShapeEnumerator<Dim>().Enumerate(sizes, leafLevels[i], caseOptions, result.Cells);
  }
  for (auto& point : result.Cells.Points)
  {
    for (int axis = 0; axis < Dim; ++axis)
    {
      point[axis] *= spacing[axis];
    }
  }
  return status;
}

/// VTK cell type and VTK point order (into the stored order) of a cell of the given shape:
/// the tessellator stores apexes first and cube corners in code order.
inline int VTKCellOrder(int dim, int shape, std::array<int, 8>& order)
{
  if (shape == 1)
  {
    for (int p = 0; p <= dim; ++p)
    {
      order[p] = p;
    }
    return dim == 2 ? VTK_TRIANGLE : VTK_TETRA;
  }
  if (dim == 2)
  {
    order = { 0, 1, 3, 2 };
    return VTK_QUAD;
  }
  if (shape == 2)
  {
    order = { 1, 2, 4, 3, 0 }; // base corners 0, 1, 3, 2 after the apex, then the apex
    return VTK_PYRAMID;
  }
  order = { 0, 1, 3, 2, 4, 5, 7, 6 };
  return VTK_HEXAHEDRON;
}

/// The cells as a VTK mesh (each with its own points).
template <int Dim>
vtkSmartPointer<vtkUnstructuredGrid> ToUnstructuredGrid(const stm::TessellationCells<Dim>& cells)
{
  auto grid = vtkSmartPointer<vtkUnstructuredGrid>::New();
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(cells.Points.size()));
  for (std::size_t p = 0; p < cells.Points.size(); ++p)
  {
    double x[3] = { 0, 0, 0 };
    for (int axis = 0; axis < Dim; ++axis)
    {
      x[axis] = static_cast<double>(cells.Points[p][axis]);
    }
    points->SetPoint(static_cast<vtkIdType>(p), x);
  }
  grid->SetPoints(points);
  grid->Allocate(static_cast<vtkIdType>(cells.Size()));
  vtkIdType first = 0;
  for (std::uint8_t shape : cells.Shapes)
  {
    std::array<int, 8> order{};
    const int type = VTKCellOrder(Dim, shape, order);
    const int count = stm::CellPointCount(Dim, shape);
    std::array<vtkIdType, 8> ids{};
    for (int p = 0; p < count; ++p)
    {
      ids[p] = first + order[p];
    }
    grid->InsertNextCell(type, count, ids.data());
    first += count;
  }
  return grid;
}

struct AngleRange
{
  double Smallest = 180.0;
  double Largest = 0.0;
};

namespace detail
{
/// The angle at an edge (a, b) between the half-planes towards c and d, in degrees: the
/// dihedral angle of a convex cell whose faces at that edge contain c and d.
inline double EdgeAngle(const double* a, const double* b, const double* c, const double* d)
{
  double e[3], u[3], v[3];
  for (int i = 0; i < 3; ++i)
  {
    e[i] = b[i] - a[i];
    u[i] = c[i] - a[i];
    v[i] = d[i] - a[i];
  }
  const double ee = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
  const double ue = (u[0] * e[0] + u[1] * e[1] + u[2] * e[2]) / ee;
  const double ve = (v[0] * e[0] + v[1] * e[1] + v[2] * e[2]) / ee;
  for (int i = 0; i < 3; ++i)
  {
    u[i] -= ue * e[i];
    v[i] -= ve * e[i];
  }
  const double uv = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
  const double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
  const double vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
  const double cosine = std::max(-1.0, std::min(1.0, uv / std::sqrt(uu * vv)));
  return std::acos(cosine) * 180.0 / 3.14159265358979323846;
}

/// The angle at corner a of a polygon between its edges towards b and c, in degrees.
inline double CornerAngle(const double* a, const double* b, const double* c)
{
  double u[3], v[3];
  for (int i = 0; i < 3; ++i)
  {
    u[i] = b[i] - a[i];
    v[i] = c[i] - a[i];
  }
  const double uv = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
  const double uu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
  const double vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
  const double cosine = std::max(-1.0, std::min(1.0, uv / std::sqrt(uu * vv)));
  return std::acos(cosine) * 180.0 / 3.14159265358979323846;
}
} // namespace detail

/// The smallest and largest angle over the cells of a mesh: interior angles of triangles and
/// quads, dihedral angles of tetrahedra, pyramids and hexahedra (Verdict has a largest angle
/// for polygons only).
inline AngleRange MeasureAngles(vtkUnstructuredGrid* mesh)
{
  AngleRange range;
  vtkNew<vtkIdList> ids;
  std::array<std::array<double, 3>, 8> x;
  auto take = [&range](double angle)
  {
    range.Smallest = std::min(range.Smallest, angle);
    range.Largest = std::max(range.Largest, angle);
  };
  for (vtkIdType cell = 0; cell < mesh->GetNumberOfCells(); ++cell)
  {
    const int type = mesh->GetCellType(cell);
    mesh->GetCellPoints(cell, ids);
    const int n = static_cast<int>(std::min<vtkIdType>(ids->GetNumberOfIds(), 8));
    for (int p = 0; p < n; ++p)
    {
      mesh->GetPoints()->GetPoint(ids->GetId(p), x[p].data());
    }
    switch (type)
    {
      case VTK_TRIANGLE:
      case VTK_QUAD:
        for (int p = 0; p < n; ++p)
        {
          take(detail::CornerAngle(x[p].data(), x[(p + 1) % n].data(), x[(p + n - 1) % n].data()));
        }
        break;
      case VTK_TETRA:
        for (int a = 0; a < 4; ++a)
        {
          for (int b = a + 1; b < 4; ++b)
          {
            int others[2], o = 0;
            for (int c = 0; c < 4; ++c)
            {
              if (c != a && c != b)
              {
                others[o++] = c;
              }
            }
            take(detail::EdgeAngle(
              x[a].data(), x[b].data(), x[others[0]].data(), x[others[1]].data()));
          }
        }
        break;
      case VTK_PYRAMID:
        for (int p = 0; p < 4; ++p)
        {
          const int next = (p + 1) % 4, previous = (p + 3) % 4;
          // Base edge: the base and a side; side edge from the apex: two sides.
          take(detail::EdgeAngle(x[p].data(), x[next].data(), x[previous].data(), x[4].data()));
          take(detail::EdgeAngle(x[4].data(), x[p].data(), x[next].data(), x[previous].data()));
        }
        break;
      case VTK_HEXAHEDRON:
        // The faces at an edge of a hexahedron contain the two other neighbours of its ends.
        for (int p = 0; p < 4; ++p)
        {
          const int next = (p + 1) % 4, previous = (p + 3) % 4;
          take(detail::EdgeAngle(x[p].data(), x[next].data(), x[previous].data(), x[p + 4].data()));
          take(detail::EdgeAngle(
            x[p + 4].data(), x[next + 4].data(), x[previous + 4].data(), x[p].data()));
          take(detail::EdgeAngle(x[p].data(), x[p + 4].data(), x[next].data(), x[previous].data()));
        }
        break;
      default:
        break;
    }
  }
  return range;
}

/// The worst values over the enumerated cells of one case.
struct QualityBound
{
  /// Distinct cells relative to the leaf, and distinct shapes up to similarity.
  std::size_t Cells = 0;
  std::size_t Shapes = 0;
  /// Largest Verdict condition number of the triangles, tetrahedra, quads and hexahedra
  /// (Verdict has none for pyramids).
  double WorstCondition = 0.0;
  AngleRange Angles;
  /// Smallest Verdict scaled Jacobian of the pyramids and of the hexahedra (quads in 2D); 1
  /// when there is none.
  double PyramidScaledJacobian = 1.0;
  double CubeScaledJacobian = 1.0;
};

/// Shapes up to similarity: the cell type and the squared distances between its points,
/// sorted and divided by their greatest common divisor (exact on integer points).
template <int Dim>
std::size_t CountShapes(const stm::TessellationCells<Dim>& cells)
{
  std::set<std::vector<std::int64_t>> shapes;
  std::size_t first = 0;
  for (std::uint8_t shape : cells.Shapes)
  {
    const int count = stm::CellPointCount(Dim, shape);
    std::vector<std::int64_t> key = stm::SimilarityKey<Dim>(&cells.Points[first], count);
    key.push_back(shape);
    shapes.insert(key);
    first += count;
  }
  return shapes.size();
}

/// Per-cell values of a Verdict measure: configure(filter) picks the measures per cell type.
template <class Configure>
vtkSmartPointer<vtkDataArray> VerdictValues(vtkUnstructuredGrid* mesh, Configure&& configure)
{
  vtkNew<vtkMeshQuality> quality;
  quality->SetInputData(mesh);
  configure(quality.Get());
  quality->Update();
  return vtkDataSet::SafeDownCast(quality->GetOutput())->GetCellData()->GetArray("Quality");
}

/// The worst values over the cells of a mesh (Cells and Shapes left at 0).
inline QualityBound MeasureMesh(vtkUnstructuredGrid* mesh)
{
  QualityBound bound;
  if (mesh->GetNumberOfCells() == 0)
  {
    return bound;
  }
  auto condition = VerdictValues(mesh,
    [](vtkMeshQuality* quality)
    {
      quality->SetTriangleQualityMeasureToCondition();
      quality->SetQuadQualityMeasureToCondition();
      quality->SetTetQualityMeasureToCondition();
      quality->SetHexQualityMeasureToCondition();
      quality->SetPyramidQualityMeasureToScaledJacobian();
    });
  bool simplicial = true;
  for (vtkIdType cell = 0; cell < mesh->GetNumberOfCells() && simplicial; ++cell)
  {
    const int type = mesh->GetCellType(cell);
    simplicial = type == VTK_TRIANGLE || type == VTK_TETRA;
  }
  vtkSmartPointer<vtkDataArray> scaledJacobian;
  if (!simplicial)
  {
    scaledJacobian = VerdictValues(mesh,
      [](vtkMeshQuality* quality)
      {
        quality->SetQuadQualityMeasureToScaledJacobian();
        quality->SetHexQualityMeasureToScaledJacobian();
        quality->SetPyramidQualityMeasureToScaledJacobian();
      });
  }
  for (vtkIdType cell = 0; cell < mesh->GetNumberOfCells(); ++cell)
  {
    switch (mesh->GetCellType(cell))
    {
      case VTK_PYRAMID:
        bound.PyramidScaledJacobian =
          std::min(bound.PyramidScaledJacobian, scaledJacobian->GetComponent(cell, 0));
        break;
      case VTK_QUAD:
      case VTK_HEXAHEDRON:
        bound.CubeScaledJacobian =
          std::min(bound.CubeScaledJacobian, scaledJacobian->GetComponent(cell, 0));
        bound.WorstCondition = std::max(bound.WorstCondition, condition->GetComponent(cell, 0));
        break;
      default:
        bound.WorstCondition = std::max(bound.WorstCondition, condition->GetComponent(cell, 0));
        break;
    }
  }
  bound.Angles = MeasureAngles(mesh);
  return bound;
}

template <int Dim>
QualityBound MeasureBound(const EnumeratedCase<Dim>& enumerated)
{
  QualityBound bound = MeasureMesh(ToUnstructuredGrid<Dim>(enumerated.Cells));
  bound.Cells = enumerated.Cells.Size();
  bound.Shapes = CountShapes<Dim>(enumerated.Cells);
  return bound;
}

/// The tessellation variants the report covers.
struct BoundVariant
{
  std::string Title;
  stm::ElementShapeEnumerationOptions Options;
};

inline std::vector<BoundVariant> BoundVariants()
{
  std::vector<BoundVariant> variants(5);
  variants[0].Title = "simplices, checkerboard templates for regular faces (the default)";
  variants[1].Title = "simplices, Kuhn templates for regular faces";
  variants[1].Options.Template = stm::CellTemplate::Kuhn;
  variants[2].Title = "simplices, checkerboard and extended templates";
  variants[2].Options.Templates = stm::TemplateRule::Extended;
  variants[3].Title = "simplices, midpoint rule everywhere";
  variants[3].Options.Templates = stm::TemplateRule::MidpointEverywhere;
  variants[4].Title = "hybrid";
  variants[4].Options.Output = stm::TessellationOutput::Hybrid;
  return variants;
}

constexpr int LargestBoundBalanceLevel = 4;

inline std::vector<BoundPattern> BoundPatterns()
{
  return { BoundPattern::Binary, BoundPattern::Ternary, BoundPattern::FlatFinestStep };
}

template <int Dim>
stm::Status ComputeBound(BoundPattern pattern, int balanceLevel,
  const stm::ElementShapeEnumerationOptions& options, QualityBound& bound)
{
  EnumeratedCase<Dim> enumerated;
  const stm::Status status = EnumerateCase<Dim>(pattern, balanceLevel, options, enumerated);
  if (status.IsOk())
  {
    bound = MeasureBound<Dim>(enumerated);
  }
  return status;
}

/// One row of the report: the bound of a dimension, variant (index into BoundVariants),
/// pattern and balance level.
struct BoundRow
{
  int Dimension = 3;
  int Variant = 0;
  BoundPattern Pattern = BoundPattern::Binary;
  int BalanceLevel = 1;
  QualityBound Bound;
};

/// Every row of the report, by dimension, variant, pattern and balance level.
inline stm::Status ComputeAllBounds(std::vector<BoundRow>& rows)
{
  rows.clear();
  const auto variants = BoundVariants();
  for (int dim : { 2, 3 })
  {
    for (int variant = 0; variant < static_cast<int>(variants.size()); ++variant)
    {
      for (BoundPattern pattern : BoundPatterns())
      {
        for (int level = 1; level <= LargestBoundBalanceLevel; ++level)
        {
          BoundRow row{ dim, variant, pattern, level, QualityBound{} };
          const auto& options = variants[variant].Options;
          const stm::Status status = dim == 2 ? ComputeBound<2>(pattern, level, options, row.Bound)
                                              : ComputeBound<3>(pattern, level, options, row.Bound);
          if (!status.IsOk())
          {
            return status;
          }
          rows.push_back(row);
        }
      }
    }
  }
  return stm::Status::Ok();
}

/// The row of a case; null if the report has none.
inline const BoundRow* FindBound(
  const std::vector<BoundRow>& rows, int dim, int variant, BoundPattern pattern, int balanceLevel)
{
  for (const BoundRow& row : rows)
  {
    if (row.Dimension == dim && row.Variant == variant && row.Pattern == pattern &&
      row.BalanceLevel == balanceLevel)
    {
      return &row;
    }
  }
  return nullptr;
}

/// Scaled Jacobians get three significant digits: the worst pyramids come close to 0.
inline std::string SignificantDigits(double value)
{
  std::ostringstream text;
  text << std::setprecision(3) << value;
  return text.str();
}

/// The table of one dimension and variant: a row per pattern and balance level.
inline std::string BoundTable(const std::vector<BoundRow>& rows, int dim, int variant)
{
  const bool hybrid = BoundVariants()[variant].Options.Output == stm::TessellationOutput::Hybrid;
  const char* angle = dim == 2 ? "angle" : "dihedral angle";
  std::ostringstream table;
  table << "| pattern | L | cells | shapes | worst condition | smallest " << angle << " | largest "
        << angle << " |";
  std::string alignment = "|---|---:|---:|---:|---:|---:|---:|";
  if (hybrid)
  {
    table << (dim == 2 ? " smallest scaled Jacobian, quads |"
                       : " smallest scaled Jacobian, pyramids | smallest scaled Jacobian, "
                         "hexahedra |");
    alignment += dim == 2 ? "---:|" : "---:|---:|";
  }
  table << "\n" << alignment << "\n";
  for (const BoundRow& row : rows)
  {
    if (row.Dimension != dim || row.Variant != variant)
    {
      continue;
    }
    const QualityBound& bound = row.Bound;
    table << "| " << PatternName(row.Pattern, dim) << " | " << row.BalanceLevel << " | "
          << bound.Cells << " | " << bound.Shapes << " | " << std::fixed << std::setprecision(3)
          << bound.WorstCondition << " | " << std::setprecision(2) << bound.Angles.Smallest << " | "
          << bound.Angles.Largest << " |";
    if (hybrid)
    {
      if (dim == 3)
      {
        table << " " << SignificantDigits(bound.PyramidScaledJacobian) << " |";
      }
      table << " " << SignificantDigits(bound.CubeScaledJacobian) << " |";
    }
    table << "\n";
  }
  return table.str();
}

/// docs/quality-bounds.md from the rows of ComputeAllBounds.
inline std::string QualityBoundsReport(const std::vector<BoundRow>& rows)
{
  std::ostringstream report;
  report
    << "# Quality bounds of the tessellation, proven by enumeration\n\n"
    << "Generated by `stmQualityBounds --output docs/quality-bounds.md` "
       "(Benchmarks/stmQualityBounds.cxx); do not edit by hand. The test "
       "`filters.QualityBounds.CommittedReportIsCurrentAndBoundsGrowWithBalanceLevel` fails "
       "when this file differs from what the program generates.\n\n"
    << "The tessellation (paper sections 2.3, 2.4) makes only finitely many element shapes for "
       "a given balance level L (paper section 4). This report enumerates them and measures the "
       "worst. A leaf C of level l in an L-balanced tree (leaves that share a point differ by at "
       "most L levels) is touched only by leaves of level at most l + L, so a face on C's "
       "boundary at canonical level m can be split, or irregular (a split edge on its "
       "boundary), only if m < l + L. Filters/Core/Tessellate/ElementShapeEnumeration.h "
       "follows the tessellator's rules face by face (split: the children's cells; unsplit and "
       "regular: the template; unsplit and irregular: the cone from the face's centre over its "
       "facets' cells, or with extended templates the cone from a corner over the shallow "
       "facets not containing it; hybrid output keeps regular faces as squares and cubes), but "
       "lets every face take every configuration its level allows, independently of its "
       "neighbours. The enumerated set is therefore a superset of the cells of every real tree, "
       "and its worst values are bounds: no mesh of an L-balanced tree with these refinement "
       "patterns has a worse element. The superset may hold cells no tree produces, so a bound "
       "may be higher than anything that occurs. The tests "
       "(Testing/Cxx/Filters/TestQualityBounds.cxx) check that every cell the tessellator makes "
       "on random balanced trees belongs to the set, and that meshes of the AAL atlas stay "
       "within the bounds.\n\n"
    << "Columns: cells, the distinct cells relative to the leaf's anchor (over the leaf levels "
       "and the anchor parities that matter); shapes, the distinct shapes up to similarity "
       "(cell type and sorted squared distances between the points); worst condition, the "
       "largest Verdict condition number (vtkMeshQuality; 1 is the equilateral simplex, the "
       "square or the cube) of the triangles, tetrahedra, quads and hexahedra (VTK's Verdict "
       "has no condition number for pyramids); smallest and largest angle, the interior angles "
       "of triangles and quads in 2D, the dihedral angles of all cells in 3D, in degrees; "
       "smallest scaled Jacobian, Verdict's, of the pyramids and hexahedra (quads in 2D) of "
       "hybrid output.\n\n"
    << "Patterns: 2x2x2 and 3x3x3 split every axis in every level (the shapes do not depend on "
       "the level, so one leaf with L levels below it gives all); 2x2x1 is the automatic "
       "pattern on 1 x 1 x 2 mm voxels, whose finest step splits x and y only and whose coarser "
       "steps split all axes, measured in millimetres over every leaf level. Other level tables "
       "(other patterns, or levels below anisotropic voxels from FinestSize) are not covered, "
       "nor are trees balanced across facets only; with balance levels per label or region, "
       "the largest one applies.\n\n"
    << "Observed values on real images are in docs/quality.md.\n";
  const auto variants = BoundVariants();
  for (int dim : { 2, 3 })
  {
    for (int variant = 0; variant < static_cast<int>(variants.size()); ++variant)
    {
      report << "\n## " << dim << "D, " << variants[variant].Title << "\n\n"
             << BoundTable(rows, dim, variant);
    }
  }
  return report.str();
}

} // namespace stmTest

#endif
