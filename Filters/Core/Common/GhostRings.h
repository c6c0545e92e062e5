// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreGhostRings_h
#define stmCoreGhostRings_h

// The ghost cells of a piece's mesh by their distance from the piece's own cells, in rings (the
// ghost levels of VTK's pipeline): ring 0 is the own cells, ring k the ghost cells that share a
// point with a cell of ring k - 1 and are in no earlier ring. A piece meshes two root cells of
// ghosts because its snapping and cuts look that far; the stages after the cut need only the
// rings next to the own cells, and every further ghost cell costs them memory and time.

#include "Execution.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

namespace stm
{

/// Per cell, its ring (0 for an own cell), or NotInAnyRing for a ghost cell beyond `rings` rings
/// (>= 0). connectivity: `corners` point ids per cell, each in [0, numberOfPoints); ghost: per
/// cell, non-zero for a ghost cell. The rings are the same whatever the number of threads.
constexpr std::uint8_t NotInAnyRing = std::numeric_limits<std::uint8_t>::max();

template <class IdType, class Executor>
std::vector<std::uint8_t> GhostRings(const IdType* connectivity, int corners,
  std::int64_t numberOfCells, std::int64_t numberOfPoints, const std::uint8_t* ghost, int rings,
  Executor& executor)
{
  const int lastRing = std::min(rings, static_cast<int>(NotInAnyRing) - 1);
  std::vector<std::uint8_t> cellRings(static_cast<std::size_t>(numberOfCells), NotInAnyRing);
  // A point's ring: the lowest ring of its cells found so far.
  std::vector<std::uint8_t> pointRings(static_cast<std::size_t>(numberOfPoints), NotInAnyRing);
  auto markPoints = [&](std::uint8_t ring)
  {
    for (std::int64_t c = 0; c < numberOfCells; ++c)
    {
      if (cellRings[c] != ring)
      {
        continue;
      }
      for (int v = 0; v < corners; ++v)
      {
        std::uint8_t& pointRing =
          pointRings[static_cast<std::size_t>(connectivity[c * corners + v])];
        pointRing = std::min(pointRing, ring);
      }
    }
  };
  for (std::int64_t c = 0; c < numberOfCells; ++c)
  {
    cellRings[c] = ghost[c] == 0 ? 0 : NotInAnyRing;
  }
  markPoints(0);
  // Each ring is decided in parallel from the points of the last (each cell writes only its own
  // entry), and its points are marked after, serially: a pass over bytes.
  struct RingKernel
  {
    using Scratch = NoScratch;
    const IdType* Connectivity;
    int Corners;
    const std::uint8_t* PointRings;
    std::uint8_t* CellRings;
    std::uint8_t Ring;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t c = begin; c < end; ++c)
      {
        if (this->CellRings[c] != NotInAnyRing)
        {
          continue;
        }
        for (int v = 0; v < this->Corners; ++v)
        {
          if (this->PointRings[this->Connectivity[c * this->Corners + v]] + 1 == this->Ring)
          {
            this->CellRings[c] = this->Ring;
            break;
          }
        }
      }
    }
  };
  for (int ring = 1; ring <= lastRing && !executor.ShouldAbort(); ++ring)
  {
    RingKernel kernel{ connectivity, corners, pointRings.data(), cellRings.data(),
      static_cast<std::uint8_t>(ring) };
    executor.For(0, numberOfCells, 1 << 16, kernel);
    if (ring < lastRing)
    {
      markPoints(static_cast<std::uint8_t>(ring));
    }
  }
  return cellRings;
}

} // namespace stm

#endif
