// SPDX-License-Identifier: BSD-3-Clause
// Pieces of a distributed mesh run side by side on threads in the core tests: a hub where their
// collective calls meet, and a stm::SnapExchange held in memory, the test double of the MPI one
// (stmSnapExchange), naming points by a few doubles each (an id in the whole mesh, or a place),
// and the slabs with rings of ghost cells that the pieces cut out of a whole mesh.

#ifndef stmtestMemoryPieces_h
#define stmtestMemoryPieces_h

#include "Cut/SnapExchange.h"

#include <algorithm>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <utility>
#include <vector>

namespace stmtest
{

/// Where the pieces' exchanges meet: each call waits for every piece.
class PieceHub
{
public:
  explicit PieceHub(int pieces)
    : Posted(static_cast<std::size_t>(pieces))
  {
  }
  /// Every piece's `values`, in the pieces' order.
  std::vector<std::vector<double>> AllGather(int piece, std::vector<double> values)
  {
    this->Posted[piece] = std::move(values);
    this->Wait();
    std::vector<std::vector<double>> all = this->Posted;
    this->Wait(); // no piece posts again before every piece has read
    return all;
  }
  double Maximum(int piece, double value)
  {
    double all = value;
    for (const std::vector<double>& posted : this->AllGather(piece, { value }))
    {
      all = std::max(all, posted[0]);
    }
    return all;
  }

private:
  void Wait()
  {
    std::unique_lock<std::mutex> lock(this->Mutex);
    const std::int64_t generation = this->Generation;
    if (++this->Arrived == static_cast<int>(this->Posted.size()))
    {
      this->Arrived = 0;
      ++this->Generation;
      this->Arrival.notify_all();
      return;
    }
    this->Arrival.wait(lock, [&] { return this->Generation != generation; });
  }
  std::vector<std::vector<double>> Posted;
  std::mutex Mutex;
  std::condition_variable Arrival;
  int Arrived = 0;
  std::int64_t Generation = 0;
};

/// A piece's exchange: point p is named by names[p * Width, (p + 1) * Width).
class MemoryExchange : public stm::SnapExchange
{
public:
  MemoryExchange(PieceHub& hub, int piece, std::vector<double> names, int width,
    std::vector<std::uint8_t> ownPoints)
    : Hub(hub)
    , Piece(piece)
    , Names(std::move(names))
    , Width(width)
    , OwnPoints(std::move(ownPoints))
  {
  }
  double Maximum(double value) override { return this->Hub.Maximum(this->Piece, value); }
  void List(const std::int64_t* points, std::int64_t count) override
  {
    using Name = std::vector<double>;
    auto nameOf = [this](std::int64_t p)
    {
      return Name(
        this->Names.begin() + p * this->Width, this->Names.begin() + (p + 1) * this->Width);
    };
    auto gather = [this](const std::vector<Name>& names)
    {
      std::vector<double> flat;
      for (const Name& name : names)
      {
        flat.insert(flat.end(), name.begin(), name.end());
      }
      std::vector<std::vector<Name>> all;
      for (const std::vector<double>& posted : this->Hub.AllGather(this->Piece, flat))
      {
        all.emplace_back();
        for (std::size_t at = 0; at < posted.size(); at += this->Width)
        {
          all.back().emplace_back(posted.begin() + at, posted.begin() + at + this->Width);
        }
      }
      return all;
    };
    std::vector<Name> held;
    std::vector<std::int64_t> heldIndices;
    for (std::int64_t i = 0; i < count; ++i)
    {
      if (!this->OwnPoints[points[i]])
      {
        held.push_back(nameOf(points[i]));
        heldIndices.push_back(i);
      }
    }
    std::set<Name> wanted;
    for (const std::vector<Name>& names : gather(held))
    {
      wanted.insert(names.begin(), names.end());
    }
    this->Sent.clear();
    std::vector<Name> sentNames;
    for (std::int64_t i = 0; i < count; ++i)
    {
      if (this->OwnPoints[points[i]] && wanted.count(nameOf(points[i])))
      {
        this->Sent.push_back(i);
        sentNames.push_back(nameOf(points[i]));
      }
    }
    std::map<Name, std::pair<std::size_t, std::size_t>> senders;
    const std::vector<std::vector<Name>> allSent = gather(sentNames);
    this->Idle = true;
    for (std::size_t piece = 0; piece < allSent.size(); ++piece)
    {
      this->Idle = this->Idle && allSent[piece].empty();
      for (std::size_t j = 0; j < allSent[piece].size(); ++j)
      {
        senders.emplace(allSent[piece][j], std::make_pair(piece, j));
      }
    }
    this->Received.clear();
    this->From.clear();
    for (std::size_t j = 0; j < held.size(); ++j)
    {
      const auto found = senders.find(held[j]);
      if (found == senders.end())
      {
        ++this->Unmatched;
        continue;
      }
      this->Received.push_back(heldIndices[j]);
      this->From.push_back(found->second);
    }
  }
  bool IsIdle() const override { return this->Idle; }
  const std::vector<std::int64_t>& GetSent() const override { return this->Sent; }
  const std::vector<std::int64_t>& GetReceived() const override { return this->Received; }
  void Share(const std::vector<double>& sent, int width, std::vector<double>& received) override
  {
    const std::vector<std::vector<double>> all = this->Hub.AllGather(this->Piece, sent);
    received.resize(this->Received.size() * static_cast<std::size_t>(width));
    for (std::size_t j = 0; j < this->Received.size(); ++j)
    {
      const double* from = all[this->From[j].first].data() + this->From[j].second * width;
      std::copy(from, from + width, received.data() + j * width);
    }
  }
  /// Held points that no piece sent, over every List.
  std::int64_t Unmatched = 0;

private:
  PieceHub& Hub;
  int Piece;
  std::vector<double> Names;
  int Width;
  std::vector<std::uint8_t> OwnPoints;
  std::vector<std::int64_t> Sent, Received;
  std::vector<std::pair<std::size_t, std::size_t>> From;
  bool Idle = false;
};

/// A piece's exchanges for the multi-material cut's steps: a MemoryExchange per step, its points
/// named by their places.
template <int D>
class MemoryStepExchanges : public stm::StepSnapExchanges
{
public:
  MemoryStepExchanges(PieceHub& hub, int piece)
    : Hub(hub)
    , Piece(piece)
  {
  }
  double Maximum(double value) override { return this->Hub.Maximum(this->Piece, value); }
  void AnyPiece(std::vector<std::uint8_t>& flags) override
  {
    std::vector<double> mine(flags.begin(), flags.end());
    for (const std::vector<double>& posted : this->Hub.AllGather(this->Piece, mine))
    {
      for (std::size_t i = 0; i < flags.size(); ++i)
      {
        flags[i] = std::max(flags[i], static_cast<std::uint8_t>(posted[i]));
      }
    }
    this->Flags = flags;
  }
  /// The flags AnyPiece gave (the cut's steps whose snaps exchange, and the last material's).
  std::vector<std::uint8_t> Flags;
  stm::SnapExchange& ForStep(
    const double* places, const std::uint8_t* ownPoints, std::int64_t count) override
  {
    this->Unmatched += this->Step ? this->Step->Unmatched : 0;
    this->Step = std::make_unique<MemoryExchange>(this->Hub, this->Piece,
      std::vector<double>(places, places + count * D), D,
      std::vector<std::uint8_t>(ownPoints, ownPoints + count));
    ++this->Steps;
    return *this->Step;
  }
  std::int64_t GetUnmatched() const
  {
    return this->Unmatched + (this->Step ? this->Step->Unmatched : 0);
  }
  /// Steps whose snaps exchanged.
  std::int64_t Steps = 0;

private:
  PieceHub& Hub;
  int Piece;
  std::unique_ptr<MemoryExchange> Step;
  std::int64_t Unmatched = 0;
};

/// The cells of piece `piece` of `pieces` slabs along x of a whole mesh (D + 1 point ids per
/// cell): `own` is 1 for the cells whose centres lie in the slab, `kept` for those and `rings`
/// rings of ghost cells around them (a cell that shares a point with the previous ring).
template <int D>
void CutOutSlab(const std::vector<double>& points, const std::vector<std::int64_t>& cells,
  int piece, int pieces, int rings, std::vector<std::uint8_t>& own, std::vector<std::uint8_t>& kept)
{
  const std::size_t cellCount = cells.size() / (D + 1);
  const std::size_t pointCount = points.size() / D;
  double low = points[0], high = points[0];
  for (std::size_t p = 0; p < pointCount; ++p)
  {
    low = std::min(low, points[p * D]);
    high = std::max(high, points[p * D]);
  }
  own.assign(cellCount, 0);
  for (std::size_t c = 0; c < cellCount; ++c)
  {
    double centre = 0.0;
    for (int k = 0; k <= D; ++k)
    {
      centre += points[cells[c * (D + 1) + k] * D] / (D + 1);
    }
    const int slab = std::min(pieces - 1, static_cast<int>((centre - low) / (high - low) * pieces));
    own[c] = slab == piece ? 1 : 0;
  }
  kept = own;
  for (int ring = 0; ring < rings; ++ring)
  {
    std::vector<std::uint8_t> reached(pointCount, 0);
    for (std::size_t c = 0; c < cellCount; ++c)
    {
      for (int k = 0; k <= D && kept[c]; ++k)
      {
        reached[cells[c * (D + 1) + k]] = 1;
      }
    }
    for (std::size_t c = 0; c < cellCount; ++c)
    {
      for (int k = 0; k <= D && !kept[c]; ++k)
      {
        kept[c] = reached[cells[c * (D + 1) + k]];
      }
    }
  }
}

} // namespace stmtest

#endif
