// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   the exchanges by which the pieces of an MPI run classify the thin parts of an image
 *          that no rank reads whole (stm::ThinPartPiece over a vtkMultiProcessController),
 *          private to the module
 *
 * Every rank that meshes a piece with thin-part refinement takes part, the ranks whose piece is
 * empty too: first a vote (all ready? all given the whole image?), and unless every rank has the
 * whole image, the exchanges of stm::ThinPartPiece: each pair of ranks whose boxes overlap swaps
 * the components of the voxels one reads and the other owns (blocking sends, the pairs in one
 * order on every rank, so that no two ranks wait on each other), then an all-gather of the
 * records and a sum of the thin voxels. A rank that fails before its turn still votes (Vote's
 * guard), so that no rank waits for it.
 */

#ifndef stmThinPartExchange_h
#define stmThinPartExchange_h

#include "Spacetree/ThinPartPieces.h"

#include "vtkCommunicator.h"
#include "vtkMultiProcessController.h"

#include <cstdint>
#include <vector>

namespace stmThinPartExchange
{
/// The first collective call of the classification; its destructor votes "not ready" for a rank
/// that returns before voting.
class Vote
{
public:
  /// controller: null when the ranks do not classify together (then nothing is collective).
  explicit Vote(vtkMultiProcessController* controller)
    : Controller(controller)
  {
  }
  ~Vote()
  {
    if (this->Controller && !this->Cast)
    {
      this->Take(false, true);
    }
  }
  Vote(const Vote&) = delete;
  Vote& operator=(const Vote&) = delete;

  vtkMultiProcessController* GetController() const { return this->Controller; }

  /// Votes once (collective): whether this rank is ready, and whether it holds the whole image.
  void Take(bool ready, bool whole)
  {
    this->Cast = true;
    int mine[2] = { ready ? 1 : 0, whole ? 1 : 0 };
    int all[2] = { 0, 0 };
    this->Controller->AllReduce(mine, all, 2, vtkCommunicator::MIN_OP);
    this->AllReady = all[0] != 0;
    this->AllWhole = all[1] != 0;
  }

  bool IsCast() const { return this->Cast; }
  bool GetAllReady() const { return this->AllReady; }
  bool GetAllWhole() const { return this->AllWhole; }

private:
  vtkMultiProcessController* Controller;
  bool Cast = false;
  bool AllReady = false;
  bool AllWhole = false;
};

/// Whether `ok` holds on every rank (collective).
inline bool AllOk(vtkMultiProcessController* controller, bool ok)
{
  int mine = ok ? 1 : 0, all = 0;
  controller->AllReduce(&mine, &all, 1, vtkCommunicator::MIN_OP);
  return all != 0;
}

/// Steps 2 and 3 of stm::ThinPartPiece for this rank's `piece` (classified), given every rank's
/// own and read boxes (collective). thin: Finish's flags; wholeThinVoxels: the sum of all ranks'
/// own thin voxels.
template <int Dim, class Executor>
stm::Status Exchange(vtkMultiProcessController* controller, stm::ThinPartPiece<Dim>& piece,
  const std::vector<stm::VoxelBox<Dim>>& owned, const std::vector<stm::VoxelBox<Dim>>& read,
  std::vector<std::uint8_t>& thin, std::int64_t& wholeThinVoxels, Executor& executor)
{
  constexpr int ComponentsTag = 731840;
  const int ranks = controller->GetNumberOfProcesses();
  const int rank = controller->GetLocalProcessId();
  stm::Status status = stm::Status::Ok();
  for (int first = 0; first < ranks; ++first)
  {
    for (int second = first + 1; second < ranks; ++second)
    {
      if (rank != first && rank != second)
      {
        continue;
      }
      const int other = rank == first ? second : first;
      const stm::VoxelBox<Dim> sent = read[rank].Intersection(owned[other]);
      const stm::VoxelBox<Dim> received = read[other].Intersection(owned[rank]);
      auto send = [&]
      {
        if (!sent.IsEmpty())
        {
          const std::vector<std::int32_t> components = piece.ComponentsIn(sent);
          controller->Send(
            components.data(), static_cast<vtkIdType>(components.size()), other, ComponentsTag);
        }
      };
      auto receive = [&]
      {
        if (!received.IsEmpty())
        {
          std::vector<std::int32_t> components(
            static_cast<std::size_t>(received.GetNumberOfVoxels()));
          controller->Receive(
            components.data(), static_cast<vtkIdType>(components.size()), other, ComponentsTag);
          if (status.IsOk())
          {
            status = piece.Join(other, received, components);
          }
        }
      };
      if (rank == first)
      {
        send();
        receive();
      }
      else
      {
        receive();
        send();
      }
    }
  }
  const std::vector<std::int64_t> records = piece.Records();
  const long long length = static_cast<long long>(records.size());
  std::vector<long long> lengths(static_cast<std::size_t>(ranks));
  controller->AllGather(&length, lengths.data(), 1);
  std::vector<vtkIdType> counts(lengths.begin(), lengths.end()), offsets(counts.size(), 0);
  for (std::size_t r = 1; r < counts.size(); ++r)
  {
    offsets[r] = offsets[r - 1] + counts[r - 1];
  }
  std::vector<long long> all(static_cast<std::size_t>(offsets.back() + counts.back()));
  if (!all.empty())
  {
    long long nothing = 0; // a valid address for a rank that sends no record
    controller->AllGatherV(
      records.empty() ? &nothing : reinterpret_cast<const long long*>(records.data()), all.data(),
      static_cast<vtkIdType>(length), counts.data(), offsets.data());
  }
  if (status.IsOk())
  {
    status = piece.Finish(std::vector<std::int64_t>(all.begin(), all.end()), thin, executor);
  }
  long long own = status.IsOk() ? piece.CountOwnThinVoxels(thin) : 0, sum = 0;
  controller->AllReduce(&own, &sum, 1, vtkCommunicator::SUM_OP);
  wholeThinVoxels = sum;
  return status;
}

} // namespace stmThinPartExchange

#endif
