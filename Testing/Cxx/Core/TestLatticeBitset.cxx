// SPDX-License-Identifier: BSD-3-Clause
// LatticeBitset numbers the points of every mesh: its ranks must be consecutive in lattice order
// and must not depend on which thread set a bit, or point ids would change with the thread count.

#include "CoreTestUtilities.h"

#include "Common/LatticeBitset.h"

namespace
{
using namespace stmtest;

template <class DimensionTag>
class LatticeBitsetTest : public ::testing::Test
{
};
TYPED_TEST_SUITE(LatticeBitsetTest, AllDimensions);

/// Awkward extents (not multiples of 64 in total) so that words straddle rows.
template <int D>
stm::LatticeIndex<D> BitsetExtents()
{
  return FirstExtents<D>({ 131, 13, 7, 5 });
}

/// A reproducible random subset of the lattice, in lattice order.
template <int D>
std::vector<stm::LatticeIndex<D>> RandomPointsInOrder(
  const stm::LatticeIndex<D>& dims, unsigned seed, int percent)
{
  std::mt19937 random(seed);
  std::vector<stm::LatticeIndex<D>> points;
  ForEachIndex<D>(dims,
    [&](const stm::LatticeIndex<D>& point)
    {
      if (static_cast<int>(random() % 100) < percent)
      {
        points.push_back(point);
      }
    });
  return points;
}

/// Sets the bits of a point list from whatever thread the executor runs a range on.
template <int D>
struct SetPointsKernel
{
  using Scratch = stm::NoScratch;
  stm::LatticeBitset<D>* Bits;
  const std::vector<stm::LatticeIndex<D>>* Points;
  void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
  {
    for (std::int64_t i = begin; i < end; ++i)
    {
      this->Bits->Set((*this->Points)[i]);
    }
  }
};

TYPED_TEST(LatticeBitsetTest, SetAndTestAgreeWithTheSetOfPoints)
{
  constexpr int D = TypeParam::value;
  const auto dims = BitsetExtents<D>();
  for (unsigned seed : { 1u, 2u, 3u })
  {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const auto points = RandomPointsInOrder<D>(dims, seed, 30);
    stm::LatticeBitset<D> bits(dims);
    EXPECT_EQ(bits.GetDimensions(), dims);
    EXPECT_EQ(bits.GetNumberOfWords(), (stm::NumberOfLatticeCells<D>(dims) + 63) / 64);
    for (const auto& point : points)
    {
      bits.Set(point);
      bits.Set(point); // setting twice is harmless
    }
    std::int64_t wrong = 0, next = 0;
    ForEachIndex<D>(dims,
      [&](const stm::LatticeIndex<D>& point)
      {
        const bool expected =
          next < static_cast<std::int64_t>(points.size()) && points[next] == point;
        next += expected;
        wrong += bits.Test(point) != expected;
      });
    EXPECT_EQ(wrong, 0);
  }
}

TYPED_TEST(LatticeBitsetTest, RanksAreConsecutiveInLatticeOrder)
{
  constexpr int D = TypeParam::value;
  const auto dims = BitsetExtents<D>();
  for (unsigned seed : { 4u, 5u })
  {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const auto points = RandomPointsInOrder<D>(dims, seed, 25);
    stm::LatticeBitset<D> bits(dims);
    // Set in reverse order: the rank must follow the lattice, not the insertion order.
    for (auto point = points.rbegin(); point != points.rend(); ++point)
    {
      bits.Set(*point);
    }
    EXPECT_EQ(bits.GetNumberOfSetBits(), 0) << "no rank before BuildRank";
    EXPECT_EQ(bits.BuildRank(), static_cast<std::int64_t>(points.size()));
    EXPECT_EQ(bits.GetNumberOfSetBits(), static_cast<std::int64_t>(points.size()));
    std::int64_t wrongRanks = 0;
    for (std::size_t id = 0; id < points.size(); ++id)
    {
      wrongRanks += bits.Rank(points[id]) != static_cast<std::int64_t>(id);
    }
    EXPECT_EQ(wrongRanks, 0);
  }
}

TYPED_TEST(LatticeBitsetTest, VisitSetBitsReportsEveryPointOnceWithItsRank)
{
  constexpr int D = TypeParam::value;
  const auto dims = BitsetExtents<D>();
  const auto points = RandomPointsInOrder<D>(dims, 6, 40);
  stm::LatticeBitset<D> bits(dims);
  for (const auto& point : points)
  {
    bits.Set(point);
  }
  bits.BuildRank();

  std::vector<std::pair<std::int64_t, stm::LatticeIndex<D>>> expected;
  for (std::size_t id = 0; id < points.size(); ++id)
  {
    expected.emplace_back(static_cast<std::int64_t>(id), points[id]);
  }

  std::vector<std::pair<std::int64_t, stm::LatticeIndex<D>>> visited;
  bits.VisitSetBits(0, bits.GetNumberOfWords(),
    [&](std::int64_t id, const stm::LatticeIndex<D>& point) { visited.emplace_back(id, point); });
  EXPECT_EQ(visited, expected);

  // Word ranges visited separately (as the parallel VisitPoints does) give the same ids.
  visited.clear();
  for (std::int64_t word = 0; word < bits.GetNumberOfWords(); word += 3)
  {
    bits.VisitSetBits(word, std::min(word + 3, bits.GetNumberOfWords()),
      [&](std::int64_t id, const stm::LatticeIndex<D>& point) { visited.emplace_back(id, point); });
  }
  EXPECT_EQ(visited, expected);
}

TYPED_TEST(LatticeBitsetTest, ConcurrentSetGivesTheSameBitsAndRanks)
{
  constexpr int D = TypeParam::value;
  const auto dims = BitsetExtents<D>();
  const auto points = RandomPointsInOrder<D>(dims, 7, 50);

  stm::LatticeBitset<D> sequentialBits(dims);
  stm::SequentialExecutor sequential;
  SetPointsKernel<D> sequentialKernel{ &sequentialBits, &points };
  sequential.For(0, static_cast<std::int64_t>(points.size()), 1, sequentialKernel);
  sequentialBits.BuildRank();

  for (int threads : { 2, 3 })
  {
    SCOPED_TRACE(std::to_string(threads) + " threads");
    stm::LatticeBitset<D> parallelBits(dims);
    stm::ThreadPoolExecutor pool(threads);
    // Grain 1 makes neighbouring points, which share words, land on different threads.
    SetPointsKernel<D> parallelKernel{ &parallelBits, &points };
    pool.For(0, static_cast<std::int64_t>(points.size()), 1, parallelKernel);
    EXPECT_EQ(parallelBits.BuildRank(), sequentialBits.GetNumberOfSetBits());
    std::int64_t differences = 0;
    ForEachIndex<D>(dims,
      [&](const stm::LatticeIndex<D>& point)
      {
        const bool set = sequentialBits.Test(point);
        differences += parallelBits.Test(point) != set;
        differences += set && parallelBits.Rank(point) != sequentialBits.Rank(point);
      });
    EXPECT_EQ(differences, 0);
  }
}

TYPED_TEST(LatticeBitsetTest, FullLatticeWhoseSizeIsAMultipleOfTheWordSize)
{
  constexpr int D = TypeParam::value;
  // 4^D * 4 or 64 bits exactly: the last word is full and its rank entry is the total.
  stm::LatticeIndex<D> dims = UniformExtents<D>(4);
  dims[0] = D == 1 ? 128 : (D == 2 ? 32 : 4 * 4);
  stm::LatticeBitset<D> bits(dims);
  const std::int64_t total = stm::NumberOfLatticeCells<D>(dims);
  ASSERT_EQ(total % 64, 0);
  ForEachIndex<D>(dims, [&](const stm::LatticeIndex<D>& point) { bits.Set(point); });
  EXPECT_EQ(bits.BuildRank(), total);
  std::int64_t wrongRanks = 0;
  ForEachIndex<D>(dims,
    [&](const stm::LatticeIndex<D>& point)
    { wrongRanks += bits.Rank(point) != stm::LinearIndex<D>(point, dims); });
  EXPECT_EQ(wrongRanks, 0);
}

TYPED_TEST(LatticeBitsetTest, ContainsIsTheHalfOpenBox)
{
  constexpr int D = TypeParam::value;
  const auto dims = BitsetExtents<D>();
  stm::LatticeBitset<D> bits(dims);
  EXPECT_TRUE(bits.Contains(stm::LatticeIndex<D>{}));
  for (int axis = 0; axis < D; ++axis)
  {
    stm::LatticeIndex<D> inside{}, below{}, beyond{};
    inside[axis] = dims[axis] - 1;
    below[axis] = -1;
    beyond[axis] = dims[axis];
    EXPECT_TRUE(bits.Contains(inside)) << ToString<D>(inside);
    EXPECT_FALSE(bits.Contains(below)) << ToString<D>(below);
    EXPECT_FALSE(bits.Contains(beyond)) << ToString<D>(beyond);
  }
}

} // namespace
