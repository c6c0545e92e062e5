// SPDX-License-Identifier: BSD-3-Clause
// PointCells: ForEachFacetAt, over every point with smallestOnly, visits each facet of the mesh
// once with the cells that FacetNeighbour pairs, and without it once from each of the facet's
// points, on Kuhn triangulations of cube grids (2D, 3D and 4D: conforming, with outer-boundary
// facets), a chain of segments (1D) and a non-manifold fan (three triangles on one edge).

#include "Common/PointCells.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <numeric>
#include <vector>

namespace
{

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

template <int Dim>
void CheckAgainstFacetNeighbour(const std::vector<std::int64_t>& connectivity,
  std::int64_t numberOfPoints, std::int64_t expectedOuterFacets)
{
  constexpr int Corners = Dim + 1;
  using Entry = typename stm::PointCells<Dim>::FacetEntry;
  const auto cells = static_cast<std::int64_t>(connectivity.size()) / Corners;
  stm::PointCells<Dim> incidence;
  incidence.Build(connectivity.data(), cells, numberOfPoints);
  std::vector<int> once(static_cast<std::size_t>(cells * Corners), 0);
  std::vector<int> fromEachPoint(once.size(), 0);
  std::vector<Entry> entries;
  std::int64_t outer = 0;
  for (std::int64_t p = 0; p < numberOfPoints; ++p)
  {
    incidence.ForEachFacetAt(
      connectivity.data(), p, true, entries, [](std::int64_t, int) { return true; },
      [&](const Entry* first, const Entry* last)
      {
        outer += last - first == 1;
        for (const Entry* entry = first; entry != last; ++entry)
        {
          ++once[entry->Cell * Corners + entry->Corner];
          if (entry != first)
          {
            ASSERT_LT(entry[-1].Cell, entry->Cell);
          }
          const std::int64_t neighbour = incidence.FacetNeighbour(
            connectivity.data() + entry->Cell * Corners, entry->Cell, entry->Corner);
          const std::int64_t expected =
            last - first == 1 ? -1 : (entry == first ? first[1].Cell : first->Cell);
          ASSERT_EQ(neighbour, expected) << "cell " << entry->Cell << ", facet " << entry->Corner;
        }
      });
    // Every facet through p, each cell's side only where keep accepts it (here: even cells).
    incidence.ForEachFacetAt(
      connectivity.data(), p, false, entries, [](std::int64_t cell, int) { return cell % 2 == 0; },
      [&](const Entry* first, const Entry* last)
      {
        for (const Entry* entry = first; entry != last; ++entry)
        {
          ASSERT_EQ(entry->Cell % 2, 0);
          ++fromEachPoint[entry->Cell * Corners + entry->Corner];
        }
      });
  }
  for (std::int64_t c = 0; c < cells; ++c)
  {
    for (int corner = 0; corner < Corners; ++corner)
    {
      ASSERT_EQ(once[c * Corners + corner], 1) << "cell " << c << ", facet " << corner;
      ASSERT_EQ(fromEachPoint[c * Corners + corner], c % 2 == 0 ? Dim : 0);
    }
  }
  EXPECT_EQ(outer, expectedOuterFacets);
}

TEST(PointCells, EachFacetOnceFromItsSmallestPoint)
{
  std::int64_t points = 0;
  // Outer facets: 2 Dim faces of n^(Dim-1) cubes, each face (Dim-1)! simplices.
  auto grid2 = KuhnGrid<2>(5, points);
  CheckAgainstFacetNeighbour<2>(grid2, points, 4 * 5);
  auto grid3 = KuhnGrid<3>(4, points);
  CheckAgainstFacetNeighbour<3>(grid3, points, 6 * 16 * 2);
  auto grid4 = KuhnGrid<4>(2, points);
  CheckAgainstFacetNeighbour<4>(grid4, points, 8 * 8 * 6);
  const std::vector<std::int64_t> chain = { 0, 1, 2, 1, 2, 3 };
  CheckAgainstFacetNeighbour<1>(chain, 4, 2);
  // Three triangles on the edge (0, 1): one facet of three cells, ascending; each cell's
  // FacetNeighbour there is the smallest other one.
  const std::vector<std::int64_t> fan = { 0, 1, 2, 1, 0, 3, 0, 1, 4 };
  CheckAgainstFacetNeighbour<2>(fan, 5, 6);
  stm::PointCells<2> incidence;
  incidence.Build(fan.data(), 3, 5);
  std::vector<stm::PointCells<2>::FacetEntry> entries;
  std::vector<std::int64_t> shared;
  incidence.ForEachFacetAt(
    fan.data(), 0, true, entries, [](std::int64_t, int) { return true; },
    [&](const stm::PointCells<2>::FacetEntry* first, const stm::PointCells<2>::FacetEntry* last)
    {
      if (first->Others[0] == 1)
      {
        for (auto* entry = first; entry != last; ++entry)
        {
          shared.push_back(entry->Cell);
        }
      }
    });
  EXPECT_EQ(shared, (std::vector<std::int64_t>{ 0, 1, 2 }));
}

} // namespace
