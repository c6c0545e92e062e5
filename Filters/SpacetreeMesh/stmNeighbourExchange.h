// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   values of shared points sent between neighbouring pieces only, for the exchanges of
 *          an MPI run (stmPieceExchange, stmSnapExchange), private to the module
 *
 * A piece wants the values of some points (the points it holds) and offers those of others
 * (the points it decides or moves); a point is named by a key, its position before the stage,
 * which the pieces compute bit for bit alike. The lists are built once:
 *
 * 1. every rank gathers every rank's bounding boxes of its wanted and of its offered keys (12
 *    doubles a rank, the only collective);
 * 2. a piece asks the pieces whose offered box meets its wanted box for its wanted keys inside
 *    that box;
 * 3. each asked piece answers with the asked keys it offers, and their group (the smoothing's
 *    root colour);
 * 4. the asking piece takes each point from the lowest rank that offers it (several pieces
 *    may offer a point of their own cells; they offer the same value) and tells each piece
 *    which of its answers it takes.
 *
 * Every share then sends each piece the taken values only, in an order both sides know (group,
 * then the asker's order), so neither the messages nor their lengths grow with the number of
 * ranks: a piece talks to the pieces whose boxes meet its own. Under MPI the messages are
 * non-blocking (vtkMPICommunicator); with any other communicator the pairs take turns in one
 * global order (the lower rank of a pair sends first), which cannot deadlock.
 */

#ifndef stmNeighbourExchange_h
#define stmNeighbourExchange_h

#include "stmPieceBorder.h"

#include "vtkCommunicator.h"
#include "vtkMPICommunicator.h"
#include "vtkMultiProcessController.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <numeric>
#include <unordered_map>
#include <vector>

namespace stmNeighbourExchange
{
using Key = stmPieceBorder::Key;

/// How a round's messages travel: non-blocking where the communicator is MPI's, else (and on
/// request, for the tests) in turns of pairs.
enum class Transport
{
  Automatic,
  PairsInTurn
};

namespace detail
{
inline vtkMPICommunicator* NonBlocking(vtkMultiProcessController* controller, Transport transport)
{
  return transport == Transport::Automatic
    ? vtkMPICommunicator::SafeDownCast(controller->GetCommunicator())
    : nullptr;
}

/// One round: `sent[k]` to rank `sendTo[k]`, and from rank `receiveFrom[k]` into
/// `received[k]`, whose length the caller knows (both sides skip empty messages alike).
template <class T>
void Round(vtkMultiProcessController* controller, Transport transport, int tag,
  const std::vector<int>& sendTo, const std::vector<std::vector<T>>& sent,
  const std::vector<int>& receiveFrom, std::vector<std::vector<T>>& received)
{
  if (vtkMPICommunicator* mpi = NonBlocking(controller, transport))
  {
    std::vector<vtkMPICommunicator::Request> requests(sendTo.size() + receiveFrom.size());
    int posted = 0;
    for (std::size_t k = 0; k < receiveFrom.size(); ++k)
    {
      if (!received[k].empty())
      {
        mpi->NoBlockReceive(received[k].data(), static_cast<int>(received[k].size()),
          receiveFrom[k], tag, requests[posted++]);
      }
    }
    for (std::size_t k = 0; k < sendTo.size(); ++k)
    {
      if (!sent[k].empty())
      {
        mpi->NoBlockSend(
          sent[k].data(), static_cast<int>(sent[k].size()), sendTo[k], tag, requests[posted++]);
      }
    }
    if (posted > 0)
    {
      mpi->WaitAll(posted, requests.data());
    }
    return;
  }
  // Every rank takes its pairs in ascending order of the other rank, the order of the pairs
  // (lower rank, higher rank) on all ranks; in a pair the lower rank sends first.
  const int rank = controller->GetLocalProcessId();
  std::vector<int> peers(sendTo);
  peers.insert(peers.end(), receiveFrom.begin(), receiveFrom.end());
  std::sort(peers.begin(), peers.end());
  peers.erase(std::unique(peers.begin(), peers.end()), peers.end());
  auto send = [&](int peer)
  {
    const auto at = std::find(sendTo.begin(), sendTo.end(), peer);
    if (at != sendTo.end() && !sent[at - sendTo.begin()].empty())
    {
      const std::vector<T>& message = sent[at - sendTo.begin()];
      controller->Send(message.data(), static_cast<vtkIdType>(message.size()), peer, tag);
    }
  };
  auto receive = [&](int peer)
  {
    const auto at = std::find(receiveFrom.begin(), receiveFrom.end(), peer);
    if (at != receiveFrom.end() && !received[at - receiveFrom.begin()].empty())
    {
      std::vector<T>& message = received[at - receiveFrom.begin()];
      controller->Receive(message.data(), static_cast<vtkIdType>(message.size()), peer, tag);
    }
  };
  for (const int peer : peers)
  {
    if (rank < peer)
    {
      send(peer);
      receive(peer);
    }
    else
    {
      receive(peer);
      send(peer);
    }
  }
}

/// A round whose lengths the receivers do not know: the lengths first.
template <class T>
std::vector<std::vector<T>> RoundWithLengths(vtkMultiProcessController* controller,
  Transport transport, int tag, const std::vector<int>& sendTo,
  const std::vector<std::vector<T>>& sent, const std::vector<int>& receiveFrom)
{
  std::vector<std::vector<vtkIdType>> lengths(sendTo.size()), theirs(receiveFrom.size());
  for (std::size_t k = 0; k < sendTo.size(); ++k)
  {
    lengths[k] = { static_cast<vtkIdType>(sent[k].size()) };
  }
  for (auto& length : theirs)
  {
    length = { 0 };
  }
  Round(controller, transport, tag, sendTo, lengths, receiveFrom, theirs);
  std::vector<std::vector<T>> received(receiveFrom.size());
  for (std::size_t k = 0; k < receiveFrom.size(); ++k)
  {
    received[k].resize(static_cast<std::size_t>(theirs[k][0]));
  }
  Round(controller, transport, tag + 1, sendTo, sent, receiveFrom, received);
  return received;
}

using Box = std::array<double, 6>; // minimum x y z, maximum x y z; empty: minimum > maximum

inline Box BoundsOf(const std::vector<Key>& keys)
{
  Box box;
  for (int a = 0; a < 3; ++a)
  {
    box[a] = std::numeric_limits<double>::infinity();
    box[a + 3] = -std::numeric_limits<double>::infinity();
  }
  for (const Key& key : keys)
  {
    for (int a = 0; a < 3; ++a)
    {
      box[a] = std::min(box[a], key[a]);
      box[a + 3] = std::max(box[a + 3], key[a]);
    }
  }
  return box;
}

inline bool Inside(const Key& key, const double* box)
{
  return key[0] >= box[0] && key[1] >= box[1] && key[2] >= box[2] && key[0] <= box[3] &&
    key[1] <= box[4] && key[2] <= box[5];
}

inline bool Meet(const double* a, const double* b)
{
  for (int axis = 0; axis < 3; ++axis)
  {
    if (a[axis] > a[axis + 3] || b[axis] > b[axis + 3] || a[axis] > b[axis + 3] ||
      b[axis] > a[axis + 3])
    {
      return false;
    }
  }
  return true;
}
} // namespace detail

/// The lists and shares of the file's comment.
class Lists
{
public:
  explicit Lists(vtkMultiProcessController* controller, Transport transport = Transport::Automatic)
    : Controller(controller)
    , Via(transport)
  {
  }

  /// Builds the lists (collective). offeredGroups: a group in [0, numberOfGroups) per offered
  /// key, or empty for one group.
  void Build(const std::vector<Key>& wanted, const std::vector<Key>& offered,
    const std::vector<std::uint8_t>& offeredGroups, int numberOfGroups)
  {
    const int ranks = this->Controller->GetNumberOfProcesses();
    const int rank = this->Controller->GetLocalProcessId();
    this->NumberOfGroups = numberOfGroups;
    this->Providers.assign(wanted.size(), -1);
    this->Taken.assign(offered.size(), 0);
    // 1. Every rank's boxes.
    const detail::Box wantedBox = detail::BoundsOf(wanted), offeredBox = detail::BoundsOf(offered);
    std::array<double, 12> boxes;
    std::copy(wantedBox.begin(), wantedBox.end(), boxes.begin());
    std::copy(offeredBox.begin(), offeredBox.end(), boxes.begin() + 6);
    std::vector<double> all(12 * static_cast<std::size_t>(ranks));
    this->Controller->AllGather(boxes.data(), all.data(), 12);
    std::vector<int> askTo, askedBy;
    for (int r = 0; r < ranks; ++r)
    {
      if (r != rank && detail::Meet(wantedBox.data(), all.data() + 12 * r + 6))
      {
        askTo.push_back(r);
      }
      if (r != rank && detail::Meet(all.data() + 12 * r, offeredBox.data()))
      {
        askedBy.push_back(r);
      }
    }
    // 2. The wanted keys inside each asked piece's offered box.
    std::vector<std::vector<std::int64_t>> asked(askTo.size());
    std::vector<std::vector<double>> askedKeys(askTo.size());
    for (std::size_t k = 0; k < askTo.size(); ++k)
    {
      const double* box = all.data() + 12 * askTo[k] + 6;
      for (std::size_t w = 0; w < wanted.size(); ++w)
      {
        if (detail::Inside(wanted[w], box))
        {
          asked[k].push_back(static_cast<std::int64_t>(w));
          askedKeys[k].insert(askedKeys[k].end(), wanted[w].begin(), wanted[w].end());
        }
      }
    }
    const std::vector<std::vector<double>> questions =
      detail::RoundWithLengths(this->Controller, this->Via, Tag, askTo, askedKeys, askedBy);
    // 3. The answers: (question index, group) of each asked key offered here.
    std::unordered_map<Key, std::int64_t, stmPieceBorder::KeyHash> offers;
    offers.reserve(offered.size());
    for (std::size_t o = 0; o < offered.size(); ++o)
    {
      offers.emplace(offered[o], static_cast<std::int64_t>(o));
    }
    std::vector<std::vector<vtkIdType>> answers(askedBy.size());
    std::vector<std::vector<std::int64_t>> answeredOffers(askedBy.size());
    for (std::size_t k = 0; k < askedBy.size(); ++k)
    {
      for (std::size_t at = 0; at + 3 <= questions[k].size(); at += 3)
      {
        const auto found =
          offers.find(Key{ questions[k][at], questions[k][at + 1], questions[k][at + 2] });
        if (found != offers.end())
        {
          const int group =
            offeredGroups.empty() ? 0 : offeredGroups[static_cast<std::size_t>(found->second)];
          answers[k].push_back(static_cast<vtkIdType>(at / 3));
          answers[k].push_back(group);
          answeredOffers[k].push_back(found->second);
        }
      }
    }
    const std::vector<std::vector<vtkIdType>> replies =
      detail::RoundWithLengths(this->Controller, this->Via, Tag + 2, askedBy, answers, askTo);
    // 4. Each wanted point from the lowest rank that offers it (askTo ascends); the taken
    //    answers' positions go back.
    this->Peers.clear();
    std::vector<std::vector<vtkIdType>> takenAnswers(askTo.size());
    for (std::size_t k = 0; k < askTo.size(); ++k)
    {
      std::vector<Entry> receives;
      for (std::size_t at = 0; at + 2 <= replies[k].size(); at += 2)
      {
        const std::int64_t w = asked[k][static_cast<std::size_t>(replies[k][at])];
        if (this->Providers[static_cast<std::size_t>(w)] < 0)
        {
          this->Providers[static_cast<std::size_t>(w)] = askTo[k];
          takenAnswers[k].push_back(static_cast<vtkIdType>(at / 2));
          receives.push_back({ static_cast<int>(replies[k][at + 1]), w });
        }
      }
      if (!receives.empty())
      {
        this->PeerOf(askTo[k]).Receives = std::move(receives);
      }
    }
    const std::vector<std::vector<vtkIdType>> taken =
      detail::RoundWithLengths(this->Controller, this->Via, Tag + 4, askTo, takenAnswers, askedBy);
    for (std::size_t k = 0; k < askedBy.size(); ++k)
    {
      std::vector<Entry> sends;
      for (const vtkIdType answer : taken[k])
      {
        const std::int64_t o = answeredOffers[k][static_cast<std::size_t>(answer)];
        const int group = offeredGroups.empty() ? 0 : offeredGroups[static_cast<std::size_t>(o)];
        sends.push_back({ group, o });
        this->Taken[static_cast<std::size_t>(o)] = 1;
      }
      if (!sends.empty())
      {
        this->PeerOf(askedBy[k]).Sends = std::move(sends);
      }
    }
    // Both sides of a pair order its values by group, then by the asker's question order.
    for (Peer& peer : this->Peers)
    {
      peer.SendOffsets = this->ByGroup(peer.Sends);
      peer.ReceiveOffsets = this->ByGroup(peer.Receives);
    }
  }

  /// Sends every peer the taken values of the groups [first, last), `fill(offered, double*)`
  /// writing `width` values of an offered point, and hands each received value to
  /// `take(wanted, const double*)` (collective over the peers).
  template <class Fill, class Take>
  void Share(int width, int first, int last, Fill&& fill, Take&& take) const
  {
    std::vector<int> sendTo, receiveFrom;
    std::vector<std::vector<double>> sent, received;
    std::vector<const Peer*> receivedPeers;
    for (const Peer& peer : this->Peers)
    {
      const std::int64_t sends = peer.SendOffsets[last] - peer.SendOffsets[first];
      if (sends > 0)
      {
        sendTo.push_back(peer.Rank);
        sent.emplace_back(static_cast<std::size_t>(sends * width));
        double* out = sent.back().data();
        for (std::int64_t i = peer.SendOffsets[first]; i < peer.SendOffsets[last]; ++i)
        {
          fill(peer.Sends[static_cast<std::size_t>(i)].Point, out);
          out += width;
        }
      }
      const std::int64_t receives = peer.ReceiveOffsets[last] - peer.ReceiveOffsets[first];
      if (receives > 0)
      {
        receiveFrom.push_back(peer.Rank);
        received.emplace_back(static_cast<std::size_t>(receives * width));
        receivedPeers.push_back(&peer);
      }
    }
    detail::Round(this->Controller, this->Via, Tag + 6, sendTo, sent, receiveFrom, received);
    for (std::size_t k = 0; k < receivedPeers.size(); ++k)
    {
      const Peer& peer = *receivedPeers[k];
      const double* in = received[k].data();
      for (std::int64_t i = peer.ReceiveOffsets[first]; i < peer.ReceiveOffsets[last]; ++i)
      {
        take(peer.Receives[static_cast<std::size_t>(i)].Point, in);
        in += width;
      }
    }
  }

  /// Per wanted key, the rank that sends it, or -1 when no piece offers it.
  const std::vector<int>& GetProviders() const { return this->Providers; }
  /// Per offered key, 1 when some piece takes it.
  const std::vector<std::uint8_t>& GetTaken() const { return this->Taken; }
  /// The pieces this one sends values to or receives values from.
  int GetNumberOfPeers() const { return static_cast<int>(this->Peers.size()); }

private:
  static constexpr int Tag = 73100; // and the next six

  struct Entry
  {
    int Group;
    std::int64_t Point; // an offered index in Sends, a wanted one in Receives
  };
  struct Peer
  {
    int Rank;
    std::vector<Entry> Sends, Receives;
    std::vector<std::int64_t> SendOffsets, ReceiveOffsets; // per group, into the lists
  };

  Peer& PeerOf(int rank)
  {
    for (Peer& peer : this->Peers)
    {
      if (peer.Rank == rank)
      {
        return peer;
      }
    }
    this->Peers.push_back(Peer{ rank, {}, {}, {}, {} });
    return this->Peers.back();
  }

  /// Sorts `entries` by group, keeping their order within a group; returns the groups' offsets.
  std::vector<std::int64_t> ByGroup(std::vector<Entry>& entries) const
  {
    std::stable_sort(entries.begin(), entries.end(),
      [](const Entry& a, const Entry& b) { return a.Group < b.Group; });
    std::vector<std::int64_t> offsets(static_cast<std::size_t>(this->NumberOfGroups) + 1, 0);
    for (const Entry& entry : entries)
    {
      ++offsets[static_cast<std::size_t>(entry.Group) + 1];
    }
    std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
    return offsets;
  }

  vtkMultiProcessController* Controller;
  Transport Via;
  int NumberOfGroups = 1;
  std::vector<Peer> Peers;
  std::vector<int> Providers;
  std::vector<std::uint8_t> Taken;
};
} // namespace stmNeighbourExchange

#endif
