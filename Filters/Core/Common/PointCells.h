// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCorePointCells_h
#define stmCorePointCells_h

// The cells around each point of a simplicial mesh, and the neighbour of a cell across one of
// its facets, for the algorithms that walk a mesh's facets (boundary smoothing, interface
// extraction).

#include "Execution.h"
#include "UninitializedVector.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

namespace stm
{

/// Point -> incident cells, in compressed rows (each point's cells in ascending order).
/// CellId: how the rows store cell ids; std::int32_t halves the rows' memory, for meshes of
/// fewer than 2^31 cells (the builder checks; see FitsCellIds).
template <int Dim, class CellId = std::int64_t>
struct PointCells
{
  static constexpr int Corners = Dim + 1;
  std::vector<std::int64_t> Offsets; // numberOfPoints + 1
  UninitializedVector<CellId> Cells; // every element written by Build, first by its threads

  /// Whether CellId holds every cell id of a mesh of numberOfCells cells.
  static constexpr bool FitsCellIds(std::int64_t numberOfCells)
  {
    return numberOfCells <= static_cast<std::int64_t>(std::numeric_limits<CellId>::max());
  }

  /// connectivity: Dim + 1 point ids per cell, each in [0, numberOfPoints).
  template <class IdType>
  void Build(const IdType* connectivity, std::int64_t numberOfCells, std::int64_t numberOfPoints)
  {
    this->Offsets.assign(static_cast<std::size_t>(numberOfPoints) + 1, 0);
    for (std::int64_t i = 0; i < numberOfCells * Corners; ++i)
    {
      ++this->Offsets[static_cast<std::int64_t>(connectivity[i]) + 1];
    }
    for (std::int64_t p = 0; p < numberOfPoints; ++p)
    {
      this->Offsets[p + 1] += this->Offsets[p];
    }
    this->Cells.resize(static_cast<std::size_t>(numberOfCells * Corners));
    std::vector<std::int64_t> next(this->Offsets.begin(), this->Offsets.end() - 1);
    for (std::int64_t i = 0; i < numberOfCells * Corners; ++i)
    {
      this->Cells[next[static_cast<std::int64_t>(connectivity[i])]++] =
        static_cast<CellId>(i / Corners);
    }
  }

  /// Build with the cells in Chunks fixed ranges, run by the executor: each range counts the
  /// cells of its points, and then writes them after those of the earlier ranges, so the rows
  /// are Build's (ascending cells) whatever the number of threads. A point's cells per range
  /// fit 32 bits (Chunks x numberOfPoints of them while it builds).
  template <class IdType, class Executor>
  void Build(const IdType* connectivity, std::int64_t numberOfCells, std::int64_t numberOfPoints,
    Executor& executor)
  {
    constexpr std::int64_t Chunks = 4;
    // Below this the serial build is faster than the passes and the counts.
    constexpr std::int64_t SerialCells = 1 << 16;
    if (numberOfCells < SerialCells)
    {
      this->Build(connectivity, numberOfCells, numberOfPoints);
      return;
    }
    const std::int64_t points = numberOfPoints;
    const std::int64_t chunkCells = (numberOfCells + Chunks - 1) / Chunks;
    // counts[k * points + p]: the cells of range k at p, then where they start in p's row.
    std::vector<std::int32_t> counts(static_cast<std::size_t>(Chunks * points), 0);
    struct CountKernel
    {
      using Scratch = NoScratch;
      const IdType* Connectivity;
      std::int64_t NumberOfCells;
      std::int64_t ChunkCells;
      std::int64_t Points;
      std::int32_t* Counts;
      bool Fill;
      const std::int64_t* Offsets;
      CellId* Cells;
      void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
      {
        for (std::int64_t k = begin; k < end; ++k)
        {
          std::int32_t* own = this->Counts + k * this->Points;
          const std::int64_t first = k * this->ChunkCells;
          const std::int64_t last = std::min(this->NumberOfCells, first + this->ChunkCells);
          for (std::int64_t i = first * Corners; i < last * Corners; ++i)
          {
            const auto id = static_cast<std::int64_t>(this->Connectivity[i]);
            if (this->Fill)
            {
              this->Cells[this->Offsets[id] + own[id]++] = static_cast<CellId>(i / Corners);
            }
            else
            {
              ++own[id];
            }
          }
        }
      }
    };
    struct StartKernel
    {
      using Scratch = NoScratch;
      std::int64_t Points;
      std::int32_t* Counts;
      std::int64_t* Degrees;
      void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
      {
        for (std::int64_t p = begin; p < end; ++p)
        {
          std::int32_t start = 0;
          for (std::int64_t k = 0; k < Chunks; ++k)
          {
            const std::int32_t count = this->Counts[k * this->Points + p];
            this->Counts[k * this->Points + p] = start;
            start += count;
          }
          this->Degrees[p + 1] = start;
        }
      }
    };
    CountKernel count{ connectivity, numberOfCells, chunkCells, points, counts.data(), false,
      nullptr, nullptr };
    executor.For(0, Chunks, 1, count);
    this->Offsets.assign(static_cast<std::size_t>(points) + 1, 0);
    StartKernel starts{ points, counts.data(), this->Offsets.data() };
    executor.For(0, points, 1 << 14, starts);
    for (std::int64_t p = 0; p < points; ++p)
    {
      this->Offsets[p + 1] += this->Offsets[p];
    }
    this->Cells.resize(static_cast<std::size_t>(numberOfCells * Corners));
    CountKernel fill{ connectivity, numberOfCells, chunkCells, points, counts.data(), true,
      this->Offsets.data(), this->Cells.data() };
    executor.For(0, Chunks, 1, fill);
  }

  /// The other cell of the facet of `cell` (point ids `ids`) opposite its corner `corner`, or
  /// -1 on the outer boundary: the first other cell in the intersection of the facet's points'
  /// cell lists, by a merge of the sorted lists (a few comparisons per incident cell).
  template <class IdType>
  std::int64_t FacetNeighbour(const IdType* ids, std::int64_t cell, int corner) const
  {
    const CellId* cursor[Dim];
    const CellId* stop[Dim];
    for (int j = 0, f = 0; j <= Dim; ++j)
    {
      if (j != corner)
      {
        const auto id = static_cast<std::int64_t>(ids[j]);
        cursor[f] = this->Cells.data() + this->Offsets[id];
        stop[f++] = this->Cells.data() + this->Offsets[id + 1];
      }
    }
    for (; cursor[0] != stop[0]; ++cursor[0])
    {
      const std::int64_t candidate = *cursor[0];
      bool everywhere = candidate != cell;
      for (int f = 1; f < Dim && everywhere; ++f)
      {
        while (cursor[f] != stop[f] && *cursor[f] < candidate)
        {
          ++cursor[f];
        }
        everywhere = cursor[f] != stop[f] && *cursor[f] == candidate;
      }
      if (everywhere)
      {
        return candidate;
      }
    }
    return -1;
  }

  /// One cell's side of a facet around a point p (ForEachFacetAt): the facet's other points,
  /// ascending, the cell and its corner opposite the facet.
  struct FacetEntry
  {
    static constexpr int OtherPoints = Dim - 1;
    std::int64_t Others[OtherPoints > 0 ? OtherPoints : 1];
    std::int64_t Cell;
    int Corner;

    bool SameFacet(const FacetEntry& other) const
    {
      for (int k = 0; k < OtherPoints; ++k)
      {
        if (this->Others[k] != other.Others[k])
        {
          return false;
        }
      }
      return true;
    }
    bool operator<(const FacetEntry& other) const
    {
      for (int k = 0; k < OtherPoints; ++k)
      {
        if (this->Others[k] != other.Others[k])
        {
          return this->Others[k] < other.Others[k];
        }
      }
      return this->Cell < other.Cell;
    }
  };

  /// The facets that hold point p, grouped: visit(first, last) gets, per facet, the entries of
  /// the cells that hold it, ascending by cell (one on the outer boundary, two inside a
  /// conforming mesh). Only the facets that keep(cell, corner) accepts take part, and with
  /// smallestOnly only those whose smallest point is p. A facet of a cell around p that holds
  /// p is in the other cell's list too, so a pass over all points with smallestOnly visits
  /// every facet of the mesh once, and reads the corners of each point's cells once (a search
  /// per cell reads those of the cells around several of its points). entries: scratch.
  template <class IdType, class Keep, class Visit>
  void ForEachFacetAt(const IdType* connectivity, std::int64_t p, bool smallestOnly,
    std::vector<FacetEntry>& entries, Keep&& keep, Visit&& visit) const
  {
    entries.clear();
    for (std::int64_t k = this->Offsets[p]; k < this->Offsets[p + 1]; ++k)
    {
      const std::int64_t cell = this->Cells[k];
      const IdType* ids = connectivity + cell * Corners;
      for (int corner = 0; corner < Corners; ++corner)
      {
        if (static_cast<std::int64_t>(ids[corner]) == p || !keep(cell, corner))
        {
          continue;
        }
        FacetEntry entry;
        entry.Cell = cell;
        entry.Corner = corner;
        int count = 0;
        bool smallest = true;
        for (int j = 0; j < Corners; ++j)
        {
          const auto id = static_cast<std::int64_t>(ids[j]);
          if (j != corner && id != p)
          {
            smallest = smallest && id > p;
            entry.Others[count++] = id;
          }
        }
        if (smallestOnly && !smallest)
        {
          continue;
        }
        std::sort(entry.Others, entry.Others + FacetEntry::OtherPoints);
        entries.push_back(entry);
      }
    }
    auto visitGroups = [&visit](const FacetEntry* sorted, std::size_t count)
    {
      for (std::size_t first = 0; first < count;)
      {
        std::size_t last = first + 1;
        while (last < count && sorted[last].SameFacet(sorted[first]))
        {
          ++last;
        }
        visit(sorted + first, sorted + last);
        first = last;
      }
    };
    // Up to 3D the other points fit one 64-bit key (ids below 2^32), and the entries come in
    // ascending cells: a stable insertion sort of the keys gives operator<'s order, moving
    // 8-byte keys and 1-byte indices instead of 32-byte entries (AAL brain mask: the
    // smoother's facet pass 0.63-0.71 -> 0.49-0.55 s).
    constexpr std::size_t PackedLimit = 64;
    if constexpr (FacetEntry::OtherPoints <= 2)
    {
      if (entries.size() <= PackedLimit && this->Offsets.size() <= (std::size_t{ 1 } << 32))
      {
        const std::size_t count = entries.size();
        std::uint64_t keys[PackedLimit];
        std::uint8_t order[PackedLimit];
        for (std::size_t i = 0; i < count; ++i)
        {
          std::uint64_t key = 0;
          for (int k = 0; k < FacetEntry::OtherPoints; ++k)
          {
            key = (key << 32) | static_cast<std::uint64_t>(entries[i].Others[k]);
          }
          std::size_t j = i;
          for (; j > 0 && keys[j - 1] > key; --j)
          {
            keys[j] = keys[j - 1];
            order[j] = order[j - 1];
          }
          keys[j] = key;
          order[j] = static_cast<std::uint8_t>(i);
        }
        FacetEntry sorted[PackedLimit];
        for (std::size_t i = 0; i < count; ++i)
        {
          sorted[i] = entries[order[i]];
        }
        visitGroups(sorted, count);
        return;
      }
    }
    std::sort(entries.begin(), entries.end());
    visitGroups(entries.data(), entries.size());
  }
};

} // namespace stm

#endif
