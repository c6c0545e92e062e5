// SPDX-License-Identifier: BSD-3-Clause
// The compile-time tables of Common/CubeInfo.h and the neighbour directions of balancing,
// checked against counts obtained by enumerating the cube {0,1}^D, its faces {0,1,*}^D and the
// directions {-1,0,1}^D, so that no expected value repeats the closed formula under test.

#include "CoreTestUtilities.h"

#include <set>

namespace
{
using namespace stmtest;

template <class DimensionTag>
class CubeInfoTest : public ::testing::Test
{
};
TYPED_TEST_SUITE(CubeInfoTest, AllDimensions);

/// Number of k-faces of the D-cube: words over {0, 1, *} of length D with exactly k stars.
int CountFacesByEnumeration(int dimension, int k)
{
  int count = 0;
  for (int word = 0; word < stm::IntPow(3, dimension); ++word)
  {
    int stars = 0;
    for (int rest = word, axis = 0; axis < dimension; ++axis, rest /= 3)
    {
      stars += rest % 3 == 2;
    }
    count += stars == k;
  }
  return count;
}

TYPED_TEST(CubeInfoTest, VertexFacetAndEdgeCountsMatchEnumeration)
{
  constexpr int D = TypeParam::value;
  using Info = stm::CubeInfo<D>;

  int vertices = 0;
  ForEachIndex<D>(UniformExtents<D>(2), [&](const stm::LatticeIndex<D>&) { ++vertices; });
  EXPECT_EQ(Info::VerticesPerCell, vertices);

  // Edges: pairs of cube vertices that differ in exactly one coordinate.
  int edges = 0;
  for (int a = 0; a < Info::VerticesPerCell; ++a)
  {
    for (int b = a + 1; b < Info::VerticesPerCell; ++b)
    {
      edges += stm::PopCount(static_cast<unsigned>(a ^ b)) == 1;
    }
  }
  EXPECT_EQ(Info::EdgesPerCell, edges);
  EXPECT_EQ(Info::EdgesPerCell, D * (1 << (D - 1)));

  EXPECT_EQ(Info::FacetsPerCell, CountFacesByEnumeration(D, D - 1));
  EXPECT_EQ(Info::FacetsPerCell, 2 * D);
  EXPECT_EQ(Info::VerticesPerSimplex, D + 1);
}

TYPED_TEST(CubeInfoTest, FacesOfEveryDimensionMatchEnumerationAndSumToThreeToTheD)
{
  constexpr int D = TypeParam::value;
  int total = 0;
  for (int k = 0; k <= D; ++k)
  {
    SCOPED_TRACE("k = " + std::to_string(k));
    EXPECT_EQ(stm::CubeInfo<D>::FacesOfDimension(k), CountFacesByEnumeration(D, k));
    total += stm::CubeInfo<D>::FacesOfDimension(k);
  }
  int threeToTheD = 1;
  for (int axis = 0; axis < D; ++axis)
  {
    threeToTheD *= 3;
  }
  EXPECT_EQ(total, threeToTheD);
  EXPECT_EQ(stm::CubeInfo<D>::FacesOfDimension(0), stm::CubeInfo<D>::VerticesPerCell);
  EXPECT_EQ(stm::CubeInfo<D>::FacesOfDimension(1), stm::CubeInfo<D>::EdgesPerCell);
  EXPECT_EQ(stm::CubeInfo<D>::FacesOfDimension(D), 1);
}

TYPED_TEST(CubeInfoTest, NeighborDirectionCountIsThreeToTheDMinusOne)
{
  constexpr int D = TypeParam::value;
  int directions = 0;
  ForEachIndex<D>(UniformExtents<D>(3),
    [&](const stm::LatticeIndex<D>& shifted)
    {
      directions +=
        std::any_of(shifted.begin(), shifted.end(), [](std::int64_t c) { return c != 1; });
    });
  EXPECT_EQ(stm::CubeInfo<D>::NeighborDirections, directions);
}

TYPED_TEST(CubeInfoTest, KuhnSimplexCountIsNumberOfPermutations)
{
  constexpr int D = TypeParam::value;
  std::array<int, D> axes;
  std::iota(axes.begin(), axes.end(), 0);
  int permutations = 0;
  do
  {
    ++permutations;
  } while (std::next_permutation(axes.begin(), axes.end()));
  EXPECT_EQ(stm::CubeInfo<D>::KuhnSimplicesPerCell, permutations);
}

TEST(CubeInfo, CheckerboardSimplexCountsAreOneTwoFive)
{
  EXPECT_EQ(stm::CubeInfo<1>::CheckerboardSimplicesPerCell, 1);
  EXPECT_EQ(stm::CubeInfo<2>::CheckerboardSimplicesPerCell, 2);
  EXPECT_EQ(stm::CubeInfo<3>::CheckerboardSimplicesPerCell, 5);
  // The template does not exist in 4D; the table says so with zero.
  EXPECT_EQ(stm::CubeInfo<4>::CheckerboardSimplicesPerCell, 0);
}

TEST(CubeInfo, IntPowMatchesRepeatedMultiplication)
{
  for (int base = 0; base <= 5; ++base)
  {
    std::int64_t power = 1;
    for (int exponent = 0; exponent <= 10; ++exponent)
    {
      EXPECT_EQ(stm::IntPow(base, exponent), power) << base << "^" << exponent;
      power *= base;
    }
  }
  static_assert(stm::IntPow(3, 4) == 81, "IntPow must be usable at compile time");
}

TEST(CubeInfo, FactorialMatchesProduct)
{
  std::int64_t product = 1;
  EXPECT_EQ(stm::Factorial(0), 1);
  for (int n = 1; n <= 12; ++n)
  {
    product *= n;
    EXPECT_EQ(stm::Factorial(n), product) << n << "!";
  }
  static_assert(stm::Factorial(4) == 24, "Factorial must be usable at compile time");
}

TEST(CubeInfo, BinomialMatchesMultiplicativeFormula)
{
  for (int n = 0; n <= 16; ++n)
  {
    // C(n, k) = C(n, k-1) (n-k+1) / k, exact in 64 bits for these n.
    std::int64_t expected = 1;
    for (int k = 0; k <= n; ++k)
    {
      if (k > 0)
      {
        expected = expected * (n - k + 1) / k;
      }
      EXPECT_EQ(stm::Binomial(n, k), expected) << "C(" << n << "," << k << ")";
    }
    EXPECT_EQ(stm::Binomial(n, -1), 0);
    EXPECT_EQ(stm::Binomial(n, n + 1), 0);
  }
}

TEST(CubeInfo, PopCountMatchesBitByBitCount)
{
  for (unsigned value = 0; value < 4096; ++value)
  {
    int bits = 0;
    for (unsigned rest = value; rest != 0; rest >>= 1)
    {
      bits += rest & 1u;
    }
    EXPECT_EQ(stm::PopCount(value), bits) << value;
  }
  EXPECT_EQ(stm::PopCount(0xFFFFFFFFu), 32);
}

TEST(CubeInfo, PopCount64MatchesBitByBitCount)
{
  std::mt19937_64 random(99);
  std::vector<std::uint64_t> values = { 0, 1, ~std::uint64_t{ 0 }, std::uint64_t{ 1 } << 63,
    0x8000000000000001ull, 0x5555555555555555ull, 0xAAAAAAAAAAAAAAAAull };
  for (int i = 0; i < 1000; ++i)
  {
    // Sparse and dense words both: AND or OR of two random words.
    const std::uint64_t a = random(), b = random();
    values.push_back(i % 2 ? (a & b) : (a | b));
  }
  for (std::uint64_t value : values)
  {
    int bits = 0;
    for (std::uint64_t rest = value; rest != 0; rest >>= 1)
    {
      bits += static_cast<int>(rest & 1u);
    }
    EXPECT_EQ(stm::PopCount64(value), bits) << std::hex << value;
  }
}

TYPED_TEST(CubeInfoTest, LinearIndexEnumeratesTheBoxInOrderAxisZeroFastest)
{
  constexpr int D = TypeParam::value;
  const stm::LatticeIndex<D> dims = FirstExtents<D>({ 5, 3, 4, 2 });
  std::int64_t expected = 0;
  ForEachIndex<D>(dims,
    [&](const stm::LatticeIndex<D>& index)
    {
      EXPECT_EQ(stm::LinearIndex<D>(index, dims), expected) << ToString<D>(index);
      ++expected;
    });
  EXPECT_EQ(stm::NumberOfLatticeCells<D>(dims), expected);
  // Axis 0 varies fastest: its unit step is 1.
  stm::LatticeIndex<D> second{};
  second[0] = 1;
  EXPECT_EQ(stm::LinearIndex<D>(second, dims), 1);
}

TYPED_TEST(CubeInfoTest, NeighborDirectionsAreUniqueNonZeroAndComplete)
{
  constexpr int D = TypeParam::value;
  for (bool facetsOnly : { false, true })
  {
    SCOPED_TRACE(facetsOnly ? "facets only" : "all neighbours");
    const auto directions = stm::NeighborDirections<D>(facetsOnly);
    EXPECT_EQ(static_cast<int>(directions.size()),
      facetsOnly ? stm::CubeInfo<D>::FacetsPerCell : stm::CubeInfo<D>::NeighborDirections);
    std::set<stm::LatticeIndex<D>> distinct(directions.begin(), directions.end());
    EXPECT_EQ(distinct.size(), directions.size()) << "a direction is repeated";
    for (const auto& direction : directions)
    {
      int nonZero = 0;
      for (int axis = 0; axis < D; ++axis)
      {
        EXPECT_GE(direction[axis], -1);
        EXPECT_LE(direction[axis], 1);
        nonZero += direction[axis] != 0;
      }
      EXPECT_GT(nonZero, 0) << "the zero direction is not a neighbour";
      if (facetsOnly)
      {
        EXPECT_EQ(nonZero, 1) << ToString<D>(direction) << " is not a facet direction";
      }
    }
    // Symmetric under negation: a neighbour relation must be mutual.
    for (const auto& direction : directions)
    {
      stm::LatticeIndex<D> opposite;
      for (int axis = 0; axis < D; ++axis)
      {
        opposite[axis] = -direction[axis];
      }
      EXPECT_EQ(distinct.count(opposite), 1u) << ToString<D>(direction);
    }
  }
}

} // namespace
