// SPDX-License-Identifier: BSD-3-Clause
// GhostRings: on Kuhn triangulations of cube grids (2D, 3D and 4D) whose own cells are a slab of
// cubes, every Kuhn simplex of a cube holds the cube's first corner, so the ghost cells of the
// j-th layer of cubes past the slab are exactly ring j; rings beyond the requested number, and
// ghost cells not joined to the own cells, are in none; threads do not change the rings.

#include "Common/GhostRings.h"

#include "CoreTestUtilities.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace
{

template <class Dimension>
class GhostRingsTest : public ::testing::Test
{
};
using MeshDimensions = ::testing::Types<stmtest::Dim<2>, stmtest::Dim<3>, stmtest::Dim<4>>;
TYPED_TEST_SUITE(GhostRingsTest, MeshDimensions);

/// Simplices per cube of the Kuhn triangulation: Dim!.
constexpr int Factorial(int n)
{
  return n <= 1 ? 1 : n * Factorial(n - 1);
}

TYPED_TEST(GhostRingsTest, LayersOfCubesPastTheOwnSlabAreTheRings)
{
  constexpr int Dim = TypeParam::value;
  constexpr int n = 6;
  constexpr int ownLayers = 2;
  std::int64_t points = 0;
  const std::vector<std::int64_t> grid = stmtest::KuhnGrid<Dim>(n, points);
  const auto cells = static_cast<std::int64_t>(grid.size()) / (Dim + 1);
  // KuhnGrid numbers the cubes with axis 0 fastest, Dim! cells each.
  auto layerOf = [&](std::int64_t cell) { return static_cast<int>((cell / Factorial(Dim)) % n); };
  std::vector<std::uint8_t> ghost(static_cast<std::size_t>(cells));
  for (std::int64_t c = 0; c < cells; ++c)
  {
    ghost[c] = layerOf(c) >= ownLayers ? 1 : 0;
  }
  for (int rings = 0; rings <= n; ++rings)
  {
    stm::SequentialExecutor executor;
    const std::vector<std::uint8_t> found =
      stm::GhostRings(grid.data(), Dim + 1, cells, points, ghost.data(), rings, executor);
    ASSERT_EQ(found.size(), static_cast<std::size_t>(cells));
    for (std::int64_t c = 0; c < cells; ++c)
    {
      const int ring = layerOf(c) < ownLayers ? 0 : layerOf(c) - ownLayers + 1;
      const std::uint8_t expected =
        ring <= rings ? static_cast<std::uint8_t>(ring) : stm::NotInAnyRing;
      ASSERT_EQ(found[c], expected) << "cell " << c << ", rings " << rings;
    }
    stm::ThreadPoolExecutor threads(3);
    EXPECT_EQ(
      stm::GhostRings(grid.data(), Dim + 1, cells, points, ghost.data(), rings, threads), found);
  }
}

TYPED_TEST(GhostRingsTest, GhostCellsApartFromTheOwnCellsAreInNoRing)
{
  constexpr int Dim = TypeParam::value;
  // Two grids side by side without a shared point: the first own, the second ghost.
  std::int64_t points = 0;
  std::vector<std::int64_t> grid = stmtest::KuhnGrid<Dim>(2, points);
  const std::size_t ids = grid.size();
  for (std::size_t i = 0; i < ids; ++i)
  {
    grid.push_back(grid[i] + points);
  }
  const auto cells = static_cast<std::int64_t>(grid.size()) / (Dim + 1);
  std::vector<std::uint8_t> ghost(static_cast<std::size_t>(cells), 0);
  std::fill(ghost.begin() + cells / 2, ghost.end(), std::uint8_t{ 1 });
  stm::SequentialExecutor executor;
  const std::vector<std::uint8_t> found =
    stm::GhostRings(grid.data(), Dim + 1, cells, 2 * points, ghost.data(), 254, executor);
  for (std::int64_t c = 0; c < cells; ++c)
  {
    EXPECT_EQ(found[c], c < cells / 2 ? 0 : stm::NotInAnyRing) << "cell " << c;
  }
}

} // namespace
