// SPDX-License-Identifier: BSD-3-Clause
// PointCells: ForEachFacetAt, over every point with smallestOnly, visits each facet of the mesh
// once with the cells that FacetNeighbour pairs, and without it once from each of the facet's
// points, on Kuhn triangulations of cube grids (2D, 3D and 4D: conforming, with outer-boundary
// facets), a chain of segments (1D) and a non-manifold fan (three triangles on one edge); and
// the parallel Build gives the serial rows; the visits come in ascending order.

#include "Common/PointCells.h"

#include "CoreTestUtilities.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <numeric>
#include <vector>

namespace
{

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
  auto grid2 = stmtest::KuhnGrid<2>(5, points);
  CheckAgainstFacetNeighbour<2>(grid2, points, 4 * 5);
  auto grid3 = stmtest::KuhnGrid<3>(4, points);
  CheckAgainstFacetNeighbour<3>(grid3, points, 6 * 16 * 2);
  auto grid4 = stmtest::KuhnGrid<4>(2, points);
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

/// ForEachFacetAt visits the facets in ascending order of their other points and each facet's
/// cells in ascending order (FacetEntry's operator<), by the packed sort of up to 64 entries as
/// by std::sort beyond: every entry of the point's cells once.
template <int Dim>
void CheckVisitOrder(const std::vector<std::int64_t>& connectivity, std::int64_t numberOfPoints,
  std::array<std::int64_t, 2>& packedAndBeyond)
{
  constexpr int Corners = Dim + 1;
  using Entry = typename stm::PointCells<Dim>::FacetEntry;
  const auto cells = static_cast<std::int64_t>(connectivity.size()) / Corners;
  stm::PointCells<Dim> incidence;
  incidence.Build(connectivity.data(), cells, numberOfPoints);
  std::vector<Entry> entries;
  for (const bool smallestOnly : { true, false })
  {
    std::int64_t visited = 0;
    for (std::int64_t p = 0; p < numberOfPoints; ++p)
    {
      std::vector<Entry> sequence;
      incidence.ForEachFacetAt(
        connectivity.data(), p, smallestOnly, entries, [](std::int64_t, int) { return true; },
        [&](const Entry* first, const Entry* last)
        {
          for (const Entry* entry = first; entry != last; ++entry)
          {
            ASSERT_TRUE(entry->SameFacet(*first));
          }
          if (!sequence.empty())
          {
            ASSERT_FALSE(sequence.back().SameFacet(*first));
          }
          sequence.insert(sequence.end(), first, last);
        });
      ASSERT_TRUE(std::is_sorted(sequence.begin(), sequence.end()));
      for (std::size_t i = 1; i < sequence.size(); ++i)
      {
        ASSERT_TRUE(sequence[i - 1] < sequence[i]) << "point " << p << ", entry " << i;
      }
      ++packedAndBeyond[sequence.size() <= 64 ? 0 : 1];
      visited += static_cast<std::int64_t>(sequence.size());
    }
    // Each facet side once from its smallest point, or once from each of its Dim points.
    EXPECT_EQ(visited, cells * Corners * (smallestOnly ? 1 : Dim));
  }
}

TEST(PointCells, VisitsFacetsInAscendingOrder)
{
  std::int64_t points = 0;
  std::array<std::int64_t, 2> packedAndBeyond = { 0, 0 };
  const std::vector<std::int64_t> grid2 = stmtest::KuhnGrid<2>(6, points);
  CheckVisitOrder<2>(grid2, points, packedAndBeyond);
  EXPECT_EQ(packedAndBeyond[1], 0);
  // 3D: the inner points' 24 cells give 72 entries without smallestOnly, beyond the packed
  // sort.
  const std::vector<std::int64_t> grid3 = stmtest::KuhnGrid<3>(4, points);
  CheckVisitOrder<3>(grid3, points, packedAndBeyond);
  EXPECT_EQ(packedAndBeyond[1], 27);
  // 40 triangles around point 0, in a shuffled order of their outer points: 80 entries at
  // point 0, the smallest point of all its facets, with smallestOnly and without.
  std::vector<std::int64_t> fan;
  for (std::int64_t i = 0; i < 40; ++i)
  {
    const std::int64_t a = 1 + (i * 17) % 41, b = 1 + (i * 17 + 1) % 41;
    fan.insert(fan.end(), { b, 0, a });
  }
  CheckVisitOrder<2>(fan, 42, packedAndBeyond);
  EXPECT_EQ(packedAndBeyond[1], 29);
  EXPECT_GT(packedAndBeyond[0], 0);
}

/// The parallel Build gives the serial one's rows, on any number of threads, for a mesh large
/// enough for its ranges (a shuffled cell order, so rows hold cells of every range).
template <int Dim>
void CheckParallelBuild(int n)
{
  constexpr int Corners = Dim + 1;
  std::int64_t points = 0;
  std::vector<std::int64_t> grid = stmtest::KuhnGrid<Dim>(n, points);
  const auto cells = static_cast<std::int64_t>(grid.size()) / Corners;
  ASSERT_GE(cells, 1 << 16) << "below the serial threshold";
  std::vector<std::int64_t> order(static_cast<std::size_t>(cells));
  std::iota(order.begin(), order.end(), 0);
  std::uint64_t state = 12345;
  for (std::int64_t i = cells - 1; i > 0; --i)
  {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    std::swap(order[i], order[static_cast<std::int64_t>((state >> 33) % (i + 1))]);
  }
  std::vector<std::int32_t> shuffled(grid.size());
  for (std::int64_t c = 0; c < cells; ++c)
  {
    for (int v = 0; v < Corners; ++v)
    {
      shuffled[c * Corners + v] = static_cast<std::int32_t>(grid[order[c] * Corners + v]);
    }
  }
  stm::PointCells<Dim> serial;
  serial.Build(shuffled.data(), cells, points);
  ASSERT_EQ(serial.Offsets.back(), cells * Corners);
  for (const int threads : { 1, 2, 3 })
  {
    stm::ThreadPoolExecutor executor(threads);
    stm::PointCells<Dim> parallel;
    parallel.Build(shuffled.data(), cells, points, executor);
    EXPECT_EQ(parallel.Offsets, serial.Offsets) << threads << " threads";
    EXPECT_EQ(parallel.Cells, serial.Cells) << threads << " threads";
  }
  // Each row ascends and holds exactly the cells with that point.
  std::vector<std::int64_t> seen(static_cast<std::size_t>(points), 0);
  for (std::int64_t p = 0; p < points; ++p)
  {
    for (std::int64_t k = serial.Offsets[p]; k < serial.Offsets[p + 1]; ++k)
    {
      const std::int64_t cell = serial.Cells[k];
      ASSERT_TRUE(k == serial.Offsets[p] || serial.Cells[k - 1] < cell);
      const std::int32_t* ids = shuffled.data() + cell * Corners;
      ASSERT_NE(std::find(ids, ids + Corners, p), ids + Corners);
      ++seen[p];
    }
  }
  EXPECT_EQ(std::accumulate(seen.begin(), seen.end(), std::int64_t{ 0 }), cells * Corners);
}

TEST(PointCells, ParallelBuildGivesTheSerialRows)
{
  CheckParallelBuild<2>(190); // 72,200 triangles
  CheckParallelBuild<3>(23);  // 73,002 tetrahedra
  CheckParallelBuild<4>(8);   // 98,304 4-simplices
}

/// Rows of 32-bit cell ids (what the smoother keeps) hold the cells of the 64-bit rows, from
/// either build, and give the same facet neighbours.
template <int Dim>
void CheckNarrowRows(int n)
{
  constexpr int Corners = Dim + 1;
  std::int64_t points = 0;
  const std::vector<std::int64_t> grid = stmtest::KuhnGrid<Dim>(n, points);
  const auto cells = static_cast<std::int64_t>(grid.size()) / Corners;
  stm::PointCells<Dim> wide;
  wide.Build(grid.data(), cells, points);
  stm::PointCells<Dim, std::int32_t> serial;
  serial.Build(grid.data(), cells, points);
  stm::ThreadPoolExecutor executor(2);
  stm::PointCells<Dim, std::int32_t> parallel;
  parallel.Build(grid.data(), cells, points, executor);
  const std::vector<std::int64_t> widened(serial.Cells.begin(), serial.Cells.end());
  EXPECT_EQ(serial.Offsets, wide.Offsets);
  EXPECT_EQ(widened, std::vector<std::int64_t>(wide.Cells.begin(), wide.Cells.end()));
  EXPECT_EQ(parallel.Offsets, wide.Offsets);
  EXPECT_EQ(parallel.Cells, serial.Cells);
  std::int64_t inner = 0;
  for (std::int64_t c = 0; c < cells; ++c)
  {
    for (int corner = 0; corner < Corners; ++corner)
    {
      const std::int64_t neighbour = serial.FacetNeighbour(grid.data() + c * Corners, c, corner);
      ASSERT_EQ(neighbour, wide.FacetNeighbour(grid.data() + c * Corners, c, corner));
      inner += neighbour >= 0 ? 1 : 0;
    }
  }
  // The outer boundary: 2 Dim faces of n^(Dim-1) cube faces, each of (Dim-1)! facets.
  std::int64_t boundary = 2 * Dim;
  for (int d = 1; d < Dim; ++d)
  {
    boundary *= n * d;
  }
  EXPECT_EQ(inner, cells * Corners - boundary);
}

TEST(PointCells, NarrowRowsHoldTheSameCells)
{
  CheckNarrowRows<2>(190); // 72,200 triangles: the parallel build's ranges
  CheckNarrowRows<3>(23);  // 73,002 tetrahedra
  CheckNarrowRows<4>(8);   // 98,304 4-simplices
  EXPECT_TRUE((stm::PointCells<3, std::int32_t>::FitsCellIds(2147483647)));
  EXPECT_FALSE((stm::PointCells<3, std::int32_t>::FitsCellIds(2147483648)));
  EXPECT_TRUE((stm::PointCells<3>::FitsCellIds(2147483648)));
}

} // namespace
