// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreExactSum_h
#define stmCoreExactSum_h

// Sums of doubles that do not depend on the order of the additions. The pieces of a distributed
// mesh sum their own cells' volumes in their own order; a floating-point sum would round each
// piece's partial sum differently from the whole mesh's sum, and the smoothing that follows the
// volumes would move the pieces' points by other last bits than the whole mesh's.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

namespace stm
{

/// The exact sum of any finite doubles, as a fixed-point number spanning every double: digits of
/// 32 bits, from 2^-1074 up, held in 64-bit words whose spare bits absorb the carries until a
/// normalisation. Adding is exact and commutative, so the value, its rounding (Value) and its
/// parts (Parts) are the same whatever the order of the additions and however they are split
/// (threads, pieces: add their parts). A non-finite addend makes the value NaN.
class ExactSum
{
public:
  ExactSum() { std::fill(this->Digits, this->Digits + NumberOfDigits, std::int64_t{ 0 }); }

  void Add(double value)
  {
    std::uint64_t bits;
    std::memcpy(&bits, &value, sizeof bits);
    const auto biased = static_cast<int>((bits >> 52) & 0x7ff);
    if (biased == 0x7ff)
    {
      this->Finite = false;
      return;
    }
    // value = +-mantissa * 2^(shift - 1074) exactly.
    std::uint64_t mantissa = bits & ((std::uint64_t{ 1 } << 52) - 1);
    int shift = 0;
    if (biased > 0)
    {
      mantissa |= std::uint64_t{ 1 } << 52;
      shift = biased - 1;
    }
    if (mantissa == 0)
    {
      return;
    }
    const int digit = shift / DigitBits, offset = shift % DigitBits;
    // mantissa << offset spans three digits; each word receives less than 2^33.
    const std::uint64_t low = (mantissa & DigitMask) << offset;
    const std::uint64_t high = (mantissa >> DigitBits) << offset;
    const auto d0 = static_cast<std::int64_t>(low & DigitMask);
    const auto d1 = static_cast<std::int64_t>((low >> DigitBits) + (high & DigitMask));
    const auto d2 = static_cast<std::int64_t>(high >> DigitBits);
    if (bits >> 63)
    {
      this->Digits[digit] -= d0;
      this->Digits[digit + 1] -= d1;
      this->Digits[digit + 2] -= d2;
    }
    else
    {
      this->Digits[digit] += d0;
      this->Digits[digit + 1] += d1;
      this->Digits[digit + 2] += d2;
    }
    if (++this->Pending == CarryInterval)
    {
      this->Normalize();
    }
  }

  void Add(const ExactSum& other)
  {
    ExactSum normal(other);
    normal.Normalize();
    this->Normalize();
    for (int d = 0; d < NumberOfDigits; ++d)
    {
      this->Digits[d] += normal.Digits[d];
    }
    this->Finite = this->Finite && other.Finite;
    this->Pending = 1;
  }

  /// The sum rounded to a double: a function of the exact value alone (within a few units in
  /// the last place of the exact sum; infinite beyond the doubles' range).
  double Value() const
  {
    if (!this->Finite)
    {
      return std::numeric_limits<double>::quiet_NaN();
    }
    bool negative = false;
    const ExactSum magnitude = this->Magnitude(negative);
    double value = 0.0;
    for (int d = 0; d < NumberOfDigits; ++d) // smallest first: the parts do not overlap
    {
      value += std::ldexp(static_cast<double>(magnitude.Digits[d]), d * DigitBits - 1074);
    }
    return negative ? -value : value;
  }

  /// Doubles whose exact sum is this sum (one per non-zero digit, smallest first; empty for
  /// zero): to send the sum to another piece, which adds the parts to its own sum.
  std::vector<double> Parts() const
  {
    std::vector<double> parts;
    if (!this->Finite)
    {
      parts.push_back(std::numeric_limits<double>::quiet_NaN());
      return parts;
    }
    bool negative = false;
    const ExactSum magnitude = this->Magnitude(negative);
    for (int d = 0; d < NumberOfDigits; ++d)
    {
      if (magnitude.Digits[d] != 0)
      {
        const double part =
          std::ldexp(static_cast<double>(magnitude.Digits[d]), d * DigitBits - 1074);
        parts.push_back(negative ? -part : part);
      }
    }
    return parts;
  }

private:
  static constexpr int DigitBits = 32;
  static constexpr std::uint64_t DigitMask = (std::uint64_t{ 1 } << DigitBits) - 1;
  // Shifts 0 to 2045 (the finite doubles) reach digit 63 + 2; two more take the carries of sums
  // beyond the largest double.
  static constexpr int NumberOfDigits = 68;
  // Additions between normalisations: each changes a word by less than 2^33, a word holds 2^63.
  static constexpr std::int64_t CarryInterval = std::int64_t{ 1 } << 29;

  /// Every digit but the last in [0, 2^32), the last signed: one form per value.
  void Normalize()
  {
    for (int d = 0; d + 1 < NumberOfDigits; ++d)
    {
      const auto low =
        static_cast<std::int64_t>(static_cast<std::uint64_t>(this->Digits[d]) & DigitMask);
      this->Digits[d + 1] += (this->Digits[d] - low) / (std::int64_t{ 1 } << DigitBits);
      this->Digits[d] = low;
    }
    this->Pending = 0;
  }

  /// The normalised absolute value, and whether the sum is negative.
  ExactSum Magnitude(bool& negative) const
  {
    ExactSum magnitude(*this);
    magnitude.Normalize();
    negative = magnitude.Digits[NumberOfDigits - 1] < 0;
    if (negative)
    {
      for (std::int64_t& digit : magnitude.Digits)
      {
        digit = -digit;
      }
      magnitude.Normalize();
    }
    return magnitude;
  }

  std::int64_t Digits[NumberOfDigits];
  std::int64_t Pending = 0;
  bool Finite = true;
};

} // namespace stm

#endif
