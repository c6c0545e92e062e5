// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreMeshInvariants_h
#define stmCoreMeshInvariants_h

// Checks the invariants every mesh of SpacetreeMesh must satisfy, in any dimension. Its cells are
// the polytopes P_j of the paper's equation (1): simplices, cubes and the cones over cubes
// between them (pyramids in 3D), see CheckCellMesh.
//  - conformity: every facet (as a point set) is shared by at most two cells (interior facets by
//    exactly two), and no boundary facet contains another boundary facet (a square facing two
//    triangles);
//  - no hanging node: no mesh point is the midpoint of an edge;
//  - every cell has positive volume (consistent orientation), checked on every simplex of its
//    Kuhn decomposition;
//  - the boundary is closed: every ridge of the boundary facets is shared by an even number of
//    boundary facets;
//  - no point is unreferenced, no point id or cell shape is invalid.
// It also reports the volume of each material and the measure of the boundary, for exact
// comparisons with the voxel model: sums of exact determinants, divided once.

#include "../Common/Determinant.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
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
  std::int64_t OvershareFacets = 0;     // facets shared by more than two cells
  std::int64_t NonConformingFacets = 0; // boundary facets containing another boundary facet
  std::int64_t NonPositiveCells = 0;    // a simplex of the cell's decomposition has volume <= 0
  std::int64_t OpenRidges = 0;          // ridges used by an odd number of boundary facets
  std::int64_t HangingNodes = 0;        // points at the midpoint of an edge
  std::int64_t UnreferencedPoints = 0;
  std::int64_t InvalidPointIds = 0;
  std::int64_t InvalidCells = 0; // shapes out of range, or arrays of inconsistent lengths
  double MinimumVolume = 0.0;
  double TotalVolume = 0.0;
  double BoundaryMeasure = 0.0;
  std::map<std::int64_t, double> VolumePerMaterial;

  bool IsValid() const
  {
    return this->NumberOfCells > 0 && this->OvershareFacets == 0 &&
      this->NonConformingFacets == 0 && this->NonPositiveCells == 0 && this->OpenRidges == 0 &&
      this->HangingNodes == 0 && this->UnreferencedPoints == 0 && this->InvalidPointIds == 0 &&
      this->InvalidCells == 0;
  }

  std::string Summary() const
  {
    std::ostringstream out;
    out << "cells " << this->NumberOfCells << ", points " << this->NumberOfPoints
        << ", boundary facets " << this->BoundaryFacets << ", facets shared by >2 cells "
        << this->OvershareFacets << ", non-conforming boundary facets " << this->NonConformingFacets
        << ", non-positive cells " << this->NonPositiveCells << ", open boundary ridges "
        << this->OpenRidges << ", hanging nodes " << this->HangingNodes << ", unreferenced points "
        << this->UnreferencedPoints << ", invalid point ids " << this->InvalidPointIds
        << ", invalid cells " << this->InvalidCells << ", total volume " << this->TotalVolume;
    return out.str();
  }
};

namespace detail
{
constexpr int MeshFactorial(int n)
{
  return n <= 1 ? 1 : n * MeshFactorial(n - 1);
}

/// A point set of at most K ids, sorted, padded with the largest id.
template <int K>
struct SortedKey
{
  std::array<std::int64_t, K> Ids;
  bool operator<(const SortedKey& other) const { return this->Ids < other.Ids; }
  bool operator==(const SortedKey& other) const { return this->Ids == other.Ids; }
};

constexpr std::int64_t KeyPadding = std::numeric_limits<std::int64_t>::max();

template <int K>
SortedKey<K> MakeKey(const std::int64_t* ids, int count)
{
  // Insertion sort: at most 2^(Dim-1) ids (the bound also tells the compiler).
  SortedKey<K> key;
  key.Ids.fill(KeyPadding);
  for (int i = 0; i < count && i < K; ++i)
  {
    int j = i;
    for (; j > 0 && key.Ids[j - 1] > ids[i]; --j)
    {
      key.Ids[j] = key.Ids[j - 1];
    }
    key.Ids[j] = ids[i];
  }
  return key;
}

/// A cell or a face of a cell: the cone with Apexes apexes (outermost first) over a cube of
/// dimension CubeDimension, whose 2^CubeDimension corners follow in code order (bit i: far side
/// along the cube's i-th axis). A simplex has a cube of dimension 1 (or 0 for a face).
template <int Dim>
struct Polytope
{
  int Apexes = 0;
  int CubeDimension = 0;
  std::array<std::int64_t, (1 << Dim)> Ids{};

  int Size() const { return this->Apexes + (1 << this->CubeDimension); }
  int Dimension() const { return this->Apexes + this->CubeDimension; }
};

/// Calls visit(facet) for the facets of a polytope of dimension >= 1: those of a cone a*X are X
/// and a*f for the facets f of X; those of a j-cube are its 2j (j-1)-cubes; the only facet of a
/// point is the empty face, so that a cone over a point has the cone over nothing (its apexes)
/// as a facet.
template <int Dim, class Visitor>
void ForEachFacet(const Polytope<Dim>& polytope, Visitor&& visit)
{
  if (polytope.Dimension() == 0)
  {
    return;
  }
  const int size = polytope.Size();
  for (int apex = 0; apex < polytope.Apexes; ++apex)
  {
    Polytope<Dim> facet;
    facet.Apexes = polytope.Apexes - 1;
    facet.CubeDimension = polytope.CubeDimension;
    int next = 0;
    for (int i = 0; i < size; ++i)
    {
      if (i != apex)
      {
        facet.Ids[next++] = polytope.Ids[i];
      }
    }
    visit(static_cast<const Polytope<Dim>&>(facet));
  }
  if (polytope.CubeDimension == 0)
  {
    // The simplex of the apexes; its innermost apex becomes its 0-cube.
    Polytope<Dim> facet;
    facet.Apexes = polytope.Apexes - 1;
    facet.CubeDimension = 0;
    for (int apex = 0; apex < polytope.Apexes && apex < Dim; ++apex)
    {
      facet.Ids[apex] = polytope.Ids[apex];
    }
    visit(static_cast<const Polytope<Dim>&>(facet));
    return;
  }
  const std::int64_t* corners = polytope.Ids.data() + polytope.Apexes;
  for (int axis = 0; axis < polytope.CubeDimension; ++axis)
  {
    for (int side = 0; side < 2; ++side)
    {
      Polytope<Dim> facet;
      facet.Apexes = polytope.Apexes;
      facet.CubeDimension = polytope.CubeDimension - 1;
      for (int apex = 0; apex < polytope.Apexes && apex < Dim; ++apex)
      {
        facet.Ids[apex] = polytope.Ids[apex];
      }
      int next = polytope.Apexes;
      // Increasing codes with bit `axis` fixed are the sub-cube's corners in its code order.
      for (int c = 0; c < (1 << polytope.CubeDimension); ++c)
      {
        if (((c >> axis) & 1) == side)
        {
          facet.Ids[next++] = corners[c];
        }
      }
      visit(static_cast<const Polytope<Dim>&>(facet));
    }
  }
}

/// Calls visit(ids, sign) for the simplices of the Kuhn decomposition of a polytope: for every
/// order of the cube's axes, the monotone corner path from corner 0 followed by the apexes. Its
/// Dimension() + 1 ids are listed so that sign times its determinant is positive for a
/// positively oriented polytope (the sign of the axis permutation).
template <int Dim, class Visitor>
void ForEachKuhnSimplex(const Polytope<Dim>& polytope, Visitor&& visit)
{
  const int j = polytope.CubeDimension;
  const std::int64_t* corners = polytope.Ids.data() + polytope.Apexes;
  std::array<int, Dim> order{};
  for (int i = 0; i < j; ++i)
  {
    order[i] = i;
  }
  std::array<std::int64_t, Dim + 1> ids{};
  do
  {
    int inversions = 0;
    for (int a = 0; a < j; ++a)
    {
      for (int b = a + 1; b < j; ++b)
      {
        inversions += order[a] > order[b];
      }
    }
    int code = 0;
    ids[0] = corners[0];
    for (int step = 0; step < j; ++step)
    {
      code |= 1 << order[step];
      ids[step + 1] = corners[code];
    }
    for (int apex = 0; apex < polytope.Apexes && apex < Dim; ++apex)
    {
      ids[j + 1 + apex] = polytope.Ids[apex];
    }
    visit(static_cast<const std::array<std::int64_t, Dim + 1>&>(ids), inversions % 2 == 0 ? 1 : -1);
  } while (std::next_permutation(order.begin(), order.begin() + j));
}

/// Calls visit(u, w) for the edges of a polytope: the cube's edges, and every apex joined to
/// every other point.
template <int Dim, class Visitor>
void ForEachEdge(const Polytope<Dim>& polytope, Visitor&& visit)
{
  const int size = polytope.Size();
  for (int apex = 0; apex < polytope.Apexes; ++apex)
  {
    for (int other = apex + 1; other < size; ++other)
    {
      visit(polytope.Ids[apex], polytope.Ids[other]);
    }
  }
  const std::int64_t* corners = polytope.Ids.data() + polytope.Apexes;
  for (int c = 0; c < (1 << polytope.CubeDimension); ++c)
  {
    for (int axis = 0; axis < polytope.CubeDimension; ++axis)
    {
      if (((c >> axis) & 1) == 0)
      {
        visit(corners[c], corners[c | (1 << axis)]);
      }
    }
  }
}

/// The checks. Simplicial meshes (only shape 1 allowed) use keys of Dim points for facets and
/// Dim - 1 for ridges, which keeps their memory at that of a simplex-only checker; otherwise
/// the largest facet is a (Dim-1)-cube and the largest ridge a (Dim-2)-cube.
template <int Dim, bool Simplicial>
MeshInvariantReport CheckCells(const std::vector<double>& points,
  const std::vector<std::int64_t>& connectivity, const std::vector<std::uint8_t>& shapes,
  const std::vector<std::int64_t>* materials, double pointTolerance)
{
  constexpr int FacetKeySize = Simplicial || Dim == 1 ? Dim : (1 << (Dim - 1));
  constexpr int RidgeKeySize = Simplicial || Dim <= 2 ? Dim - 1 : (1 << (Dim - 2));
  MeshInvariantReport report;
  report.NumberOfPoints = static_cast<std::int64_t>(points.size()) / Dim;
  report.NumberOfCells = static_cast<std::int64_t>(shapes.size());
  const std::int64_t cells = report.NumberOfCells;

  // Offsets of the cells in the connectivity; the largest facet must fit the keys.
  std::vector<std::int64_t> offsets(static_cast<std::size_t>(cells) + 1, 0);
  const int largestShape = Simplicial ? 1 : Dim;
  for (std::int64_t cell = 0; cell < cells; ++cell)
  {
    const int shape = shapes[cell];
    const bool valid = shape >= 1 && shape <= largestShape;
    report.InvalidCells += !valid;
    offsets[cell + 1] = offsets[cell] + (valid ? (Dim - shape) + (1 << shape) : 0);
  }
  report.InvalidCells += offsets.back() != static_cast<std::int64_t>(connectivity.size());
  report.InvalidCells += materials && static_cast<std::int64_t>(materials->size()) != cells;
  if (report.InvalidCells > 0)
  {
    return report;
  }
  std::vector<char> referenced(static_cast<std::size_t>(report.NumberOfPoints), 0);
  for (std::int64_t id : connectivity)
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

  auto cellPolytope = [&](std::int64_t cell)
  {
    Polytope<Dim> polytope;
    polytope.CubeDimension = shapes[cell];
    polytope.Apexes = Dim - polytope.CubeDimension;
    std::copy(connectivity.begin() + offsets[cell], connectivity.begin() + offsets[cell + 1],
      polytope.Ids.begin());
    return polytope;
  };

  // Volumes: sums of exact determinants (Dim! volumes), divided once at the end.
  constexpr double factorial = MeshFactorial(Dim);
  report.MinimumVolume = cells > 0 ? 1e300 : 0.0;
  double totalDeterminant = 0.0;
  std::map<std::int64_t, double> determinantPerMaterial;
  for (std::int64_t cell = 0; cell < cells; ++cell)
  {
    double cellDeterminant = 0.0;
    bool positive = true;
    ForEachKuhnSimplex<Dim>(cellPolytope(cell),
      [&](const std::array<std::int64_t, Dim + 1>& ids, int sign)
      {
        double m[Dim][Dim];
        const double* p0 = &points[ids[0] * Dim];
        for (int row = 0; row < Dim; ++row)
        {
          const double* p = &points[ids[row + 1] * Dim];
          for (int col = 0; col < Dim; ++col)
          {
            m[row][col] = p[col] - p0[col];
          }
        }
        const double determinant = sign * Determinant<Dim>(m);
        positive = positive && determinant > 0.0;
        cellDeterminant += determinant;
      });
    report.MinimumVolume = std::min(report.MinimumVolume, cellDeterminant / factorial);
    report.NonPositiveCells += !positive;
    totalDeterminant += cellDeterminant;
    const std::int64_t material = materials ? (*materials)[cell] : 0;
    determinantPerMaterial[material] += cellDeterminant;
  }
  report.TotalVolume = totalDeterminant / factorial;
  for (const auto& entry : determinantPerMaterial)
  {
    report.VolumePerMaterial[entry.first] = entry.second / factorial;
  }

  // Facets, as point sets: those used once are the boundary.
  std::vector<SortedKey<FacetKeySize>> facets;
  facets.reserve(static_cast<std::size_t>(cells * (Dim + 1)));
  for (std::int64_t cell = 0; cell < cells; ++cell)
  {
    ForEachFacet<Dim>(cellPolytope(cell),
      [&](const Polytope<Dim>& facet)
      { facets.push_back(MakeKey<FacetKeySize>(facet.Ids.data(), facet.Size())); });
  }
  std::sort(facets.begin(), facets.end());
  std::vector<SortedKey<FacetKeySize>> boundary;
  for (std::size_t i = 0; i < facets.size();)
  {
    std::size_t j = i + 1;
    while (j < facets.size() && facets[j] == facets[i])
    {
      ++j;
    }
    if (j - i == 1)
    {
      boundary.push_back(facets[i]);
    }
    else if (j - i > 2)
    {
      ++report.OvershareFacets;
    }
    i = j;
  }
  facets.clear();
  facets.shrink_to_fit();
  report.BoundaryFacets = static_cast<std::int64_t>(boundary.size());
  auto isBoundary = [&boundary](const SortedKey<FacetKeySize>& key)
  { return std::binary_search(boundary.begin(), boundary.end(), key); };

  // The boundary facets again, with their structure: measure, ridges, overlaps.
  double scaledBoundary = 0.0;
  std::vector<SortedKey<(RidgeKeySize > 0 ? RidgeKeySize : 1)>> ridges;
  for (std::int64_t cell = 0; cell < cells && !boundary.empty(); ++cell)
  {
    ForEachFacet<Dim>(cellPolytope(cell),
      [&](const Polytope<Dim>& facet)
      {
        const int size = facet.Size();
        if (!isBoundary(MakeKey<FacetKeySize>(facet.Ids.data(), size)))
        {
          return;
        }
        if constexpr (Dim == 1)
        {
          scaledBoundary += 1.0;
        }
        else
        {
          ForEachKuhnSimplex<Dim>(facet,
            [&](const std::array<std::int64_t, Dim + 1>& ids, int)
            {
              double edges[Dim - 1][Dim];
              for (int v = 1; v < Dim; ++v)
              {
                for (int axis = 0; axis < Dim; ++axis)
                {
                  edges[v - 1][axis] = points[ids[v] * Dim + axis] - points[ids[0] * Dim + axis];
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
              scaledBoundary += std::sqrt(std::max(0.0, Determinant<Dim - 1>(gram)));
            });
          ForEachFacet<Dim>(facet,
            [&](const Polytope<Dim>& ridge)
            { ridges.push_back(MakeKey<RidgeKeySize>(ridge.Ids.data(), ridge.Size())); });
        }
        // A boundary facet whose points include all those of another boundary facet overlaps
        // it: the two sides of a facet were tessellated differently.
        if (size > Dim)
        {
          bool overlaps = false;
          for (unsigned subset = 1; !overlaps && subset + 1 < (1u << size); ++subset)
          {
            std::array<std::int64_t, FacetKeySize> ids;
            int count = 0;
            for (int i = 0; i < size; ++i)
            {
              if (subset & (1u << i))
              {
                ids[count++] = facet.Ids[i];
              }
            }
            overlaps = count >= Dim && isBoundary(MakeKey<FacetKeySize>(ids.data(), count));
          }
          report.NonConformingFacets += overlaps;
        }
      });
  }
  constexpr double facetFactorial = MeshFactorial(Dim - 1);
  report.BoundaryMeasure = scaledBoundary / facetFactorial;

  // Closed boundary: ridges of boundary facets are used an even number of times.
  std::sort(ridges.begin(), ridges.end());
  for (std::size_t i = 0; i < ridges.size();)
  {
    std::size_t j = i + 1;
    while (j < ridges.size() && ridges[j] == ridges[i])
    {
      ++j;
    }
    report.OpenRidges += (j - i) % 2 != 0;
    i = j;
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
  std::vector<SortedKey<2>> edges;
  edges.reserve(static_cast<std::size_t>(cells * (Dim + 1) * Dim / 2));
  for (std::int64_t cell = 0; cell < cells; ++cell)
  {
    ForEachEdge<Dim>(cellPolytope(cell),
      [&](std::int64_t u, std::int64_t w) {
        edges.push_back({ { std::min(u, w), std::max(u, w) } });
      });
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
} // namespace detail

/// Checks a mesh of polytopes P_j (1 <= j <= Dim): cell c has shapes[c] = j and
/// (Dim - j) + 2^j point ids in the connectivity, its apexes (outermost first) followed by the
/// corners of its j-cube in code order (bit i: far side along the cube's i-th axis). j = 1 is a
/// simplex, j = Dim a cube (quadrilateral, hexahedron), j = 2 in 3D a pyramid. A cell is
/// positively oriented when the simplex of its corners 0, 1, 2, 4, ..., 2^(j-1) followed by its
/// apexes is. points: numberOfPoints * Dim coordinates; materials: one label per cell (may be
/// null). pointTolerance: coordinates closer than this are the same point when looking for
/// hanging nodes.
template <int Dim>
MeshInvariantReport CheckCellMesh(const std::vector<double>& points,
  const std::vector<std::int64_t>& connectivity, const std::vector<std::uint8_t>& shapes,
  const std::vector<std::int64_t>* materials, double pointTolerance = 1e-9)
{
  return detail::CheckCells<Dim, false>(points, connectivity, shapes, materials, pointTolerance);
}

/// CheckCellMesh for simplices: cells is numberOfCells * (Dim+1) point ids.
template <int Dim>
MeshInvariantReport CheckSimplicialMesh(const std::vector<double>& points,
  const std::vector<std::int64_t>& cells, const std::vector<std::int64_t>* materials,
  double pointTolerance = 1e-9)
{
  const std::vector<std::uint8_t> shapes(cells.size() / (Dim + 1), 1);
  return detail::CheckCells<Dim, true>(points, cells, shapes, materials, pointTolerance);
}

} // namespace stm

#endif
