// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreTestUtilities_h
#define stmCoreTestUtilities_h

// Shared fixtures of the core unit tests: the dimension tag for typed tests, label images with
// reproducible random content, the build -> balance -> tessellate pipeline, and exact integer
// reference computations (voxel counts, voxel boundary faces, simplex determinants) that do not
// reuse any arithmetic of the code under test.

#include "Balance/SpacetreeBalance.h"
#include "Check/MeshInvariants.h"
#include "Check/SimplexQuality.h"
#include "Common/CubeInfo.h"
#include "Common/Determinant.h"
#include "Common/Execution.h"
#include "Common/Status.h"
#include "Cut/MarchingSimplices.h"
#include "Spacetree/Spacetree.h"
#include "Spacetree/SpacetreeBuild.h"
#include "Tessellate/SpacetreeTessellation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <iomanip>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace stmtest
{

/// Dimension tag for typed tests, the deal.II / p4est way: one test body, every dimension.
template <int D>
struct Dim
{
  static constexpr int value = D;
};

using AllDimensions = ::testing::Types<Dim<1>, Dim<2>, Dim<3>, Dim<4>>;

/// The Kuhn triangulation of an n^Dim grid of unit cubes: Dim! simplices per cube, one per
/// permutation (the path from the cube's first corner adding one axis at a time).
template <int Dim>
std::vector<std::int64_t> KuhnGrid(int n, std::int64_t& numberOfPoints)
{
  numberOfPoints = 1;
  for (int d = 0; d < Dim; ++d)
  {
    numberOfPoints *= n + 1;
  }
  auto pointId = [&](const std::array<int, Dim>& x)
  {
    std::int64_t id = 0;
    for (int d = Dim - 1; d >= 0; --d)
    {
      id = id * (n + 1) + x[d];
    }
    return id;
  };
  std::vector<std::int64_t> connectivity;
  std::int64_t cubes = 1;
  for (int d = 0; d < Dim; ++d)
  {
    cubes *= n;
  }
  for (std::int64_t cube = 0; cube < cubes; ++cube)
  {
    std::array<int, Dim> corner{};
    for (int d = 0, rest = static_cast<int>(cube); d < Dim; ++d, rest /= n)
    {
      corner[d] = rest % n;
    }
    std::array<int, Dim> axes{};
    std::iota(axes.begin(), axes.end(), 0);
    do
    {
      std::array<int, Dim> x = corner;
      connectivity.push_back(pointId(x));
      for (const int axis : axes)
      {
        ++x[axis];
        connectivity.push_back(pointId(x));
      }
    } while (std::next_permutation(axes.begin(), axes.end()));
  }
  return connectivity;
}

/// The first D entries of a list of extents, so one list of awkward sizes serves every dimension.
template <int D>
stm::LatticeIndex<D> FirstExtents(std::initializer_list<std::int64_t> extents)
{
  stm::LatticeIndex<D> dims{};
  auto value = extents.begin();
  for (int axis = 0; axis < D; ++axis, ++value)
  {
    dims[axis] = *value;
  }
  return dims;
}

template <int D>
stm::LatticeIndex<D> UniformExtents(std::int64_t extent)
{
  stm::LatticeIndex<D> dims;
  dims.fill(extent);
  return dims;
}

template <int D>
std::string ToString(const stm::LatticeIndex<D>& index)
{
  std::string text = "(";
  for (int axis = 0; axis < D; ++axis)
  {
    text += (axis ? "," : "") + std::to_string(index[axis]);
  }
  return text + ")";
}

/// Calls visit(index) for every index of the box [lower, upper), axis 0 fastest, which is the
/// linear (lattice) order used throughout the core.
template <int D, class Visitor>
void ForEachIndexInBox(
  const stm::LatticeIndex<D>& lower, const stm::LatticeIndex<D>& upper, Visitor&& visit)
{
  stm::ForEachLatticePoint<D>(
    lower, upper, [&](const stm::LatticeIndex<D>& index) { visit(index); });
}

template <int D, class Visitor>
void ForEachIndex(const stm::LatticeIndex<D>& dims, Visitor&& visit)
{
  ForEachIndexInBox<D>(stm::LatticeIndex<D>{}, dims, std::forward<Visitor>(visit));
}

/// A material image that owns its values. Reads outside the image return the background, which
/// is how the spacetree pads the root grid.
template <int D>
class LabelImage
{
public:
  explicit LabelImage(const stm::LatticeIndex<D>& dims)
    : Dimensions(dims)
    , Values(static_cast<std::size_t>(stm::NumberOfLatticeCells<D>(dims)), stm::BackgroundMaterial)
  {
  }

  const stm::LatticeIndex<D>& GetDimensions() const { return this->Dimensions; }

  bool Contains(const stm::LatticeIndex<D>& voxel) const
  {
    for (int axis = 0; axis < D; ++axis)
    {
      if (voxel[axis] < 0 || voxel[axis] >= this->Dimensions[axis])
      {
        return false;
      }
    }
    return true;
  }

  stm::MaterialIndex At(const stm::LatticeIndex<D>& voxel) const
  {
    return this->Contains(voxel) ? this->Values[stm::LinearIndex<D>(voxel, this->Dimensions)]
                                 : stm::BackgroundMaterial;
  }

  void Set(const stm::LatticeIndex<D>& voxel, stm::MaterialIndex material)
  {
    this->Values[stm::LinearIndex<D>(voxel, this->Dimensions)] = material;
  }

  std::int64_t CountVoxels(stm::MaterialIndex material) const
  {
    return std::count(this->Values.begin(), this->Values.end(), material);
  }

  std::int64_t CountBodyVoxels() const
  {
    return static_cast<std::int64_t>(this->Values.size()) -
      this->CountVoxels(stm::BackgroundMaterial);
  }

  stm::MaterialIndex LargestMaterial() const
  {
    return *std::max_element(this->Values.begin(), this->Values.end());
  }

  stm::MaterialImage<D> View() const { return { this->Dimensions, this->Values.data() }; }

  std::vector<stm::MaterialIndex>& GetValues() { return this->Values; }

private:
  stm::LatticeIndex<D> Dimensions;
  std::vector<stm::MaterialIndex> Values;
};

/// Random image: background, then random boxes of materials 1..materials (coarse leaves and
/// level jumps of every size), then isolated specks of random materials, which force the finest
/// level next to coarse regions. std::mt19937 output is fixed by the standard and only `%` is
/// applied to it, so a seed gives the same image with every standard library.
template <int D>
LabelImage<D> MakeRandomImage(
  const stm::LatticeIndex<D>& dims, unsigned seed, int materials, int boxes, int speckPerMille)
{
  LabelImage<D> image(dims);
  std::mt19937 random(seed);
  for (int box = 0; box < boxes; ++box)
  {
    stm::LatticeIndex<D> lower, upper;
    for (int axis = 0; axis < D; ++axis)
    {
      const std::int64_t a = random() % dims[axis];
      const std::int64_t b = random() % dims[axis];
      lower[axis] = std::min(a, b);
      upper[axis] = std::max(a, b) + 1;
    }
    const auto material = static_cast<stm::MaterialIndex>(1 + random() % materials);
    ForEachIndexInBox<D>(
      lower, upper, [&](const stm::LatticeIndex<D>& voxel) { image.Set(voxel, material); });
  }
  ForEachIndex<D>(dims,
    [&](const stm::LatticeIndex<D>& voxel)
    {
      if (static_cast<int>(random() % 1000) < speckPerMille)
      {
        image.Set(voxel, static_cast<stm::MaterialIndex>(random() % (materials + 1)));
      }
    });
  return image;
}

/// Label values of materials 0..count-1; deliberately not equal to the indices.
inline std::vector<std::int64_t> MaterialLabels(int count)
{
  std::vector<std::int64_t> labels;
  for (int material = 0; material < count; ++material)
  {
    labels.push_back(material == 0 ? 0 : 100 + 7 * material);
  }
  return labels;
}

/// The pattern that splits every axis into `count` in every level.
template <int D>
std::vector<stm::SplitCounts<D>> UniformPattern(int count)
{
  stm::SplitCounts<D> counts;
  counts.fill(count);
  return { counts };
}

/// Builds the spacetree of an image on a planned level table and, when balanceLevel > 0,
/// balances it.
template <int D, class Executor>
stm::Status BuildTreeWithPlan(const LabelImage<D>& image, const stm::RefinementPlanOptions<D>& plan,
  int balanceLevel, bool faceBalanceOnly, Executor& executor, stm::Spacetree<D>& tree)
{
  stm::Status status = stm::SpacetreeBuilder<D>().Build(
    image.View(), MaterialLabels(image.LargestMaterial() + 1), plan, tree, executor);
  if (!status.IsOk() || balanceLevel <= 0)
  {
    return status;
  }
  stm::SpacetreeBalanceOptions balanceOptions;
  balanceOptions.BalanceLevel = balanceLevel;
  balanceOptions.FaceBalanceOnly = faceBalanceOnly;
  return stm::SpacetreeBalancer<D>().Balance(tree, balanceOptions, executor);
}

/// Builds the 2^D spacetree of an image and, when balanceLevel > 0, balances it.
template <int D, class Executor>
stm::Status BuildTree(const LabelImage<D>& image, std::int64_t maxCellSize, int balanceLevel,
  bool faceBalanceOnly, Executor& executor, stm::Spacetree<D>& tree)
{
  stm::RefinementPlanOptions<D> plan;
  plan.MaxCellSize = maxCellSize;
  plan.Pattern = UniformPattern<D>(2);
  return BuildTreeWithPlan<D>(image, plan, balanceLevel, faceBalanceOnly, executor, tree);
}

/// The output of the tessellator, in the form the VTK layer would copy it: cells of any shape
/// (see stm::CellPointCount), simplices only for simplicial output.
template <int D>
struct TessellationMesh
{
  std::vector<std::int64_t> Connectivity;
  /// Shape j of every cell (1 simplex, D cube, in between a cone over a j-cube).
  std::vector<std::uint8_t> Shapes;
  /// Offset of every cell's first point id in Connectivity, and the total at the end.
  std::vector<std::int64_t> Offsets{ 0 };
  std::vector<stm::MaterialIndex> Materials;
  /// Point coordinates in half lattice units, indexed by point id.
  std::vector<stm::LatticeIndex<D>> HalfUnitPoints;
  /// How many times VisitPoints reported each point id (must be exactly once).
  std::vector<int> VisitCounts;

  std::int64_t GetNumberOfCells() const { return static_cast<std::int64_t>(this->Shapes.size()); }
  /// For simplicial output only (every cell has D + 1 points).
  std::int64_t GetNumberOfSimplices() const
  {
    return static_cast<std::int64_t>(this->Connectivity.size()) / (D + 1);
  }
  std::int64_t GetNumberOfPoints() const
  {
    return static_cast<std::int64_t>(this->HalfUnitPoints.size());
  }
  /// For simplicial output only: corner `corner` of simplex `simplex`.
  const stm::LatticeIndex<D>& Vertex(std::int64_t simplex, int corner) const
  {
    return this->HalfUnitPoints[this->Connectivity[simplex * (D + 1) + corner]];
  }
  int GetCellSize(std::int64_t cell) const
  {
    return static_cast<int>(this->Offsets[cell + 1] - this->Offsets[cell]);
  }
  /// Point `index` of a cell of any shape: its apexes first, then its cube corners.
  std::int64_t CellPointId(std::int64_t cell, int index) const
  {
    return this->Connectivity[this->Offsets[cell] + index];
  }
  const stm::LatticeIndex<D>& CellPoint(std::int64_t cell, int index) const
  {
    return this->HalfUnitPoints[this->CellPointId(cell, index)];
  }
  std::int64_t CountCellsOfShape(int shape) const
  {
    return std::count(this->Shapes.begin(), this->Shapes.end(), static_cast<std::uint8_t>(shape));
  }
  /// Coordinates in lattice units (voxel edge = 1): exact, since they are halves of integers.
  std::vector<double> Coordinates() const
  {
    std::vector<double> coordinates;
    coordinates.reserve(this->HalfUnitPoints.size() * D);
    for (const auto& point : this->HalfUnitPoints)
    {
      for (int axis = 0; axis < D; ++axis)
      {
        coordinates.push_back(0.5 * static_cast<double>(point[axis]));
      }
    }
    return coordinates;
  }
  std::vector<std::int64_t> MaterialsAsInt64() const
  {
    return std::vector<std::int64_t>(this->Materials.begin(), this->Materials.end());
  }
};

/// The name the simplicial tests know the mesh by.
template <int D>
using SimplicialMesh = TessellationMesh<D>;

/// Prepares and writes a tessellation with the given tessellator, which stays available for
/// its queries (CountInsertedPoints, IsHangingNode, ...).
template <int D, class Executor>
stm::Status TessellateTree(const stm::Spacetree<D>& tree,
  const stm::SpacetreeTessellationOptions& options, Executor& executor, TessellationMesh<D>& mesh,
  stm::SpacetreeTessellator<D>& tessellator)
{
  stm::Status status = tessellator.Prepare(tree, options, executor);
  if (!status.IsOk())
  {
    return status;
  }
  const std::int64_t cells = tessellator.GetNumberOfCells();
  mesh.Connectivity.assign(static_cast<std::size_t>(tessellator.GetConnectivitySize()), -1);
  mesh.Shapes.assign(static_cast<std::size_t>(cells), 0xFF);
  mesh.Materials.assign(static_cast<std::size_t>(cells), 0xFFFF);
  status = tessellator.WriteCells(
    mesh.Connectivity.data(), mesh.Shapes.data(), mesh.Materials.data(), executor);
  if (!status.IsOk())
  {
    return status;
  }
  mesh.Offsets.assign(static_cast<std::size_t>(cells) + 1, 0);
  for (std::int64_t cell = 0; cell < cells; ++cell)
  {
    const int shape = mesh.Shapes[cell];
    mesh.Offsets[cell + 1] =
      mesh.Offsets[cell] + (shape >= 1 && shape <= D ? stm::CellPointCount(D, shape) : 0);
  }
  stm::LatticeIndex<D> unset;
  unset.fill(-1);
  mesh.HalfUnitPoints.assign(static_cast<std::size_t>(tessellator.GetNumberOfPoints()), unset);
  mesh.VisitCounts.assign(static_cast<std::size_t>(tessellator.GetNumberOfPoints()), 0);
  // Each id is visited by exactly one thread, so plain writes to distinct slots are race-free.
  auto visit = [&mesh](std::int64_t id, const stm::LatticeIndex<D>& point)
  {
    if (id >= 0 && id < mesh.GetNumberOfPoints())
    {
      mesh.HalfUnitPoints[id] = point;
      ++mesh.VisitCounts[id];
    }
  };
  return tessellator.VisitPoints(visit, executor);
}

template <int D, class Executor>
stm::Status TessellateTree(const stm::Spacetree<D>& tree,
  const stm::SpacetreeTessellationOptions& options, Executor& executor, TessellationMesh<D>& mesh)
{
  stm::SpacetreeTessellator<D> tessellator;
  return TessellateTree<D>(tree, options, executor, mesh, tessellator);
}

/// Exact floating-point equality that prints both values in full when they differ (gtest's
/// EXPECT_EQ prints 63.999999999999631 as 64).
inline ::testing::AssertionResult ExactlyEqual(double actual, double expected)
{
  if (actual == expected)
  {
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure() << std::setprecision(17) << actual << " is not exactly "
                                       << expected << " (difference " << actual - expected << ")";
}

/// CheckCellMesh sums exact determinants and divides once, so its volumes and boundary measures
/// of lattice meshes are exact: the checker's values must equal the integer references.
constexpr double CheckerRelativeTolerance = 0.0;

inline ::testing::AssertionResult CheckerMeasureMatches(double checkerValue, double exactValue)
{
  const double allowed = CheckerRelativeTolerance * std::max(1.0, std::abs(exactValue));
  if (std::abs(checkerValue - exactValue) <= allowed)
  {
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure() << std::setprecision(17) << "checker value " << checkerValue
                                       << " differs from the exact " << exactValue;
}

/// Per cell, the id of its connected component (through shared facets) among the cells of its
/// label: the smallest cell id of the component.
template <int D>
std::vector<std::int64_t> CellComponentIds(
  const std::vector<std::int64_t>& cells, const std::vector<std::int64_t>& labels)
{
  const auto count = static_cast<std::int64_t>(labels.size());
  std::vector<std::int64_t> root(static_cast<std::size_t>(count));
  std::iota(root.begin(), root.end(), 0);
  std::function<std::int64_t(std::int64_t)> find = [&](std::int64_t c)
  { return root[c] == c ? c : root[c] = find(root[c]); };
  std::map<std::vector<std::int64_t>, std::int64_t> facetOwner;
  for (std::int64_t c = 0; c < count; ++c)
  {
    for (int skip = 0; skip <= D; ++skip)
    {
      std::vector<std::int64_t> facet;
      for (int v = 0; v <= D; ++v)
      {
        if (v != skip)
        {
          facet.push_back(cells[c * (D + 1) + v]);
        }
      }
      std::sort(facet.begin(), facet.end());
      const auto found = facetOwner.emplace(facet, c);
      if (!found.second && labels[found.first->second] == labels[c])
      {
        const std::int64_t a = find(c), b = find(found.first->second);
        root[std::max(a, b)] = std::min(a, b);
      }
    }
  }
  for (std::int64_t c = 0; c < count; ++c)
  {
    root[c] = find(c);
  }
  return root;
}

/// Connected components (through shared facets) of each label's cells.
template <int D>
std::map<std::int64_t, int> CellComponents(
  const std::vector<std::int64_t>& cells, const std::vector<std::int64_t>& labels)
{
  const std::vector<std::int64_t> ids = CellComponentIds<D>(cells, labels);
  std::map<std::int64_t, int> components;
  for (std::size_t c = 0; c < ids.size(); ++c)
  {
    components[labels[c]] += ids[c] == static_cast<std::int64_t>(c) ? 1 : 0;
  }
  return components;
}

/// Per voxel, the id (0, 1, ...) of its face-connected component among the voxels of its label.
template <int D>
std::vector<std::int64_t> VoxelComponentIds(const LabelImage<D>& image)
{
  const stm::LatticeIndex<D>& dims = image.GetDimensions();
  std::vector<std::int64_t> ids(static_cast<std::size_t>(stm::NumberOfLatticeCells<D>(dims)), -1);
  std::int64_t next = 0;
  ForEachIndex<D>(dims,
    [&](const stm::LatticeIndex<D>& start)
    {
      if (ids[stm::LinearIndex<D>(start, dims)] >= 0)
      {
        return;
      }
      const std::int64_t label = image.At(start);
      const std::int64_t id = next++;
      std::vector<stm::LatticeIndex<D>> stack{ start };
      ids[stm::LinearIndex<D>(start, dims)] = id;
      while (!stack.empty())
      {
        const stm::LatticeIndex<D> voxel = stack.back();
        stack.pop_back();
        for (int axis = 0; axis < D; ++axis)
        {
          for (const int step : { -1, 1 })
          {
            stm::LatticeIndex<D> neighbour = voxel;
            neighbour[axis] += step;
            if (image.Contains(neighbour) && image.At(neighbour) == label &&
              ids[stm::LinearIndex<D>(neighbour, dims)] < 0)
            {
              ids[stm::LinearIndex<D>(neighbour, dims)] = id;
              stack.push_back(neighbour);
            }
          }
        }
      }
    });
  return ids;
}

/// Face-connected components of each label's voxels.
template <int D>
std::map<std::int64_t, int> VoxelComponents(const LabelImage<D>& image)
{
  const std::vector<std::int64_t> ids = VoxelComponentIds<D>(image);
  std::map<std::int64_t, int> components;
  std::int64_t seen = -1;
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      const std::int64_t id = ids[stm::LinearIndex<D>(voxel, image.GetDimensions())];
      if (id > seen) // ids are numbered in this order
      {
        seen = id;
        ++components[image.At(voxel)];
      }
    });
  return components;
}

/// How a cut mesh (points in voxel units, D per point) keeps the voxel components: a component
/// is lost when no cell of its label has its centroid in one of its voxels, and split when such
/// cells belong to more than one connected component of the mesh that lies in it alone (a mesh
/// component reaching into two voxel components, such as the piece around the shared edge of
/// two diagonal neighbours, splits neither).
struct ComponentsKept
{
  std::int64_t Components = 0;
  std::int64_t Lost = 0;
  std::int64_t Split = 0;
};

template <int D>
ComponentsKept CheckComponentsKept(const LabelImage<D>& image, const std::vector<double>& points,
  const std::vector<std::int64_t>& cells, const std::vector<std::int64_t>& labels)
{
  const std::vector<std::int64_t> voxelIds = VoxelComponentIds<D>(image);
  const std::vector<std::int64_t> cellIds = CellComponentIds<D>(cells, labels);
  std::map<std::int64_t, std::set<std::int64_t>> pieces; // voxel component -> mesh components
  std::map<std::int64_t, std::set<std::int64_t>> reach;  // mesh component -> voxel components
  for (std::size_t c = 0; c < labels.size(); ++c)
  {
    stm::LatticeIndex<D> voxel;
    for (int axis = 0; axis < D; ++axis)
    {
      double centroid = 0.0;
      for (int k = 0; k <= D; ++k)
      {
        centroid += points[cells[c * (D + 1) + k] * D + axis] / (D + 1);
      }
      voxel[axis] = static_cast<std::int64_t>(std::floor(centroid));
    }
    if (image.Contains(voxel) && image.At(voxel) == labels[c])
    {
      const std::int64_t component = voxelIds[stm::LinearIndex<D>(voxel, image.GetDimensions())];
      pieces[component].insert(cellIds[c]);
      reach[cellIds[c]].insert(component);
    }
  }
  ComponentsKept kept;
  kept.Components = *std::max_element(voxelIds.begin(), voxelIds.end()) + 1;
  for (std::int64_t component = 0; component < kept.Components; ++component)
  {
    const auto found = pieces.find(component);
    if (found == pieces.end())
    {
      ++kept.Lost;
      continue;
    }
    const auto own = std::count_if(found->second.begin(), found->second.end(),
      [&](std::int64_t piece) { return reach[piece].size() == 1; });
    kept.Split += own > 1 ? 1 : 0;
  }
  return kept;
}

/// The largest condition number of the simplices (D + 1 point ids each, D coordinates per
/// point).
template <int D>
double WorstSimplexCondition(
  const std::vector<double>& points, const std::vector<std::int64_t>& cells)
{
  double worst = 0.0;
  for (std::size_t c = 0; c < cells.size() / (D + 1); ++c)
  {
    const double* corners[D + 1];
    for (int k = 0; k <= D; ++k)
    {
      corners[k] = points.data() + cells[c * (D + 1) + k] * D;
    }
    worst = std::max(worst, stm::MeasureSimplex<D>(corners).Condition);
  }
  return worst;
}

template <int D>
stm::MeshInvariantReport CheckMesh(const TessellationMesh<D>& mesh)
{
  const std::vector<std::int64_t> materials = mesh.MaterialsAsInt64();
  return stm::CheckCellMesh<D>(mesh.Coordinates(), mesh.Connectivity, mesh.Shapes, &materials);
}

/// Determinant by the Leibniz formula: a sum over permutations with the sign from the
/// inversion count, deliberately unlike the elimination used by the code under test.
template <int N>
std::int64_t LeibnizDeterminant(const std::array<std::array<std::int64_t, N>, N>& m)
{
  std::array<int, N> permutation;
  std::iota(permutation.begin(), permutation.end(), 0);
  std::int64_t determinant = 0;
  do
  {
    int inversions = 0;
    for (int i = 0; i < N; ++i)
    {
      for (int j = i + 1; j < N; ++j)
      {
        inversions += permutation[i] > permutation[j];
      }
    }
    std::int64_t product = 1;
    for (int row = 0; row < N; ++row)
    {
      product *= m[row][permutation[row]];
    }
    determinant += (inversions % 2 == 0) ? product : -product;
  } while (std::next_permutation(permutation.begin(), permutation.end()));
  return determinant;
}

/// D! times the signed volume of a simplex of integer points.
template <int D>
std::int64_t ScaledSignedVolume(const std::array<stm::LatticeIndex<D>, D + 1>& vertices)
{
  std::array<std::array<std::int64_t, D>, D> edges;
  for (int row = 0; row < D; ++row)
  {
    for (int axis = 0; axis < D; ++axis)
    {
      edges[row][axis] = vertices[row + 1][axis] - vertices[0][axis];
    }
  }
  return LeibnizDeterminant<D>(edges);
}

/// Exact integer measures of a mesh, in units of (half lattice unit)^D / D! for volumes and
/// (half lattice unit)^(D-1) / (D-1)! for boundary facets.
struct ExactMeasures
{
  std::map<std::int64_t, std::int64_t> ScaledVolumePerMaterial;
  std::int64_t ScaledTotalVolume = 0;
  /// Simplices of the cells' Kuhn decompositions (all of a simplex) with volume <= 0.
  std::int64_t NonPositiveSimplices = 0;
  std::int64_t BoundaryFacets = 0;
  /// Boundary facets that do not lie in a plane orthogonal to an axis; the boundary of a union
  /// of voxels has none.
  std::int64_t SkewBoundaryFacets = 0;
  std::int64_t ScaledBoundaryMeasure = 0;
};

/// Calls visit(simplex, sign) for the simplices of the Kuhn decomposition of a cone with
/// `apexes` apexes over a cube of dimension `cube` (points: apexes, then corners in code order):
/// the monotone corner paths, then the apexes; sign is that of the axis permutation, so that
/// sign times the simplex's volume is positive for a positively oriented cell.
template <int D, class Visitor>
void ForEachKuhnPiece(const stm::LatticeIndex<D>* points, int apexes, int cube, Visitor&& visit)
{
  std::array<int, D> axes{};
  std::iota(axes.begin(), axes.begin() + cube, 0);
  std::array<stm::LatticeIndex<D>, D + 1> simplex{};
  do
  {
    int corner = 0, inversions = 0;
    simplex[0] = points[apexes];
    // (The bounds by D tell the compiler what the callers guarantee.)
    for (int step = 0; step < cube && step < D; ++step)
    {
      corner |= 1 << axes[step];
      simplex[step + 1] = points[apexes + corner];
      for (int later = step + 1; later < cube && later < D; ++later)
      {
        inversions += axes[step] > axes[later];
      }
    }
    for (int apex = 0; apex < apexes && cube + 1 + apex <= D; ++apex)
    {
      simplex[cube + 1 + apex] = points[apex];
    }
    visit(static_cast<const std::array<stm::LatticeIndex<D>, D + 1>&>(simplex),
      inversions % 2 == 0 ? 1 : -1);
  } while (std::next_permutation(axes.begin(), axes.begin() + cube));
}

template <int D>
ExactMeasures ComputeExactMeasures(const TessellationMesh<D>& mesh)
{
  ExactMeasures measures;
  // Facets as sorted point id lists (padded with -1), with their structure (apex count, cube
  // dimension, points in cell order) kept for the boundary measure.
  constexpr int maxFacetPoints = D == 1 ? 1 : (1 << (D - 1));
  struct Facet
  {
    std::array<std::int64_t, maxFacetPoints> Key;
    std::array<std::int64_t, maxFacetPoints> Ids;
    int Apexes;
    int Cube;
    bool operator<(const Facet& other) const { return this->Key < other.Key; }
  };
  std::vector<Facet> facets;
  for (std::int64_t cell = 0; cell < mesh.GetNumberOfCells(); ++cell)
  {
    const int shape = mesh.Shapes[cell];
    const int apexes = D - shape;
    const int size = mesh.GetCellSize(cell);
    std::array<std::int64_t, (1 << D)> ids{};
    std::array<stm::LatticeIndex<D>, (1 << D)> points{};
    for (int i = 0; i < size && i < (1 << D); ++i)
    {
      ids[i] = mesh.CellPointId(cell, i);
      points[i] = mesh.HalfUnitPoints[ids[i]];
    }
    ForEachKuhnPiece<D>(points.data(), apexes, shape,
      [&](const std::array<stm::LatticeIndex<D>, D + 1>& simplex, int sign)
      {
        const std::int64_t volume = sign * ScaledSignedVolume<D>(simplex);
        measures.NonPositiveSimplices += volume <= 0;
        measures.ScaledVolumePerMaterial[mesh.Materials[cell]] += volume;
        measures.ScaledTotalVolume += volume;
      });
    // Facets of the cone A * Q: (A minus one apex) * Q, and A * (each facet of the cube Q),
    // where the facets of a 1-cube are its end points.
    Facet facet;
    int count = 0;
    auto addFacet = [&](int facetApexes, int facetCube)
    {
      facet.Apexes = facetApexes;
      facet.Cube = facetCube;
      facet.Key.fill(-1);
      for (int i = 0; i < count && i < maxFacetPoints; ++i) // insertion sort
      {
        int j = i;
        for (; j > 0 && facet.Key[j - 1] > facet.Ids[i]; --j)
        {
          facet.Key[j] = facet.Key[j - 1];
        }
        facet.Key[j] = facet.Ids[i];
      }
      facets.push_back(facet);
    };
    for (int skipped = 0; skipped < apexes; ++skipped)
    {
      count = 0;
      for (int i = 0; i < size; ++i)
      {
        if (i != skipped)
        {
          facet.Ids[count++] = ids[i];
        }
      }
      addFacet(apexes - 1, shape);
    }
    for (int axis = 0; axis < shape; ++axis)
    {
      for (int side = 0; side < 2; ++side)
      {
        count = 0;
        for (int i = 0; i < apexes; ++i)
        {
          facet.Ids[count++] = ids[i];
        }
        for (int corner = 0; corner < (1 << shape); ++corner)
        {
          if (((corner >> axis) & 1) == side)
          {
            facet.Ids[count++] = ids[apexes + corner];
          }
        }
        addFacet(apexes, shape - 1);
      }
    }
  }
  std::sort(facets.begin(), facets.end());
  for (std::size_t first = 0; first < facets.size();)
  {
    std::size_t last = first + 1;
    while (last < facets.size() && facets[last].Key == facets[first].Key)
    {
      ++last;
    }
    if (last - first == 1)
    {
      ++measures.BoundaryFacets;
      const Facet& facet = facets[first];
      const int size = facet.Apexes + (1 << facet.Cube);
      std::array<stm::LatticeIndex<D>, maxFacetPoints> points;
      for (int i = 0; i < size; ++i)
      {
        points[i] = mesh.HalfUnitPoints[facet.Ids[i]];
      }
      int normalAxis = -1;
      for (int axis = 0; axis < D && normalAxis < 0; ++axis)
      {
        bool flat = true;
        for (int i = 1; i < size; ++i)
        {
          flat = flat && points[i][axis] == points[0][axis];
        }
        normalAxis = flat ? axis : -1;
      }
      if (normalAxis < 0)
      {
        ++measures.SkewBoundaryFacets;
      }
      else
      {
        // The facet's measure is that of its projection along the normal axis, summed over its
        // Kuhn simplices (a cone over a 0-cube is one simplex).
        ForEachKuhnPiece<D>(points.data(), facet.Apexes, facet.Cube,
          [&](const std::array<stm::LatticeIndex<D>, D + 1>& simplex, int)
          {
            std::array<std::array<std::int64_t, D - 1>, D - 1> edges;
            for (int row = 0; row < D - 1; ++row)
            {
              int column = 0;
              for (int axis = 0; axis < D; ++axis)
              {
                if (axis != normalAxis)
                {
                  edges[row][column++] = simplex[row + 1][axis] - simplex[0][axis];
                }
              }
            }
            const std::int64_t measure = LeibnizDeterminant<D - 1>(edges);
            measures.ScaledBoundaryMeasure += measure < 0 ? -measure : measure;
          });
      }
    }
    first = last;
  }
  return measures;
}

/// Faces between a body voxel (any non-background material) and a non-body voxel, counting the
/// faces on the image border: the boundary measure of the voxel model, in voxel faces. With an
/// axis, only the faces orthogonal to it.
template <int D>
std::int64_t CountVoxelBoundaryFaces(const LabelImage<D>& image, int onlyAxis = -1)
{
  std::int64_t faces = 0;
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      if (image.At(voxel) == stm::BackgroundMaterial)
      {
        return;
      }
      for (int axis = 0; axis < D; ++axis)
      {
        if (onlyAxis >= 0 && axis != onlyAxis)
        {
          continue;
        }
        for (int step : { -1, 1 })
        {
          stm::LatticeIndex<D> neighbor = voxel;
          neighbor[axis] += step;
          faces += image.At(neighbor) == stm::BackgroundMaterial;
        }
      }
    });
  return faces;
}

/// Number of lattice cells covered by a leaf.
template <int D>
std::int64_t LeafVolume(const stm::Spacetree<D>& tree, std::int64_t leaf)
{
  return tree.GetCellVolume(tree.LeafLevels[leaf]);
}

template <int D>
std::int64_t LatticeVolume(const stm::Spacetree<D>& tree)
{
  return stm::NumberOfLatticeCells<D>(tree.GetLatticeDimensions());
}

/// For every lattice cell of the root grid, the index of the leaf covering it; -1 where no leaf
/// does. Leaves that overlap or leave the root grid are counted in the return value.
template <int D>
std::int64_t MapCellsToLeaves(const stm::Spacetree<D>& tree, std::vector<std::int64_t>& cellToLeaf)
{
  const stm::LatticeIndex<D> dims = tree.GetLatticeDimensions();
  cellToLeaf.assign(static_cast<std::size_t>(stm::NumberOfLatticeCells<D>(dims)), -1);
  std::int64_t conflicts = 0;
  for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
  {
    const stm::LatticeIndex<D>& size = tree.GetCellSize(tree.LeafLevels[leaf]);
    stm::LatticeIndex<D> upper;
    for (int axis = 0; axis < D; ++axis)
    {
      upper[axis] = tree.LeafAnchors[leaf][axis] + size[axis];
      if (tree.LeafAnchors[leaf][axis] < 0 || upper[axis] > dims[axis])
      {
        ++conflicts;
        upper[axis] = std::min(upper[axis], dims[axis]);
      }
    }
    ForEachIndexInBox<D>(tree.LeafAnchors[leaf], upper,
      [&](const stm::LatticeIndex<D>& cell)
      {
        std::int64_t& owner = cellToLeaf[stm::LinearIndex<D>(cell, dims)];
        conflicts += owner >= 0;
        owner = leaf;
      });
  }
  return conflicts;
}

/// Lattice cells of the root grid whose leaf material differs from the image (padding reads as
/// background).
template <int D>
std::int64_t CountMaterialMismatches(const stm::Spacetree<D>& tree, const LabelImage<D>& image)
{
  std::vector<std::int64_t> cellToLeaf;
  MapCellsToLeaves<D>(tree, cellToLeaf);
  const stm::LatticeIndex<D> dims = tree.GetLatticeDimensions();
  std::int64_t mismatches = 0;
  ForEachIndex<D>(dims,
    [&](const stm::LatticeIndex<D>& cell)
    {
      const std::int64_t leaf = cellToLeaf[stm::LinearIndex<D>(cell, dims)];
      stm::LatticeIndex<D> voxel;
      for (int axis = 0; axis < D; ++axis)
      {
        voxel[axis] = cell[axis] / tree.VoxelSubdivision[axis];
      }
      mismatches += leaf < 0 || tree.LeafMaterials[leaf] != image.At(voxel);
    });
  return mismatches;
}

template <int D>
std::vector<stm::CellTemplate> TemplatesOf()
{
  if (D <= 3)
  {
    return { stm::CellTemplate::Kuhn, stm::CellTemplate::Checkerboard };
  }
  return { stm::CellTemplate::Kuhn };
}

inline std::string TemplateName(stm::CellTemplate cellTemplate)
{
  return cellTemplate == stm::CellTemplate::Kuhn ? "Kuhn" : "Checkerboard";
}

inline stm::SpacetreeTessellationOptions TessellationOptions(
  stm::CellTemplate cellTemplate, bool includeBackground = false)
{
  stm::SpacetreeTessellationOptions options;
  options.Template = cellTemplate;
  options.IncludeBackground = includeBackground;
  return options;
}

/// One voxel in the units of the exact volumes: D! times its volume in half lattice units, 2^D.
template <int D>
std::int64_t ScaledVoxelVolume()
{
  return stm::IntPow(2, D) * stm::Factorial(D);
}

/// One voxel face in the units of the exact boundary measure: (D-1)! 2^(D-1).
template <int D>
std::int64_t ScaledVoxelFace()
{
  return stm::IntPow(2, D - 1) * stm::Factorial(D - 1);
}

/// Point ids must follow the lattice order of the half-unit points, each visited exactly once.
template <int D>
void ExpectPointsInLatticeOrder(const TessellationMesh<D>& mesh, const stm::Spacetree<D>& tree)
{
  stm::LatticeIndex<D> pointDims;
  for (int axis = 0; axis < D; ++axis)
  {
    pointDims[axis] = 2 * tree.GetLatticeDimensions()[axis] + 1;
  }
  std::int64_t outside = 0, outOfOrder = 0;
  for (std::int64_t id = 0; id < mesh.GetNumberOfPoints(); ++id)
  {
    const auto& point = mesh.HalfUnitPoints[id];
    for (int axis = 0; axis < D; ++axis)
    {
      outside += point[axis] < 0 || point[axis] >= pointDims[axis];
    }
    if (id > 0 &&
      stm::LinearIndex<D>(mesh.HalfUnitPoints[id - 1], pointDims) >=
        stm::LinearIndex<D>(point, pointDims))
    {
      ++outOfOrder;
    }
  }
  EXPECT_EQ(outside, 0);
  EXPECT_EQ(outOfOrder, 0) << "point ids do not follow the lattice order";
  EXPECT_EQ(std::count(mesh.VisitCounts.begin(), mesh.VisitCounts.end(), 1),
    static_cast<std::ptrdiff_t>(mesh.VisitCounts.size()))
    << "VisitPoints must report every point exactly once";
}

/// Everything the mesh of a body (simplicial or hybrid output) must satisfy, against the voxel
/// image it came from.
template <int D>
void ExpectMeshMatchesVoxelModel(
  const TessellationMesh<D>& mesh, const stm::Spacetree<D>& tree, const LabelImage<D>& image)
{
  const stm::MeshInvariantReport report = CheckMesh<D>(mesh);
  EXPECT_TRUE(report.IsValid()) << report.Summary();
  EXPECT_EQ(report.NumberOfCells, mesh.GetNumberOfCells());
  EXPECT_EQ(report.NumberOfPoints, mesh.GetNumberOfPoints());
  EXPECT_EQ(std::count(mesh.Connectivity.begin(), mesh.Connectivity.end(), -1), 0)
    << "connectivity entries were not written";
  EXPECT_EQ(mesh.Offsets.back(), static_cast<std::int64_t>(mesh.Connectivity.size()))
    << "shapes do not match the connectivity size";
  ExpectPointsInLatticeOrder<D>(mesh, tree);

  const ExactMeasures exact = ComputeExactMeasures<D>(mesh);
  EXPECT_EQ(exact.NonPositiveSimplices, 0) << "WriteCells must orient every cell";
  const std::int64_t latticeCellsPerVoxel = stm::NumberOfLatticeCells<D>(tree.VoxelSubdivision);
  std::map<std::int64_t, std::int64_t> expectedVolumes;
  for (stm::MaterialIndex material = 1; material <= image.LargestMaterial(); ++material)
  {
    if (image.CountVoxels(material) > 0)
    {
      expectedVolumes[material] =
        image.CountVoxels(material) * ScaledVoxelVolume<D>() * latticeCellsPerVoxel;
    }
  }
  EXPECT_EQ(exact.ScaledVolumePerMaterial, expectedVolumes) << "exact volume per material";
  for (const auto& [material, volume] : expectedVolumes)
  {
    ASSERT_EQ(report.VolumePerMaterial.count(material), 1u) << "material " << material;
    EXPECT_TRUE(CheckerMeasureMatches(
      report.VolumePerMaterial.at(material), static_cast<double>(volume / ScaledVoxelVolume<D>())))
      << "checker volume of material " << material;
  }

  // A voxel face orthogonal to an axis holds the product of the other axes' subdivisions.
  std::int64_t faces = 0;
  for (int axis = 0; axis < D; ++axis)
  {
    faces +=
      CountVoxelBoundaryFaces<D>(image, axis) * latticeCellsPerVoxel / tree.VoxelSubdivision[axis];
  }
  EXPECT_EQ(exact.SkewBoundaryFacets, 0) << "the boundary of a voxel body is axis-aligned";
  EXPECT_EQ(exact.ScaledBoundaryMeasure, faces * ScaledVoxelFace<D>()) << "exact boundary";
  EXPECT_TRUE(CheckerMeasureMatches(report.BoundaryMeasure, static_cast<double>(faces)))
    << "checker boundary";
}

/// Signed volume times d! of a simplex given as d + 1 points of D coordinates.
template <int D>
double ScaledVolume(const std::vector<double>& coordinates, const std::int64_t* ids)
{
  double m[D][D];
  for (int r = 0; r < D; ++r)
  {
    for (int c = 0; c < D; ++c)
    {
      m[r][c] = coordinates[ids[r + 1] * D + c] - coordinates[ids[0] * D + c];
    }
  }
  return stm::Determinant<D>(m);
}

/// A simplicial mesh cut by marching simplices, with the cut vertices' coordinates and values.
template <int D>
struct CutResult
{
  stm::Status Result;
  std::vector<double> Coordinates; // input points, then cut vertices
  std::vector<double> Values;
  std::vector<std::int64_t> Connectivity;
  std::vector<std::int64_t> Parents;
  std::vector<std::uint8_t> Sides;
  std::vector<std::int64_t> Surface;
  std::vector<std::int64_t> SurfaceParents;
  std::int64_t SplitCells = 0;
  std::int64_t CutEdges = 0;

  std::int64_t GetNumberOfCells() const { return static_cast<std::int64_t>(this->Sides.size()); }
};

template <int D, class Executor, class AllZeroSide>
CutResult<D> Cut(const std::vector<double>& coordinates, const std::vector<double>& values,
  const std::vector<std::int64_t>& connectivity, const stm::MarchingSimplicesOptions& options,
  Executor& executor, AllZeroSide allZeroSide)
{
  CutResult<D> result;
  stm::MarchingSimplices<D> cutter;
  const auto points = static_cast<std::int64_t>(values.size());
  const auto cells = static_cast<std::int64_t>(connectivity.size()) / (D + 1);
  result.Result = cutter.Classify(
    values.data(), points, connectivity.data(), cells, options, allZeroSide, executor);
  if (!result.Result.IsOk())
  {
    return result;
  }
  const std::int64_t outputCells = cutter.GetNumberOfCells();
  result.Connectivity.assign(static_cast<std::size_t>(outputCells * (D + 1)), -1);
  result.Parents.assign(static_cast<std::size_t>(outputCells), -1);
  result.Sides.assign(static_cast<std::size_t>(outputCells), 0xFF);
  result.Result = cutter.WriteCells(connectivity.data(), result.Connectivity.data(),
    result.Parents.data(), result.Sides.data(), executor);
  if (!result.Result.IsOk())
  {
    return result;
  }
  result.Result =
    cutter.ExtractSurface(connectivity.data(), result.Surface, result.SurfaceParents, executor);
  result.Coordinates = coordinates;
  result.Values = values;
  for (const stm::CutEdge& edge : cutter.GetCutEdges())
  {
    for (int axis = 0; axis < D; ++axis)
    {
      result.Coordinates.push_back(
        (1.0 - edge.T) * coordinates[edge.A * D + axis] + edge.T * coordinates[edge.B * D + axis]);
    }
    result.Values.push_back((1.0 - edge.T) * (values[edge.A] - options.IsoValue) +
      edge.T * (values[edge.B] - options.IsoValue) + options.IsoValue);
  }
  result.SplitCells = cutter.GetNumberOfSplitCells();
  result.CutEdges = static_cast<std::int64_t>(cutter.GetCutEdges().size());
  return result;
}

} // namespace stmtest

#endif
