// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   the smoothing's pass over the points that pieces share, for pieces meshed on the
 *          ranks of an MPI run (stmImageToSpacetree::SplitIntoPieces), private to the module
 *
 * Each piece holds the points of its ghost cells in its volume restoration and quality
 * improvement (the steps before them are exchanged, stmPieceExchange.h), so the quality
 * improvement cannot move the points two pieces share. A cell beyond the quality bounds at such
 * a point then stays (the AAL atlas with all 116 labels on 2 ranks, before the exchanged steps:
 * worst condition number 4.54 and smallest dihedral angle 9.1 degrees, against 3.5 and 15.0 on
 * one rank). After every rank has smoothed, all ranks together:
 *
 * 1. send the positions of the points of their own cells that have a border point (a point of
 *    an own and of a ghost cell), so that every rank updates the ghost cells next to its own:
 *    the neighbours' copies. A point is named by its position before the smoothing, which the
 *    pieces compute bit for bit alike.
 * 2. take turns in rank order. In its turn a rank improves the cells beyond the bounds that
 *    have a border point, on the cells around their points: it moves their border points and
 *    its own points, whose every cell it has (a cell at a border point shares it with an own
 *    cell, so it is in the ring of ghost cells the piece keeps), with the smoother's quality
 *    improvement and validation. It then sends the points it moved, and the others update
 *    their copies, bit for bit, before the next turn.
 *
 * Every rank takes part in every step, also one with an empty piece or a failed smoothing
 * (with nothing to send): the steps are collective. The turns are serial over the ranks; each
 * scans the rank's cells once and improves a small mesh (the cells around a few bad cells). The
 * exchange in step 1 is about the size of the ring of ghost cells.
 */

#ifndef stmPieceBorder_h
#define stmPieceBorder_h

#include "Check/SimplexQuality.h"
#include "Smooth/BoundarySmooth.h"

#include "vtkInformation.h"
#include "vtkMultiProcessController.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <unordered_map>
#include <vector>

namespace stmPieceBorder
{
/// A point's name in the exchange: its position before the smoothing.
using Key = std::array<double, 3>;

struct KeyHash
{
  std::size_t operator()(const Key& key) const
  {
    std::size_t hash = 0;
    for (const double value : key)
    {
      std::uint64_t bits;
      std::memcpy(&bits, &value, sizeof bits);
      hash = (hash ^ bits) * 0x100000001b3ull;
    }
    return hash;
  }
};

/// What the pass did on this rank.
struct Stats
{
  std::int64_t UpdatedCopies = 0;  // ghost points given their owner's smoothed position
  std::int64_t ImprovedPoints = 0; // points this rank's turns moved
  std::int64_t BadCellsBefore = 0; // cells beyond the bounds at border points, before its turn
};

/// A piece's mesh as the pass reads and moves it. Empty (no points) for a rank with nothing to
/// contribute.
template <int Dim, class IdType>
struct Piece
{
  double* Points = nullptr; // Dim per point, the smoother's coordinates
  std::int64_t NumberOfPoints = 0;
  const IdType* Connectivity = nullptr;
  std::int64_t NumberOfCells = 0;
  const unsigned char* GhostCells = nullptr;
  const std::uint8_t* GhostPoints = nullptr; // per point: 1 for a point of a ghost cell
  const std::int64_t* Materials = nullptr;   // per cell, or null
  const std::uint8_t* Roles = nullptr;       // the smoother's PointRole per point
};

namespace detail
{
/// Gathers every rank's records on every rank, in rank order.
inline std::vector<double> AllGather(
  vtkMultiProcessController* controller, const std::vector<double>& records)
{
  const int ranks = controller->GetNumberOfProcesses();
  const long long length = static_cast<long long>(records.size());
  std::vector<long long> lengths(static_cast<std::size_t>(ranks));
  controller->AllGather(&length, lengths.data(), 1);
  std::vector<vtkIdType> counts(lengths.begin(), lengths.end()), offsets(counts.size(), 0);
  for (std::size_t r = 1; r < counts.size(); ++r)
  {
    offsets[r] = offsets[r - 1] + counts[r - 1];
  }
  std::vector<double> all(static_cast<std::size_t>(offsets.back() + counts.back()));
  if (!all.empty())
  {
    double nothing = 0.0; // a valid address for a rank that sends no record
    controller->AllGatherV(records.empty() ? &nothing : records.data(), all.data(),
      static_cast<vtkIdType>(length), counts.data(), offsets.data());
  }
  return all;
}

/// `records` of rank `root` on every rank.
inline void Broadcast(vtkMultiProcessController* controller, int root, std::vector<double>& records)
{
  long long count = static_cast<long long>(records.size());
  controller->Broadcast(&count, 1, root);
  records.resize(static_cast<std::size_t>(count));
  if (count > 0)
  {
    controller->Broadcast(records.data(), static_cast<vtkIdType>(count), root);
  }
}
} // namespace detail

/// The pass (see the file's comment), collective over the ranks of `controller`. `ready` false
/// (an empty piece, a failed or unsupported smoothing) takes part with nothing; when any rank
/// is not ready, or no rank has ghost cells, no rank changes anything. keyOf(p, double[3]) gives
/// point p's position before the smoothing. `options` are the smoothing's; projector as
/// BoundarySmoother::Smooth takes it, called with the piece's point ids.
template <int Dim, class IdType, class KeyOf, class Projector, class Executor>
stm::Status ImproveSharedPoints(vtkMultiProcessController* controller, bool ready,
  const Piece<Dim, IdType>& piece, KeyOf&& keyOf, const stm::BoundarySmoothOptions& options,
  Projector&& projector, Executor& executor, Stats& stats)
{
  constexpr int Corners = Dim + 1;
  constexpr int Width = 3 + Dim; // a record: the key, then the position
  const bool hasGhosts = ready && piece.GhostCells && piece.GhostPoints &&
    std::any_of(piece.GhostCells, piece.GhostCells + piece.NumberOfCells,
      [](unsigned char g) { return g != 0; });
  int local[2] = { ready ? 1 : 0, hasGhosts ? 1 : 0 }, all[2] = { 0, 0 };
  controller->AllReduce(local, all, 1, vtkCommunicator::MIN_OP);
  controller->AllReduce(local + 1, all + 1, 1, vtkCommunicator::MAX_OP);
  if (all[0] == 0 || all[1] == 0)
  {
    return stm::Status::Ok();
  }
  const bool active = hasGhosts && Dim >= 2 && Dim <= 3;
  const std::int64_t points = active ? piece.NumberOfPoints : 0;
  const std::int64_t cells = active ? piece.NumberOfCells : 0;

  // Own points (those of own cells); with the ghost points, the border points (both).
  const std::uint8_t* ghost = piece.GhostPoints;
  std::vector<std::uint8_t> own(static_cast<std::size_t>(points), 0);
  for (std::int64_t c = 0; c < cells; ++c)
  {
    for (int v = 0; v < Corners && !piece.GhostCells[c]; ++v)
    {
      own[static_cast<std::size_t>(piece.Connectivity[c * Corners + v])] = 1;
    }
  }
  auto isBorder = [&](std::int64_t p) { return own[p] && ghost[p]; };
  std::vector<std::int64_t> borderCells;
  for (std::int64_t c = 0; c < cells; ++c)
  {
    for (int v = 0; v < Corners; ++v)
    {
      if (isBorder(static_cast<std::int64_t>(piece.Connectivity[c * Corners + v])))
      {
        borderCells.push_back(c);
        break;
      }
    }
  }
  auto append = [&](std::vector<double>& records, std::int64_t p)
  {
    double key[3];
    keyOf(p, key);
    records.insert(records.end(), key, key + 3);
    records.insert(records.end(), piece.Points + p * Dim, piece.Points + (p + 1) * Dim);
  };
  // The ghost points by key: the copies that other ranks' records update.
  std::unordered_map<Key, std::int64_t, KeyHash> copies;
  for (std::int64_t p = 0; p < points; ++p)
  {
    if (ghost[p])
    {
      Key key;
      keyOf(p, key.data());
      copies.emplace(key, p);
    }
  }
  // Applies other ranks' records to the copies; border points only when `borderToo` (in step 1
  // they are held on every rank and already equal).
  auto apply = [&](const std::vector<double>& records, bool borderToo)
  {
    std::int64_t updated = 0;
    for (std::size_t r = 0; r + Width <= records.size(); r += Width)
    {
      const Key key{ records[r], records[r + 1], records[r + 2] };
      const auto found = copies.find(key);
      if (found == copies.end() || (!borderToo && own[found->second]))
      {
        continue;
      }
      std::copy(
        records.begin() + r + 3, records.begin() + r + Width, piece.Points + found->second * Dim);
      ++updated;
    }
    return updated;
  };

  // Step 1: the own points of the cells at the border, to the neighbours' copies.
  {
    std::vector<std::uint8_t> sent(static_cast<std::size_t>(points), 0);
    std::vector<double> records;
    for (const std::int64_t c : borderCells)
    {
      for (int v = 0; v < Corners && !piece.GhostCells[c]; ++v)
      {
        const auto p = static_cast<std::int64_t>(piece.Connectivity[c * Corners + v]);
        if (!sent[p])
        {
          sent[p] = 1;
          append(records, p);
        }
      }
    }
    stats.UpdatedCopies += apply(detail::AllGather(controller, records), false);
  }

  // Step 2: the turns.
  const double minCosine = std::cos(options.MinDihedralAngle * (3.14159265358979323846 / 180.0));
  auto isBad = [&](std::int64_t c)
  {
    const double* corners[Dim + 1];
    for (int v = 0; v < Corners; ++v)
    {
      corners[v] =
        piece.Points + static_cast<std::int64_t>(piece.Connectivity[c * Corners + v]) * Dim;
    }
    const stm::SimplexCosines shape = stm::MeasureSimplexCosines<Dim>(corners);
    return shape.Determinant > 0.0 &&
      (shape.Condition > options.MaxConditionNumber || shape.LargestDihedralCosine > minCosine);
  };
  stm::Status status = stm::Status::Ok();
  for (int turn = 0; turn < controller->GetNumberOfProcesses(); ++turn)
  {
    std::vector<double> records;
    if (turn == controller->GetLocalProcessId() && status.IsOk() && !executor.ShouldAbort())
    {
      // The movable points: the border points and the smoothable own points of the bad cells.
      std::vector<std::uint8_t> movable(static_cast<std::size_t>(points), 0);
      bool any = false;
      for (const std::int64_t c : borderCells)
      {
        if (!isBad(c))
        {
          continue;
        }
        ++stats.BadCellsBefore;
        for (int v = 0; v < Corners; ++v)
        {
          const auto p = static_cast<std::int64_t>(piece.Connectivity[c * Corners + v]);
          const std::uint8_t role = piece.Roles[p];
          const bool smoothable = role == stm::BoundarySmoother<Dim>::Surface ||
            role == stm::BoundarySmoother<Dim>::InteriorLayer ||
            role == stm::BoundarySmoother<Dim>::KeptSurface;
          movable[p] = isBorder(p) || (!ghost[p] && smoothable);
          any = any || movable[p];
        }
      }
      if (any)
      {
        // The cells around the movable points, with their own point numbering: every other
        // point is held.
        std::unordered_map<std::int64_t, std::int64_t> subId;
        std::vector<std::int64_t> pieceId, subConnectivity, subMaterials;
        for (std::int64_t c = 0; c < cells; ++c)
        {
          const IdType* ids = piece.Connectivity + c * Corners;
          if (std::none_of(ids, ids + Corners, [&](IdType id) { return movable[id] != 0; }))
          {
            continue;
          }
          for (int v = 0; v < Corners; ++v)
          {
            const auto p = static_cast<std::int64_t>(ids[v]);
            const auto inserted = subId.emplace(p, static_cast<std::int64_t>(pieceId.size()));
            if (inserted.second)
            {
              pieceId.push_back(p);
            }
            subConnectivity.push_back(inserted.first->second);
          }
          if (piece.Materials)
          {
            subMaterials.push_back(piece.Materials[c]);
          }
        }
        const auto subPoints = static_cast<std::int64_t>(pieceId.size());
        std::vector<double> positions(static_cast<std::size_t>(subPoints * Dim));
        std::vector<std::uint8_t> held(static_cast<std::size_t>(subPoints));
        for (std::int64_t s = 0; s < subPoints; ++s)
        {
          std::copy(piece.Points + pieceId[s] * Dim, piece.Points + (pieceId[s] + 1) * Dim,
            positions.data() + s * Dim);
          held[s] = !movable[pieceId[s]];
        }
        stm::BoundarySmoothOptions turnOptions = options;
        turnOptions.NumberOfIterations = 0;
        turnOptions.TargetVolumes.clear();
        turnOptions.VolumeTargetMaterials = nullptr;
        turnOptions.SmallPartPoints = 0; // the kept points are not movable (their role)
        turnOptions.HeldPoints = held.data();
        turnOptions.GhostCells = nullptr;
        turnOptions.CellRootColours = nullptr; // the whole piece's cells, not the submesh's
        turnOptions.Exchange = nullptr;
        turnOptions.GhostPoints = nullptr;
        const std::int64_t* materials = piece.Materials ? subMaterials.data() : nullptr;
        const auto subCells = static_cast<std::int64_t>(subConnectivity.size() / Corners);
        stm::BoundarySmoother<Dim> smoother;
        if (std::is_same<std::decay_t<Projector>, stm::NoProjection>::value)
        {
          status = smoother.Smooth(positions.data(), subPoints, subConnectivity.data(), subCells,
            materials, turnOptions, executor);
        }
        else
        {
          auto project = [&](std::int64_t s, double* x) { return projector(pieceId[s], x); };
          status = smoother.Smooth(positions.data(), subPoints, subConnectivity.data(), subCells,
            materials, turnOptions, project, executor);
        }
        for (std::int64_t s = 0; s < subPoints && status.IsOk(); ++s)
        {
          double* x = piece.Points + pieceId[s] * Dim;
          if (!held[s] && !std::equal(x, x + Dim, positions.data() + s * Dim))
          {
            std::copy(positions.data() + s * Dim, positions.data() + (s + 1) * Dim, x);
            append(records, pieceId[s]);
            ++stats.ImprovedPoints;
          }
        }
      }
    }
    detail::Broadcast(controller, turn, records);
    if (turn != controller->GetLocalProcessId())
    {
      apply(records, true);
    }
  }
  return status;
}
} // namespace stmPieceBorder

#endif
