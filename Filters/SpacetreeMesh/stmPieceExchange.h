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
 * ghost cell here. The lists are made once; every exchange then sends values only, in the
 * lists' order (AllGatherV, so the cost grows with the ranks; the pieces that share no point
 * still take part).
 */

#ifndef stmPieceExchange_h
#define stmPieceExchange_h

#include "stmPieceBorder.h"

#include "Smooth/BoundarySmooth.h"

#include "vtkCommunicator.h"
#include "vtkDataArray.h"
#include "vtkMultiProcessController.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <map>
#include <unordered_map>
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
    const int ranks = this->Controller->GetNumberOfProcesses();
    const int rank = this->Controller->GetLocalProcessId();
    // The points this piece moves that other pieces may have, by colour, then id.
    std::vector<std::uint8_t> sent(static_cast<std::size_t>(points), 0);
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
        sent[p] = !movers.Held[p];
      }
    }
    this->SentOffsets.assign(static_cast<std::size_t>(this->NumberOfColours) + 1, 0);
    for (std::int64_t p = 0; p < points; ++p)
    {
      if (sent[p])
      {
        ++this->SentOffsets[movers.Colours[p] + 1];
      }
    }
    for (int colour = 0; colour < this->NumberOfColours; ++colour)
    {
      this->SentOffsets[colour + 1] += this->SentOffsets[colour];
    }
    this->Sent.resize(static_cast<std::size_t>(this->SentOffsets.back()));
    std::vector<std::int64_t> next(this->SentOffsets.begin(), this->SentOffsets.end() - 1);
    for (std::int64_t p = 0; p < points; ++p)
    {
      if (sent[p])
      {
        this->Sent[static_cast<std::size_t>(next[movers.Colours[p]]++)] = p;
      }
    }
    // Every rank's colour offsets and keys.
    std::vector<long long> offsets(this->SentOffsets.begin(), this->SentOffsets.end());
    std::vector<long long> allOffsets(offsets.size() * static_cast<std::size_t>(ranks));
    this->Controller->AllGather(
      offsets.data(), allOffsets.data(), static_cast<vtkIdType>(offsets.size()));
    this->RankOffsets.assign(static_cast<std::size_t>(ranks), {});
    for (int r = 0; r < ranks; ++r)
    {
      this->RankOffsets[r].assign(
        allOffsets.begin() + r * static_cast<std::ptrdiff_t>(offsets.size()),
        allOffsets.begin() + (r + 1) * static_cast<std::ptrdiff_t>(offsets.size()));
    }
    std::vector<double> keys;
    keys.reserve(this->Sent.size() * 3);
    for (const std::int64_t p : this->Sent)
    {
      double key[3];
      keyOf(p, key);
      keys.insert(keys.end(), key, key + 3);
    }
    const std::vector<double> allKeys = stmPieceBorder::detail::AllGather(this->Controller, keys);
    // The held points by key, matched with the senders' lists.
    std::unordered_map<stmPieceBorder::Key, std::int64_t, stmPieceBorder::KeyHash> held;
    for (std::int64_t p = 0; p < points; ++p)
    {
      if (movers.Held[p])
      {
        stmPieceBorder::Key key;
        keyOf(p, key.data());
        held.emplace(key, p);
      }
    }
    this->Copies.assign(static_cast<std::size_t>(this->NumberOfColours), {});
    std::vector<std::uint8_t> matched(static_cast<std::size_t>(points), 0);
    std::size_t base = 0;
    for (int r = 0; r < ranks; ++r)
    {
      const std::vector<long long>& rankOffsets = this->RankOffsets[r];
      for (int colour = 0; colour < this->NumberOfColours && r != rank; ++colour)
      {
        for (long long i = rankOffsets[colour]; i < rankOffsets[colour + 1]; ++i)
        {
          const std::size_t at = base + 3 * static_cast<std::size_t>(i);
          const auto found =
            held.find(stmPieceBorder::Key{ allKeys[at], allKeys[at + 1], allKeys[at + 2] });
          if (found != held.end())
          {
            this->Copies[colour].push_back({ found->second, r, i - rankOffsets[colour] });
            matched[static_cast<std::size_t>(found->second)] = 1;
          }
        }
      }
      base += 3 * static_cast<std::size_t>(rankOffsets.back());
    }
    this->Unmatched = 0;
    for (std::int64_t p = 0; p < points; ++p)
    {
      this->Unmatched += movers.Held[p] && !matched[p];
    }
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
    const int ranks = this->Controller->GetNumberOfProcesses();
    std::vector<vtkIdType> counts(static_cast<std::size_t>(ranks)), offsets(counts.size(), 0);
    for (int r = 0; r < ranks; ++r)
    {
      counts[r] =
        static_cast<vtkIdType>((this->RankOffsets[r][last] - this->RankOffsets[r][first]) * width);
      offsets[r] = r == 0 ? 0 : offsets[r - 1] + counts[r - 1];
    }
    if (offsets.back() + counts.back() == 0)
    {
      return; // every rank knows the counts: all skip
    }
    std::vector<double> send;
    send.reserve(
      static_cast<std::size_t>((this->SentOffsets[last] - this->SentOffsets[first]) * width));
    for (std::int64_t i = this->SentOffsets[first]; i < this->SentOffsets[last]; ++i)
    {
      const std::int64_t p = this->Sent[static_cast<std::size_t>(i)];
      send.insert(send.end(), values + p * width, values + (p + 1) * width);
    }
    std::vector<double> received(static_cast<std::size_t>(offsets.back() + counts.back()));
    double nothing = 0.0;
    this->Controller->AllGatherV(send.empty() ? &nothing : send.data(), received.data(),
      static_cast<vtkIdType>(send.size()), counts.data(), offsets.data());
    for (int c = first; c < last; ++c)
    {
      for (const Copy& copy : this->Copies[c])
      {
        // Index within the sender's colour c, which starts after its colours first..c-1.
        const long long index =
          this->RankOffsets[copy.Rank][c] - this->RankOffsets[copy.Rank][first] + copy.Index;
        const double* from = received.data() + offsets[copy.Rank] + index * width;
        double* to = values + copy.Point * width;
        if (!std::equal(from, from + width, to))
        {
          std::copy(from, from + width, to);
          if (changed)
          {
            changed->push_back(copy.Point);
          }
        }
      }
    }
  }

  /// Sent points, and held points no piece sent (0 when the pieces' rings are complete).
  std::int64_t GetNumberOfSentPoints() const
  {
    return static_cast<std::int64_t>(this->Sent.size());
  }
  std::int64_t GetNumberOfUnmatchedPoints() const { return this->Unmatched; }

private:
  struct Copy
  {
    std::int64_t Point; // the held point here
    int Rank;           // the piece that moves it
    long long Index;    // its position in that piece's list of its colour
  };
  vtkMultiProcessController* Controller;
  int NumberOfColours;
  std::vector<std::int64_t> Sent;
  std::vector<std::int64_t> SentOffsets;           // per colour, into Sent
  std::vector<std::vector<long long>> RankOffsets; // every rank's SentOffsets
  std::vector<std::vector<Copy>> Copies;           // per colour
  std::int64_t Unmatched = 0;
};
} // namespace stmPieceExchange

#endif
