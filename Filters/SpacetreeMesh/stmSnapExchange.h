// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   the exchanges between the pieces of an MPI run while they snap (stm::SnapExchange
 *          over a vtkMultiProcessController), private to the module
 *
 * A piece decides the points of its own cells as the whole mesh does, given the whole mesh's
 * states around them at the start of every round (stm::SnapExchange). A point that lies on
 * none of the piece's own cells is held: it lies on an own cell of another piece (the ghost
 * cell it lies on is some piece's own), which sends its state. Several pieces may offer one
 * point (it lies on own cells of each), with the same state; the holder takes it from one of
 * them. A point is named by its position before the snap, which the pieces compute bit for bit
 * alike. The states travel between neighbouring pieces only (stmNeighbourExchange).
 */

#ifndef stmSnapExchange_h
#define stmSnapExchange_h

#include "stmNeighbourExchange.h"
#include "stmPieceBorder.h"
#include "stmPieceExchange.h"

#include "Cut/SnapExchange.h"

#include "vtkCommunicator.h"
#include "vtkMultiProcessController.h"
#include "vtkPoints.h"

#include <algorithm>
#include <cstdint>
#include <memory>
#include <vector>

class stmSnapExchange : public stm::SnapExchange
{
public:
  /// keys: the points' positions before the snap; ownPoints: per point, 1 on an own cell.
  stmSnapExchange(
    vtkMultiProcessController* controller, vtkPoints* keys, std::vector<std::uint8_t> ownPoints)
    : Controller(controller)
    , Keys(keys)
    , OwnPoints(std::move(ownPoints))
  {
  }

  /// keys: three coordinates per point, its position before the snap.
  stmSnapExchange(vtkMultiProcessController* controller, std::vector<double> keys,
    std::vector<std::uint8_t> ownPoints)
    : Controller(controller)
    , KeyCoordinates(std::move(keys))
    , OwnPoints(std::move(ownPoints))
  {
  }

  /// Per point of a piece with `cells` cells (Dim + 1 ids each): 1 on a cell that is no ghost.
  template <int Dim, class IdType>
  static std::vector<std::uint8_t> FindOwnPoints(const IdType* connectivity, std::int64_t cells,
    std::int64_t points, const unsigned char* ghostCells)
  {
    std::vector<std::uint8_t> own(static_cast<std::size_t>(points), 0);
    for (std::int64_t c = 0; c < cells; ++c)
    {
      for (int v = 0; v <= Dim && !ghostCells[c]; ++v)
      {
        own[static_cast<std::size_t>(connectivity[c * (Dim + 1) + v])] = 1;
      }
    }
    return own;
  }

  double Maximum(double value) override
  {
    return stmPieceExchange::AllMaximum(this->Controller, value);
  }

  void List(const std::int64_t* points, std::int64_t count) override
  {
    using stmPieceBorder::Key;
    std::vector<Key> wantedKeys, offeredKeys;
    std::vector<std::int64_t> wanted, offered; // indices into `points`
    for (std::int64_t i = 0; i < count; ++i)
    {
      const std::int64_t p = points[i];
      Key key;
      if (this->Keys)
      {
        this->Keys->GetPoint(p, key.data());
      }
      else
      {
        std::copy(
          this->KeyCoordinates.data() + 3 * p, this->KeyCoordinates.data() + 3 * p + 3, key.data());
      }
      if (this->OwnPoints[static_cast<std::size_t>(p)])
      {
        offered.push_back(i);
        offeredKeys.push_back(key);
      }
      else
      {
        wanted.push_back(i);
        wantedKeys.push_back(key);
      }
    }
    this->Lists.Build(wantedKeys, offeredKeys, {}, 1);
    // Sent and Received ascend, as the lists' indices do.
    const std::vector<std::uint8_t>& taken = this->Lists.GetTaken();
    this->Sent.clear();
    this->SentAt.assign(offered.size(), -1);
    for (std::size_t o = 0; o < offered.size(); ++o)
    {
      if (taken[o])
      {
        this->SentAt[o] = static_cast<std::int64_t>(this->Sent.size());
        this->Sent.push_back(offered[o]);
      }
    }
    const std::vector<int>& providers = this->Lists.GetProviders();
    this->Received.clear();
    this->ReceivedAt.assign(wanted.size(), -1);
    for (std::size_t w = 0; w < wanted.size(); ++w)
    {
      if (providers[w] >= 0)
      {
        this->ReceivedAt[w] = static_cast<std::int64_t>(this->Received.size());
        this->Received.push_back(wanted[w]);
      }
    }
    this->Unmatched = std::count(providers.begin(), providers.end(), -1);
    this->Idle = stmPieceExchange::AllAgree(this->Controller, this->Sent.empty());
  }

  bool IsIdle() const override { return this->Idle; }

  const std::vector<std::int64_t>& GetSent() const override { return this->Sent; }
  const std::vector<std::int64_t>& GetReceived() const override { return this->Received; }

  void Share(const std::vector<double>& sent, int width, std::vector<double>& received) override
  {
    received.resize(this->Received.size() * static_cast<std::size_t>(width));
    this->Lists.Share(
      width, 0, 1,
      [&](std::int64_t offered, double* out)
      {
        const double* from = sent.data() + this->SentAt[static_cast<std::size_t>(offered)] * width;
        std::copy(from, from + width, out);
      },
      [&](std::int64_t wanted, const double* in)
      {
        std::copy(in, in + width,
          received.data() + this->ReceivedAt[static_cast<std::size_t>(wanted)] * width);
      });
  }

  /// Held points that no piece sends: 0 when the pieces' meshes agree where they meet.
  std::int64_t GetNumberOfUnmatchedPoints() const { return this->Unmatched; }

private:
  vtkMultiProcessController* Controller;
  vtkPoints* Keys = nullptr;
  std::vector<double> KeyCoordinates; // without Keys
  std::vector<std::uint8_t> OwnPoints;
  stmNeighbourExchange::Lists Lists{ this->Controller };
  std::vector<std::int64_t> Sent, Received; // indices into the listed points
  std::vector<std::int64_t> SentAt;         // per offered (own) listed point, into Sent, or -1
  std::vector<std::int64_t> ReceivedAt;     // per wanted (held) listed point, into Received
  bool Idle = true;
  std::int64_t Unmatched = 0;
};

/// The snap exchanges of stmMultiMaterialCut's steps (stm::StepSnapExchanges): a
/// stmSnapExchange per step, its points named by their places before the step's snap.
class stmStepSnapExchanges : public stm::StepSnapExchanges
{
public:
  stmStepSnapExchanges(vtkMultiProcessController* controller, int dimension)
    : Controller(controller)
    , Dimension(dimension)
  {
  }

  double Maximum(double value) override
  {
    return stmPieceExchange::AllMaximum(this->Controller, value);
  }

  void AnyPiece(std::vector<std::uint8_t>& flags) override
  {
    const std::vector<std::uint8_t> mine = flags;
    this->Controller->AllReduce(
      mine.data(), flags.data(), static_cast<vtkIdType>(flags.size()), vtkCommunicator::MAX_OP);
  }

  stm::SnapExchange& ForStep(
    const double* places, const std::uint8_t* ownPoints, std::int64_t count) override
  {
    std::vector<double> keys(static_cast<std::size_t>(3 * count), 0.0);
    for (std::int64_t p = 0; p < count; ++p)
    {
      std::copy(
        places + p * this->Dimension, places + (p + 1) * this->Dimension, keys.data() + 3 * p);
    }
    this->Step = std::make_unique<stmSnapExchange>(
      this->Controller, std::move(keys), std::vector<std::uint8_t>(ownPoints, ownPoints + count));
    return *this->Step;
  }

private:
  vtkMultiProcessController* Controller;
  int Dimension;
  std::unique_ptr<stmSnapExchange> Step;
};

#endif
