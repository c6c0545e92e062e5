// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreLatticeBitset_h
#define stmCoreLatticeBitset_h

// One bit per point of a box-shaped lattice, settable from many threads, with a rank index
// so that the set points get consecutive ids in lattice order. Used for the spacetree vertex
// set V (which lattice points are leaf corners) and for numbering the points of a mesh: ids
// follow the lattice order, so they do not depend on the number of threads.

#include "CubeInfo.h"

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

namespace stm
{

template <int Dim>
class LatticeBitset
{
public:
  LatticeBitset() = default;

  /// dims: number of lattice points per axis.
  explicit LatticeBitset(const LatticeIndex<Dim>& dims)
    : Dimensions(dims)
    , NumberOfBits(NumberOfLatticeCells<Dim>(dims))
    , NumberOfWords((NumberOfBits + 63) / 64)
    , Words(new std::atomic<std::uint64_t>[static_cast<std::size_t>(NumberOfWords)])
  {
    for (std::int64_t w = 0; w < this->NumberOfWords; ++w)
    {
      this->Words[w].store(0, std::memory_order_relaxed);
    }
  }

  const LatticeIndex<Dim>& GetDimensions() const { return this->Dimensions; }
  std::int64_t GetNumberOfWords() const { return this->NumberOfWords; }

  bool Contains(const LatticeIndex<Dim>& point) const
  {
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (point[axis] < 0 || point[axis] >= this->Dimensions[axis])
      {
        return false;
      }
    }
    return true;
  }

  /// Thread-safe.
  void Set(const LatticeIndex<Dim>& point)
  {
    const std::int64_t bit = LinearIndex<Dim>(point, this->Dimensions);
    const std::uint64_t mask = std::uint64_t{ 1 } << (bit & 63);
    auto& word = this->Words[bit >> 6];
    if ((word.load(std::memory_order_relaxed) & mask) == 0)
    {
      word.fetch_or(mask, std::memory_order_relaxed);
    }
  }

  bool Test(const LatticeIndex<Dim>& point) const
  {
    const std::int64_t bit = LinearIndex<Dim>(point, this->Dimensions);
    return (this->Words[bit >> 6].load(std::memory_order_relaxed) >> (bit & 63)) & 1u;
  }

  /// Builds the rank index; call after the last Set and before Rank. Returns the count of set
  /// bits.
  std::int64_t BuildRank()
  {
    this->WordRank.assign(static_cast<std::size_t>(this->NumberOfWords + 1), 0);
    std::int64_t total = 0;
    for (std::int64_t w = 0; w < this->NumberOfWords; ++w)
    {
      this->WordRank[w] = total;
      total += PopCount64(this->Words[w].load(std::memory_order_relaxed));
    }
    this->WordRank[this->NumberOfWords] = total;
    return total;
  }

  std::int64_t GetNumberOfSetBits() const
  {
    return this->WordRank.empty() ? 0 : this->WordRank.back();
  }

  /// Number of set bits before this point in lattice order, i.e. the point's id.
  std::int64_t Rank(const LatticeIndex<Dim>& point) const
  {
    const std::int64_t bit = LinearIndex<Dim>(point, this->Dimensions);
    const std::uint64_t word = this->Words[bit >> 6].load(std::memory_order_relaxed);
    const std::uint64_t below = word & ((std::uint64_t{ 1 } << (bit & 63)) - 1);
    return this->WordRank[bit >> 6] + PopCount64(below);
  }

  /// Calls visit(id, point) for every set bit of the words [firstWord, lastWord), in order.
  template <class Visitor>
  void VisitSetBits(std::int64_t firstWord, std::int64_t lastWord, Visitor&& visit) const
  {
    for (std::int64_t w = firstWord; w < lastWord; ++w)
    {
      std::uint64_t word = this->Words[w].load(std::memory_order_relaxed);
      std::int64_t id = this->WordRank[w];
      while (word != 0)
      {
        const int offset = __builtin_ctzll(word);
        word &= word - 1;
        std::int64_t linear = w * 64 + offset;
        LatticeIndex<Dim> point;
        for (int axis = 0; axis < Dim; ++axis)
        {
          point[axis] = linear % this->Dimensions[axis];
          linear /= this->Dimensions[axis];
        }
        visit(id++, point);
      }
    }
  }

private:
  LatticeIndex<Dim> Dimensions{};
  std::int64_t NumberOfBits = 0;
  std::int64_t NumberOfWords = 0;
  std::unique_ptr<std::atomic<std::uint64_t>[]> Words;
  std::vector<std::int64_t> WordRank;
};

} // namespace stm

#endif
