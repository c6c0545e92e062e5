// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreMeshInvariants_h
#define stmCoreMeshInvariants_h

// Checks the invariants every simplicial mesh of SpacetreeMesh must satisfy, in any dimension:
//  - conformity: every facet is shared by at most two cells (interior facets by exactly two);
//  - no hanging node: no mesh point is the midpoint of an edge;
//  - every cell has positive volume (consistent orientation);
//  - the boundary is closed: every ridge of the boundary facets is shared by an even number of
//    boundary facets;
//  - no point is unreferenced.
// It also reports the volume of each material and the measure of the boundary, for exact
// comparisons with the voxel model.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <sstream>
#include <string>
#include <unordered_set>
#include <vector>

namespace stm
{

struct MeshInvariantReport
{
  std::int64_t NumberOfCells = 0;
  std::int64_t NumberOfPoints = 0;
  std::int64_t BoundaryFacets = 0;
  std::int64_t OvershareFacets = 0;  // facets shared by more than two cells
  std::int64_t NonPositiveCells = 0; // volume <= 0
  std::int64_t OpenRidges = 0;       // ridges used by an odd number of boundary facets
  std::int64_t HangingNodes = 0;     // points at the midpoint of an edge
  std::int64_t UnreferencedPoints = 0;
  std::int64_t InvalidPointIds = 0;
  double MinimumVolume = 0.0;
  double TotalVolume = 0.0;
  double BoundaryMeasure = 0.0;
  std::map<std::int64_t, double> VolumePerMaterial;

  bool IsValid() const
  {
    return this->NumberOfCells > 0 && this->OvershareFacets == 0 && this->NonPositiveCells == 0 &&
      this->OpenRidges == 0 && this->HangingNodes == 0 && this->UnreferencedPoints == 0 &&
      this->InvalidPointIds == 0;
  }

  std::string Summary() const
  {
    std::ostringstream out;
    out << "cells " << this->NumberOfCells << ", points " << this->NumberOfPoints
        << ", boundary facets " << this->BoundaryFacets << ", facets shared by >2 cells "
        << this->OvershareFacets << ", non-positive cells " << this->NonPositiveCells
        << ", open boundary ridges " << this->OpenRidges << ", hanging nodes " << this->HangingNodes
        << ", unreferenced points " << this->UnreferencedPoints << ", invalid point ids "
        << this->InvalidPointIds << ", total volume " << this->TotalVolume;
    return out.str();
  }
};

namespace detail
{
template <int K>
struct SortedKey
{
  std::array<std::int64_t, K> Ids;
  bool operator<(const SortedKey& other) const { return this->Ids < other.Ids; }
  bool operator==(const SortedKey& other) const { return this->Ids == other.Ids; }
};

/// Determinant by the Leibniz formula: exact for the small dyadic entries of lattice meshes.
template <int K>
double LeibnizDeterminant(const double (&m)[K][K])
{
  int permutation[K];
  for (int i = 0; i < K; ++i)
  {
    permutation[i] = i;
  }
  double sum = 0.0;
  do
  {
    int inversions = 0;
    for (int i = 0; i < K; ++i)
    {
      for (int j = i + 1; j < K; ++j)
      {
        inversions += permutation[i] > permutation[j];
      }
    }
    double product = 1.0;
    for (int row = 0; row < K; ++row)
    {
      product *= m[row][permutation[row]];
    }
    sum += (inversions % 2 == 0) ? product : -product;
  } while (std::next_permutation(permutation, permutation + K));
  return sum;
}

template <int K>
void CountRuns(std::vector<SortedKey<K>>& keys, std::int64_t& singles, std::int64_t& overshared,
  std::vector<SortedKey<K>>* singleKeys)
{
  std::sort(keys.begin(), keys.end());
  for (std::size_t i = 0; i < keys.size();)
  {
    std::size_t j = i + 1;
    while (j < keys.size() && keys[j] == keys[i])
    {
      ++j;
    }
    const std::size_t run = j - i;
    if (run == 1)
    {
      ++singles;
      if (singleKeys)
      {
        singleKeys->push_back(keys[i]);
      }
    }
    else if (run > 2)
    {
      ++overshared;
    }
    i = j;
  }
}
} // namespace detail

/// points: numberOfPoints * Dim coordinates; cells: numberOfCells * (Dim+1) point ids;
/// materials: one label per cell (may be null). pointTolerance: coordinates closer than this
/// are the same point when looking for hanging nodes.
template <int Dim>
MeshInvariantReport CheckSimplicialMesh(const std::vector<double>& points,
  const std::vector<std::int64_t>& cells, const std::vector<std::int64_t>* materials,
  double pointTolerance = 1e-9)
{
  constexpr int N = Dim + 1;
  MeshInvariantReport report;
  report.NumberOfPoints = static_cast<std::int64_t>(points.size()) / Dim;
  report.NumberOfCells = static_cast<std::int64_t>(cells.size()) / N;
  std::vector<char> referenced(static_cast<std::size_t>(report.NumberOfPoints), 0);
  for (std::int64_t id : cells)
  {
    if (id < 0 || id >= report.NumberOfPoints)
    {
      ++report.InvalidPointIds;
    }
    else
    {
      referenced[id] = 1;
    }
  }
  if (report.InvalidPointIds > 0)
  {
    return report;
  }
  report.UnreferencedPoints = std::count(referenced.begin(), referenced.end(), 0);

  // Volumes: sums of exact determinants (Dim! volumes), divided once at the end.
  constexpr double factorial = Dim == 1 ? 1.0 : Dim == 2 ? 2.0 : Dim == 3 ? 6.0 : 24.0;
  report.MinimumVolume = report.NumberOfCells > 0 ? 1e300 : 0.0;
  double totalDeterminant = 0.0;
  std::map<std::int64_t, double> determinantPerMaterial;
  for (std::int64_t cell = 0; cell < report.NumberOfCells; ++cell)
  {
    double m[Dim][Dim];
    const double* p0 = &points[cells[cell * N] * Dim];
    for (int row = 0; row < Dim; ++row)
    {
      const double* p = &points[cells[cell * N + row + 1] * Dim];
      for (int col = 0; col < Dim; ++col)
      {
        m[row][col] = p[col] - p0[col];
      }
    }
    const double determinant = detail::LeibnizDeterminant<Dim>(m);
    const double volume = determinant / factorial;
    report.MinimumVolume = std::min(report.MinimumVolume, volume);
    if (!(volume > 0.0))
    {
      ++report.NonPositiveCells;
    }
    totalDeterminant += determinant;
    const std::int64_t material = materials ? (*materials)[cell] : 0;
    determinantPerMaterial[material] += determinant;
  }
  report.TotalVolume = totalDeterminant / factorial;
  for (const auto& entry : determinantPerMaterial)
  {
    report.VolumePerMaterial[entry.first] = entry.second / factorial;
  }

  // Facets.
  std::vector<detail::SortedKey<Dim>> facets;
  facets.reserve(static_cast<std::size_t>(report.NumberOfCells * N));
  for (std::int64_t cell = 0; cell < report.NumberOfCells; ++cell)
  {
    for (int skip = 0; skip < N; ++skip)
    {
      detail::SortedKey<Dim> key;
      int j = 0;
      for (int v = 0; v < N; ++v)
      {
        if (v != skip)
        {
          key.Ids[j++] = cells[cell * N + v];
        }
      }
      std::sort(key.Ids.begin(), key.Ids.end());
      facets.push_back(key);
    }
  }
  std::vector<detail::SortedKey<Dim>> boundary;
  detail::CountRuns<Dim>(facets, report.BoundaryFacets, report.OvershareFacets, &boundary);
  facets.clear();
  facets.shrink_to_fit();

  double scaledBoundary = 0.0;
  for (const auto& facet : boundary)
  {
    if constexpr (Dim == 1)
    {
      scaledBoundary += 1.0;
    }
    else
    {
      double edges[Dim - 1][Dim];
      for (int v = 1; v < Dim; ++v)
      {
        for (int axis = 0; axis < Dim; ++axis)
        {
          edges[v - 1][axis] =
            points[facet.Ids[v] * Dim + axis] - points[facet.Ids[0] * Dim + axis];
        }
      }
      double gram[Dim - 1][Dim - 1];
      for (int i = 0; i < Dim - 1; ++i)
      {
        for (int j = 0; j < Dim - 1; ++j)
        {
          double dot = 0.0;
          for (int axis = 0; axis < Dim; ++axis)
          {
            dot += edges[i][axis] * edges[j][axis];
          }
          gram[i][j] = dot;
        }
      }
      scaledBoundary += std::sqrt(std::max(0.0, detail::LeibnizDeterminant<Dim - 1>(gram)));
    }
  }
  constexpr double facetFactorial = Dim <= 2 ? 1.0 : Dim == 3 ? 2.0 : 6.0;
  report.BoundaryMeasure = scaledBoundary / facetFactorial;

  // Closed boundary: ridges of boundary facets are used an even number of times.
  if constexpr (Dim >= 2)
  {
    std::vector<detail::SortedKey<Dim - 1>> ridges;
    for (const auto& facet : boundary)
    {
      for (int skip = 0; skip < Dim; ++skip)
      {
        detail::SortedKey<Dim - 1> key;
        int j = 0;
        for (int v = 0; v < Dim; ++v)
        {
          if (v != skip)
          {
            key.Ids[j++] = facet.Ids[v];
          }
        }
        ridges.push_back(key);
      }
    }
    std::sort(ridges.begin(), ridges.end());
    for (std::size_t i = 0; i < ridges.size();)
    {
      std::size_t j = i + 1;
      while (j < ridges.size() && ridges[j] == ridges[i])
      {
        ++j;
      }
      if ((j - i) % 2 != 0)
      {
        ++report.OpenRidges;
      }
      i = j;
    }
  }

  // Hanging nodes: a mesh point at the midpoint of a mesh edge.
  struct CoordinateHash
  {
    std::size_t operator()(const std::array<std::int64_t, Dim>& key) const
    {
      std::size_t h = 1469598103934665603ull;
      for (std::int64_t v : key)
      {
        h = (h ^ static_cast<std::size_t>(v)) * 1099511628211ull;
      }
      return h;
    }
  };
  auto quantize = [&](const double* x)
  {
    std::array<std::int64_t, Dim> key;
    for (int axis = 0; axis < Dim; ++axis)
    {
      key[axis] = std::llround(x[axis] / pointTolerance);
    }
    return key;
  };
  std::unordered_set<std::array<std::int64_t, Dim>, CoordinateHash> pointKeys;
  pointKeys.reserve(static_cast<std::size_t>(report.NumberOfPoints));
  for (std::int64_t p = 0; p < report.NumberOfPoints; ++p)
  {
    pointKeys.insert(quantize(&points[p * Dim]));
  }
  std::vector<detail::SortedKey<2>> edges;
  edges.reserve(static_cast<std::size_t>(report.NumberOfCells * N * Dim / 2));
  for (std::int64_t cell = 0; cell < report.NumberOfCells; ++cell)
  {
    for (int a = 0; a < N; ++a)
    {
      for (int b = a + 1; b < N; ++b)
      {
        const std::int64_t u = cells[cell * N + a], w = cells[cell * N + b];
        edges.push_back({ { std::min(u, w), std::max(u, w) } });
      }
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  for (const auto& edge : edges)
  {
    double midpoint[Dim];
    for (int axis = 0; axis < Dim; ++axis)
    {
      midpoint[axis] = 0.5 * (points[edge.Ids[0] * Dim + axis] + points[edge.Ids[1] * Dim + axis]);
    }
    if (pointKeys.count(quantize(midpoint)))
    {
      ++report.HangingNodes;
    }
  }
  return report;
}

} // namespace stm

#endif
