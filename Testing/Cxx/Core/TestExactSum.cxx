// SPDX-License-Identifier: BSD-3-Clause
// ExactSum makes the pieces of a distributed mesh sum volumes to the whole mesh's sums bit for
// bit: its value must not depend on the order or the split of the additions, and its parts must
// add up to the exact sum.

#include "CoreTestUtilities.h"

#include "Common/ExactSum.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

namespace
{

// The exact sums below are integers times 2^-Scale, checked in 128-bit integers.
constexpr int Scale = 40;
using Wide = __int128;

/// The parts' exact sum in units of 2^-Scale (every part of these sums is such a multiple).
Wide PartsInUnits(const stm::ExactSum& sum)
{
  Wide total = 0;
  for (const double part : sum.Parts())
  {
    const double units = std::ldexp(part, Scale);
    EXPECT_EQ(units, std::trunc(units)) << "a part below the addends' unit";
    total += static_cast<Wide>(units);
  }
  return total;
}

std::uint64_t Bits(double value)
{
  std::uint64_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  return bits;
}

TEST(ExactSumTest, TheSumDoesNotDependOnTheOrderOrTheSplitOfTheAdditions)
{
  // Addends of 53 bits over 60 binary orders of magnitude and both signs: a floating-point sum
  // rounds differently in every order.
  std::mt19937_64 random(7);
  std::vector<double> addends;
  Wide exact = 0;
  for (int i = 0; i < 20000; ++i)
  {
    const auto mantissa = static_cast<std::int64_t>(random() >> 11); // below 2^53
    const int shift = static_cast<int>(random() % 60);
    const std::int64_t sign = random() % 3 == 0 ? -1 : 1;
    addends.push_back(std::ldexp(static_cast<double>(sign * mantissa), shift - Scale));
    exact += static_cast<Wide>(sign * mantissa) * (Wide{ 1 } << shift);
  }
  stm::ExactSum inOrder;
  for (const double addend : addends)
  {
    inOrder.Add(addend);
  }
  EXPECT_TRUE(PartsInUnits(inOrder) == exact);
  const double reference = std::ldexp(static_cast<double>(exact), -Scale);
  EXPECT_LE(std::abs(inOrder.Value() - reference), std::abs(reference) * 1e-15);
  double floating = 0.0, shuffledFloating = 0.0;
  for (const double addend : addends)
  {
    floating += addend;
  }

  std::vector<double> shuffled(addends);
  std::shuffle(shuffled.begin(), shuffled.end(), random);
  for (const double addend : shuffled)
  {
    shuffledFloating += addend;
  }
  EXPECT_NE(Bits(floating), Bits(shuffledFloating)) << "the case no longer tests the order";
  // Shuffled, and split into three pieces that send their parts to a fourth.
  stm::ExactSum pieces[3];
  for (std::size_t i = 0; i < shuffled.size(); ++i)
  {
    pieces[(i * 7) % 3].Add(shuffled[i]);
  }
  stm::ExactSum byParts, bySums;
  for (const stm::ExactSum& piece : pieces)
  {
    for (const double part : piece.Parts())
    {
      byParts.Add(part);
    }
    bySums.Add(piece);
  }
  for (const stm::ExactSum* sum : { &byParts, &bySums })
  {
    EXPECT_EQ(Bits(sum->Value()), Bits(inOrder.Value()));
    EXPECT_EQ(sum->Parts(), inOrder.Parts());
  }
}

TEST(ExactSumTest, CancellationsAndTheRangeOfTheDoubles)
{
  stm::ExactSum sum;
  EXPECT_EQ(sum.Value(), 0.0);
  EXPECT_TRUE(sum.Parts().empty());
  // 1e16 + 1 - 1e16: the floating-point sum loses the 1.
  sum.Add(1e16);
  sum.Add(1.0);
  sum.Add(-1e16);
  EXPECT_EQ(sum.Value(), 1.0);
  EXPECT_EQ(sum.Parts(), std::vector<double>{ 1.0 });
  sum.Add(-3.0);
  EXPECT_EQ(sum.Value(), -2.0);
  EXPECT_EQ(sum.Parts(), std::vector<double>{ -2.0 });
  sum.Add(2.0);
  EXPECT_EQ(sum.Value(), 0.0);
  EXPECT_TRUE(sum.Parts().empty());

  // The smallest subnormal and the largest double, together.
  const double tiny = std::numeric_limits<double>::denorm_min();
  const double huge = std::numeric_limits<double>::max();
  stm::ExactSum extremes;
  extremes.Add(huge);
  extremes.Add(tiny);
  extremes.Add(tiny);
  const std::vector<double> parts = extremes.Parts();
  ASSERT_GE(parts.size(), 2u);
  EXPECT_EQ(parts.front(), 2 * tiny);
  EXPECT_EQ(extremes.Value(), huge);
  extremes.Add(-huge);
  EXPECT_EQ(extremes.Value(), 2 * tiny);
  // Beyond the doubles' range the value is infinite, and exact again once back in range.
  stm::ExactSum overflow;
  overflow.Add(huge);
  overflow.Add(huge);
  EXPECT_EQ(overflow.Value(), std::numeric_limits<double>::infinity());
  overflow.Add(-huge);
  EXPECT_EQ(overflow.Value(), huge);

  // Ten times 0.1 is 1 + 5.55e-17 exactly, which rounds to 1.
  stm::ExactSum tenths;
  for (int i = 0; i < 10; ++i)
  {
    tenths.Add(0.1);
  }
  EXPECT_EQ(tenths.Value(), 1.0);
  EXPECT_EQ(tenths.Parts().size(), 2u);

  stm::ExactSum invalid;
  invalid.Add(1.0);
  invalid.Add(std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isnan(invalid.Value()));
}

TEST(ExactSumTest, ManyAdditionsCarryBetweenTheDigits)
{
  // More additions than a digit's word holds without a carry (2^29), each filling three digits.
  const double addend = std::ldexp(static_cast<double>((std::int64_t{ 1 } << 53) - 1), 31 - Scale);
  const std::int64_t count = (std::int64_t{ 1 } << 29) + 12345;
  stm::ExactSum sum;
  for (std::int64_t i = 0; i < count; ++i)
  {
    sum.Add(addend);
  }
  const Wide exact = static_cast<Wide>(count) * (((Wide{ 1 } << 53) - 1) << 31);
  EXPECT_TRUE(PartsInUnits(sum) == exact);
}

} // namespace
