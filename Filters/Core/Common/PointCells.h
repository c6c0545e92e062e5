// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCorePointCells_h
#define stmCorePointCells_h

// The cells around each point of a simplicial mesh, and the neighbour of a cell across one of
// its facets, for the algorithms that walk a mesh's facets (boundary smoothing, interface
// extraction).

#include <cstdint>
#include <vector>

namespace stm
{

/// Point -> incident cells, in compressed rows (each point's cells in ascending order).
template <int Dim>
struct PointCells
{
  static constexpr int Corners = Dim + 1;
  std::vector<std::int64_t> Offsets; // numberOfPoints + 1
  std::vector<std::int64_t> Cells;

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
    this->Cells.assign(static_cast<std::size_t>(numberOfCells * Corners), 0);
    std::vector<std::int64_t> next(this->Offsets.begin(), this->Offsets.end() - 1);
    for (std::int64_t i = 0; i < numberOfCells * Corners; ++i)
    {
      this->Cells[next[static_cast<std::int64_t>(connectivity[i])]++] = i / Corners;
    }
  }

  /// The other cell of the facet of `cell` (point ids `ids`) opposite its corner `corner`, or
  /// -1 on the outer boundary: the first other cell in the intersection of the facet's points'
  /// cell lists, by a merge of the sorted lists (a few comparisons per incident cell).
  template <class IdType>
  std::int64_t FacetNeighbour(const IdType* ids, std::int64_t cell, int corner) const
  {
    const std::int64_t* cursor[Dim];
    const std::int64_t* stop[Dim];
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

  /// FacetNeighbour for every corner at once, into neighbours[corner]: the facets that hold
  /// corner 0 from corner 0's cells, the one that does not from corner 1's, each list scanned
  /// once and each candidate's corners compared with the cell's, where a merge per facet would
  /// read Dim lists per facet.
  template <class IdType>
  void AllFacetNeighbours(
    const IdType* connectivity, std::int64_t cell, std::int64_t (&neighbours)[Corners]) const
  {
    const IdType* ids = connectivity + cell * Corners;
    for (std::int64_t& neighbour : neighbours)
    {
      neighbour = -1;
    }
    for (int list = 0; list < 2; ++list)
    {
      const auto id = static_cast<std::int64_t>(ids[list]);
      int missing = list == 0 ? Dim : 1; // facets still to find from this list
      for (std::int64_t k = this->Offsets[id]; k < this->Offsets[id + 1] && missing > 0; ++k)
      {
        const std::int64_t candidate = this->Cells[k];
        if (candidate == cell)
        {
          continue;
        }
        // Which of the cell's corners the candidate holds, as a bit set.
        const IdType* other = connectivity + candidate * Corners;
        unsigned shared = 0;
        for (int v = 0; v < Corners; ++v)
        {
          for (int w = 0; w < Corners; ++w)
          {
            shared |= ids[v] == other[w] ? 1u << v : 0u;
          }
        }
        // A facet: every corner but one; from list 0 the one is not corner 0, from list 1 it
        // is corner 0. Ascending lists, so each facet gets the smallest such cell.
        const unsigned all = (1u << Corners) - 1u;
        for (int corner = list == 0 ? 1 : 0; corner < (list == 0 ? Corners : 1); ++corner)
        {
          const unsigned facet = all & ~(1u << corner);
          if (neighbours[corner] < 0 && (shared & facet) == facet)
          {
            neighbours[corner] = candidate;
            --missing;
          }
        }
      }
    }
  }
};

} // namespace stm

#endif
