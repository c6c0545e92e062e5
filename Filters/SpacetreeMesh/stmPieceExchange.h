// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   the exchanges between the pieces of an MPI run while they smooth
 *          (stm::SmoothingExchange over a vtkMultiProcessController), private to the module
 *
 * Each point is moved by one piece: the piece that owns the root cell of the smallest colour
 * among the point's cells (stm::RootColouring), which is the root cell of the block the whole
 * mesh's smoothing moves the point in. That piece has every cell around the point (it owns one,
 * and the cut keeps the ring of ghost cells around its own). The other pieces that have the
 * point hold it, and the exchange gives them the mover's values: the roles once the roles and
 * each interior layer are known, the lambda targets of every Taubin step, and the positions
 * after every colour of every step. A point is named by its position before the smoothing,
 * which the pieces compute bit for bit alike.
 *
 * A piece sends the points it moves that other pieces may have: the points of its cells that
 * have a point of a ghost cell. A point another piece has lies in a cell that piece has, an own
 * cell of either or a ghost cell of that piece's ring, and every such cell has a point of a
 * ghost cell here. The lists are made once; every exchange then sends values only, to the
 * pieces that hold them (stmNeighbourExchange: neither the messages nor their number grow
 * with the ranks).
 */

#ifndef stmPieceExchange_h
#define stmPieceExchange_h

#include "stmNeighbourExchange.h"
#include "stmPieceBorder.h"

#include "Smooth/BoundarySmooth.h"

#include "vtkCommunicator.h"
#include "vtkDataArray.h"
#include "vtkMultiProcessController.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <map>
#include <vector>

namespace stmPieceExchange
{
/// Whether `can` holds on every rank of `controller` (collective).
inline bool AllAgree(vtkMultiProcessController* controller, bool can)
{
  int local = can ? 1 : 0, all = 0;
  controller->AllReduce(&local, &all, 1, vtkCommunicator::MIN_OP);
  return all != 0;
}

/// The largest `value` of every rank of `controller` (collective).
inline double AllMaximum(vtkMultiProcessController* controller, double value)
{
  double all = value;
  controller->AllReduce(&value, &all, 1, vtkCommunicator::MAX_OP);
  return all;
}

/// Per point of a piece: the smallest root colour of its cells, and 1 where another piece moves
/// it (a cell of that colour is a ghost; the cells of one colour around a point lie in one root
/// cell, so they are all ghosts or all own).
struct Movers
{
  std::vector<std::uint8_t> Colours;
  std::vector<std::uint8_t> Held;
};

template <int Dim, class IdType>
Movers FindMovers(const IdType* connectivity, std::int64_t cells, std::int64_t points,
  const unsigned char* ghostCells, const std::uint8_t* cellColours)
{
  constexpr int Corners = Dim + 1;
  Movers movers;
  movers.Colours.assign(static_cast<std::size_t>(points), std::numeric_limits<std::uint8_t>::max());
  movers.Held.assign(static_cast<std::size_t>(points), 1);
  for (std::int64_t c = 0; c < cells; ++c)
  {
    for (int v = 0; v < Corners; ++v)
    {
      std::uint8_t& colour =
        movers.Colours[static_cast<std::size_t>(connectivity[c * Corners + v])];
      colour = std::min(colour, cellColours[c]);
    }
  }
  for (std::int64_t c = 0; c < cells; ++c)
  {
    for (int v = 0; v < Corners && !ghostCells[c]; ++v)
    {
      const auto p = static_cast<std::size_t>(connectivity[c * Corners + v]);
      if (movers.Colours[p] == cellColours[c])
      {
        movers.Held[p] = 0;
      }
    }
  }
  return movers;
}

/// The whole mesh's volume per material from every piece's exact parts (rows of material and
/// part, stmPieces::VolumePartsName), as the whole mesh's own cells would sum them (collective).
inline std::map<std::int64_t, double> SumVolumeParts(
  vtkMultiProcessController* controller, vtkDataArray* parts)
{
  std::vector<double> rows(static_cast<std::size_t>(parts->GetNumberOfTuples()) * 2);
  for (vtkIdType t = 0; t < parts->GetNumberOfTuples(); ++t)
  {
    parts->GetTuple(t, rows.data() + 2 * t);
  }
  const std::vector<double> all = stmPieceBorder::detail::AllGather(controller, rows);
  std::map<std::int64_t, stm::ExactSum> sums;
  for (std::size_t at = 0; at + 2 <= all.size(); at += 2)
  {
    sums[static_cast<std::int64_t>(all[at])].Add(all[at + 1]);
  }
  std::map<std::int64_t, double> volumes;
  for (const auto& entry : sums)
  {
    if (entry.second.Value() > 0.0) // as stmMultiMaterialCut lists a material
    {
      volumes.emplace(entry.first, entry.second.Value());
    }
  }
  return volumes;
}

/// stm::SmoothingExchange between the pieces on the ranks of a controller (the file's comment).
class Exchange : public stm::SmoothingExchange
{
public:
  Exchange(vtkMultiProcessController* controller, int numberOfColours)
    : Controller(controller)
    , NumberOfColours(numberOfColours)
  {
  }

  /// Makes the lists (collective). ghostPoints: per point, 1 for a point of a ghost cell;
  /// keyOf(p, double[3]) the point's position before the smoothing.
  template <int Dim, class IdType, class KeyOf>
  void Build(const IdType* connectivity, std::int64_t cells, std::int64_t points,
    const std::uint8_t* ghostPoints, const Movers& movers, KeyOf&& keyOf)
  {
    constexpr int Corners = Dim + 1;
    // The points this piece moves that other pieces may have.
    std::vector<std::uint8_t> offered(static_cast<std::size_t>(points), 0);
    for (std::int64_t c = 0; c < cells; ++c)
    {
      bool touches = false;
      for (int v = 0; v < Corners && !touches; ++v)
      {
        touches = ghostPoints[static_cast<std::size_t>(connectivity[c * Corners + v])] != 0;
      }
      for (int v = 0; v < Corners && touches; ++v)
      {
        const auto p = static_cast<std::size_t>(connectivity[c * Corners + v]);
        offered[p] = !movers.Held[p];
      }
    }
    std::vector<stmPieceBorder::Key> wantedKeys, offeredKeys;
    std::vector<std::uint8_t> colours;
    this->Wanted.clear();
    this->Offered.clear();
    for (std::int64_t p = 0; p < points; ++p)
    {
      if (movers.Held[p] || offered[p])
      {
        stmPieceBorder::Key key;
        keyOf(p, key.data());
        if (movers.Held[p])
        {
          this->Wanted.push_back(p);
          wantedKeys.push_back(key);
        }
        else
        {
          this->Offered.push_back(p);
          offeredKeys.push_back(key);
          colours.push_back(movers.Colours[p]);
        }
      }
    }
    this->Lists.Build(wantedKeys, offeredKeys, colours, this->NumberOfColours);
    const std::vector<int>& providers = this->Lists.GetProviders();
    this->Unmatched = std::count(providers.begin(), providers.end(), -1);
  }

  bool AllReady(bool ready) override { return AllAgree(this->Controller, ready); }

  double Maximum(double value) override { return AllMaximum(this->Controller, value); }

  std::vector<double> Gather(const std::vector<double>& values) override
  {
    return stmPieceBorder::detail::AllGather(this->Controller, values);
  }

  void Share(double* values, int width, int colour, std::vector<std::int64_t>* changed) override
  {
    const int first = colour >= 0 ? colour : 0;
    const int last = colour >= 0 ? colour + 1 : this->NumberOfColours;
    this->Lists.Share(
      width, first, last,
      [&](std::int64_t offered, double* out)
      {
        const std::int64_t p = this->Offered[static_cast<std::size_t>(offered)];
        std::copy(values + p * width, values + (p + 1) * width, out);
      },
      [&](std::int64_t wanted, const double* in)
      {
        const std::int64_t p = this->Wanted[static_cast<std::size_t>(wanted)];
        double* to = values + p * width;
        if (!std::equal(in, in + width, to))
        {
          std::copy(in, in + width, to);
          if (changed)
          {
            changed->push_back(p);
          }
        }
      });
  }

  /// Points this piece sends, the pieces it exchanges with, and held points no piece sends (0
  /// when the pieces' rings are complete).
  std::int64_t GetNumberOfSentPoints() const
  {
    const std::vector<std::uint8_t>& taken = this->Lists.GetTaken();
    return std::count(taken.begin(), taken.end(), 1);
  }
  int GetNumberOfPeers() const { return this->Lists.GetNumberOfPeers(); }
  std::int64_t GetNumberOfUnmatchedPoints() const { return this->Unmatched; }

private:
  vtkMultiProcessController* Controller;
  int NumberOfColours;
  stmNeighbourExchange::Lists Lists{ this->Controller };
  std::vector<std::int64_t> Wanted;  // the held points
  std::vector<std::int64_t> Offered; // the moved points other pieces may have
  std::int64_t Unmatched = 0;
};
} // namespace stmPieceExchange

#endif
