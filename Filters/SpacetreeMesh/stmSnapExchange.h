// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   the exchanges between the pieces of an MPI run while they snap (stm::SnapExchange
 *          over a vtkMultiProcessController), private to the module
 *
 * A piece decides the points of its own cells as the whole mesh does, given the whole mesh's
 * states around them at the start of every round (stm::SnapExchange). A point that lies on
 * none of the piece's own cells is held: it lies on an own cell of another piece (the ghost
 * cell it lies on is some piece's own), which sends its state. Each piece gathers the names of
 * every piece's held points and sends the states of those that lie on its own cells; several
 * pieces may send one point (it lies on own cells of each), and they send the same state. A
 * point is named by its position before the snap, which the pieces compute bit for bit alike.
 * Every exchange is an AllGatherV of the sent states, so the cost grows with the ranks.
 */

#ifndef stmSnapExchange_h
#define stmSnapExchange_h

#include "stmPieceBorder.h"
#include "stmPieceExchange.h"

#include "Cut/SnapExchange.h"

#include "vtkCommunicator.h"
#include "vtkMultiProcessController.h"
#include "vtkPoints.h"

#include <algorithm>
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <unordered_set>
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
    auto keyOf = [this](std::int64_t p)
    {
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
      return key;
    };
    // Every piece's held points, by name.
    std::vector<double> heldKeys;
    std::vector<std::int64_t> held;
    for (std::int64_t i = 0; i < count; ++i)
    {
      if (!this->OwnPoints[static_cast<std::size_t>(points[i])])
      {
        const Key key = keyOf(points[i]);
        heldKeys.insert(heldKeys.end(), key.begin(), key.end());
        held.push_back(i);
      }
    }
    const std::vector<double> allHeld =
      stmPieceBorder::detail::AllGather(this->Controller, heldKeys);
    std::unordered_set<Key, stmPieceBorder::KeyHash> wanted;
    for (std::size_t at = 0; at + 3 <= allHeld.size(); at += 3)
    {
      wanted.insert(Key{ allHeld[at], allHeld[at + 1], allHeld[at + 2] });
    }
    // This piece's own points among them, and every piece's such points, by name.
    this->Sent.clear();
    std::vector<double> sentKeys;
    for (std::int64_t i = 0; i < count; ++i)
    {
      if (this->OwnPoints[static_cast<std::size_t>(points[i])])
      {
        const Key key = keyOf(points[i]);
        if (wanted.count(key))
        {
          this->Sent.push_back(i);
          sentKeys.insert(sentKeys.end(), key.begin(), key.end());
        }
      }
    }
    const int ranks = this->Controller->GetNumberOfProcesses();
    const long long sentCount = static_cast<long long>(this->Sent.size());
    std::vector<long long> sentCounts(static_cast<std::size_t>(ranks));
    this->Controller->AllGather(&sentCount, sentCounts.data(), 1);
    this->SentCounts.assign(sentCounts.begin(), sentCounts.end());
    const std::vector<double> allSent =
      stmPieceBorder::detail::AllGather(this->Controller, sentKeys);
    std::unordered_map<Key, std::int64_t, stmPieceBorder::KeyHash> senders;
    for (std::size_t at = 0; at + 3 <= allSent.size(); at += 3)
    {
      senders.emplace(
        Key{ allSent[at], allSent[at + 1], allSent[at + 2] }, static_cast<std::int64_t>(at / 3));
    }
    this->Received.clear();
    this->ReceivedFrom.clear();
    this->Unmatched = 0;
    for (std::size_t j = 0; j < held.size(); ++j)
    {
      const auto found =
        senders.find(Key{ heldKeys[3 * j], heldKeys[3 * j + 1], heldKeys[3 * j + 2] });
      if (found == senders.end())
      {
        ++this->Unmatched;
        continue;
      }
      this->Received.push_back(held[j]);
      this->ReceivedFrom.push_back(found->second);
    }
  }

  bool IsIdle() const override
  {
    return std::all_of(
      this->SentCounts.begin(), this->SentCounts.end(), [](long long n) { return n == 0; });
  }

  const std::vector<std::int64_t>& GetSent() const override { return this->Sent; }
  const std::vector<std::int64_t>& GetReceived() const override { return this->Received; }

  void Share(const std::vector<double>& sent, int width, std::vector<double>& received) override
  {
    const int ranks = this->Controller->GetNumberOfProcesses();
    std::vector<vtkIdType> counts(static_cast<std::size_t>(ranks)), offsets(counts.size(), 0);
    for (int r = 0; r < ranks; ++r)
    {
      counts[r] = static_cast<vtkIdType>(this->SentCounts[r] * width);
      offsets[r] = r == 0 ? 0 : offsets[r - 1] + counts[r - 1];
    }
    received.resize(this->Received.size() * static_cast<std::size_t>(width));
    const vtkIdType total = offsets.back() + counts.back();
    if (total == 0)
    {
      return; // every rank knows the counts: all skip
    }
    this->All.resize(static_cast<std::size_t>(total));
    double nothing = 0.0;
    this->Controller->AllGatherV(sent.empty() ? &nothing : sent.data(), this->All.data(),
      static_cast<vtkIdType>(sent.size()), counts.data(), offsets.data());
    for (std::size_t j = 0; j < this->Received.size(); ++j)
    {
      const double* from = this->All.data() + this->ReceivedFrom[j] * width;
      std::copy(from, from + width, received.data() + j * width);
    }
  }

  /// Held points that no piece sends: 0 when the pieces' meshes agree where they meet.
  std::int64_t GetNumberOfUnmatchedPoints() const { return this->Unmatched; }

private:
  vtkMultiProcessController* Controller;
  vtkPoints* Keys = nullptr;
  std::vector<double> KeyCoordinates; // without Keys
  std::vector<std::uint8_t> OwnPoints;
  std::vector<std::int64_t> Sent;
  std::vector<long long> SentCounts; // per rank
  std::vector<std::int64_t> Received;
  std::vector<std::int64_t> ReceivedFrom; // index among all ranks' sent points, in rank order
  std::vector<double> All;
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
