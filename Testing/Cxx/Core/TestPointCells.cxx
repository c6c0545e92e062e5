// SPDX-License-Identifier: BSD-3-Clause
// PointCells: AllFacetNeighbours gives, facet by facet, what FacetNeighbour gives, on Kuhn
// triangulations of cube grids (2D, 3D and 4D: conforming, with outer-boundary facets) and on
// a non-manifold fan (three triangles on one edge, where the smallest other cell wins).

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
  const auto cells = static_cast<std::int64_t>(connectivity.size()) / Corners;
  stm::PointCells<Dim> incidence;
  incidence.Build(connectivity.data(), cells, numberOfPoints);
  std::int64_t outer = 0;
  for (std::int64_t c = 0; c < cells; ++c)
  {
    std::int64_t all[Corners];
    incidence.AllFacetNeighbours(connectivity.data(), c, all);
    for (int corner = 0; corner < Corners; ++corner)
    {
      const std::int64_t one =
        incidence.FacetNeighbour(connectivity.data() + c * Corners, c, corner);
      ASSERT_EQ(all[corner], one) << "cell " << c << ", facet " << corner;
      outer += one < 0;
    }
  }
  EXPECT_EQ(outer, expectedOuterFacets);
}

TEST(PointCells, AllFacetNeighboursAgreeWithFacetNeighbour)
{
  std::int64_t points = 0;
  // Outer facets: 2 Dim faces of n^(Dim-1) cubes, each face (Dim-1)! simplices.
  auto grid2 = KuhnGrid<2>(5, points);
  CheckAgainstFacetNeighbour<2>(grid2, points, 4 * 5);
  auto grid3 = KuhnGrid<3>(4, points);
  CheckAgainstFacetNeighbour<3>(grid3, points, 6 * 16 * 2);
  auto grid4 = KuhnGrid<4>(2, points);
  CheckAgainstFacetNeighbour<4>(grid4, points, 8 * 8 * 6);
  // Three triangles on the edge (0, 1): each one's facet there goes to the smallest other.
  const std::vector<std::int64_t> fan = { 0, 1, 2, 1, 0, 3, 0, 1, 4 };
  CheckAgainstFacetNeighbour<2>(fan, 5, 6);
  stm::PointCells<2> incidence;
  incidence.Build(fan.data(), 3, 5);
  std::int64_t neighbours[3];
  incidence.AllFacetNeighbours(fan.data(), 2, neighbours);
  EXPECT_EQ(neighbours[2], 0);
  incidence.AllFacetNeighbours(fan.data(), 0, neighbours);
  EXPECT_EQ(neighbours[2], 1);
}

} // namespace
