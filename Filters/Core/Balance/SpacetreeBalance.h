// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSpacetreeBalance_h
#define stmCoreSpacetreeBalance_h

// Balancing (paper section 2.2): refine leaves until no two adjacent leaves differ by more than
// BalanceLevel levels. Adjacent means sharing a facet, or with FaceBalanceOnly unset, sharing
// any vertex. Balancing only splits leaves; it never coarsens and never changes a material.
//
// Leaves are processed from the finest level to the coarsest. A leaf of level l forces every
// adjacent leaf to level >= l - L; the leaves this creates have levels <= l - L < l and are
// therefore visited later in the same sweep, so one sweep suffices. Each split rewrites the
// level map of the split leaf, so the work is linear in the lattice cells times the levels.

#include "../Common/CubeInfo.h"
#include "../Common/Execution.h"
#include "../Common/Status.h"
#include "../Spacetree/LevelMap.h"
#include "../Spacetree/Spacetree.h"

#include <algorithm>
#include <cstdint>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace stm
{

struct SpacetreeBalanceOptions
{
  /// Largest level difference allowed between adjacent leaves (>= 1).
  int BalanceLevel = 1;
  /// Only leaves that share a facet count as adjacent.
  bool FaceBalanceOnly = false;
};

/// The neighbour directions of a cell, each component in {-1, 0, 1}; all 3^Dim - 1 of them,
/// or only the 2 Dim facet directions.
template <int Dim>
std::vector<LatticeIndex<Dim>> NeighborDirections(bool facetsOnly)
{
  std::vector<LatticeIndex<Dim>> directions;
  for (int code = 0; code < IntPow(3, Dim); ++code)
  {
    LatticeIndex<Dim> direction;
    int rest = code;
    int nonZero = 0;
    for (int axis = 0; axis < Dim; ++axis)
    {
      direction[axis] = rest % 3 - 1;
      rest /= 3;
      nonZero += direction[axis] != 0;
    }
    if (nonZero == 0 || (facetsOnly && nonZero != 1))
    {
      continue;
    }
    directions.push_back(direction);
  }
  return directions;
}

template <int Dim>
class SpacetreeBalancer
{
  /// Finds, for the leaves of one level, the neighbouring cells that lie in too coarse a leaf.
  struct ScanKernel
  {
    using Scratch = NoScratch;
    const LevelMap<Dim>* Map;
    const std::vector<LatticeIndex<Dim>>* Leaves;
    const std::vector<LatticeIndex<Dim>>* Directions;
    int Level;
    int CoarsestAllowed;
    std::int64_t Size;
    /// (first leaf of the range, cells found), one entry per range.
    mutable std::vector<std::pair<std::int64_t, std::vector<LatticeIndex<Dim>>>> Found;
    mutable std::mutex FoundLock;

    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      std::vector<LatticeIndex<Dim>> found;
      for (std::int64_t i = begin; i < end; ++i)
      {
        const LatticeIndex<Dim>& anchor = (*this->Leaves)[i];
        if (this->Map->LevelAt(anchor) != this->Level)
        {
          continue; // split since it was queued
        }
        for (const auto& direction : *this->Directions)
        {
          LatticeIndex<Dim> sample;
          bool inside = true;
          for (int axis = 0; axis < Dim; ++axis)
          {
            sample[axis] = direction[axis] < 0 ? anchor[axis] - 1
              : direction[axis] > 0            ? anchor[axis] + this->Size
                                               : anchor[axis];
            inside = inside && sample[axis] >= 0 && sample[axis] < this->Map->GetDimensions()[axis];
          }
          if (inside && this->Map->LevelAt(sample) < this->CoarsestAllowed)
          {
            found.push_back(sample);
          }
        }
      }
      if (!found.empty())
      {
        std::lock_guard<std::mutex> lock(this->FoundLock);
        this->Found.emplace_back(begin, std::move(found));
      }
    }

    /// The cells found, in leaf order whatever the order in which the ranges ran.
    std::vector<LatticeIndex<Dim>> TakeFound() const
    {
      std::sort(this->Found.begin(), this->Found.end(),
        [](const auto& x, const auto& y) { return x.first < y.first; });
      std::vector<LatticeIndex<Dim>> all;
      for (auto& range : this->Found)
      {
        all.insert(all.end(), range.second.begin(), range.second.end());
      }
      this->Found.clear();
      return all;
    }
  };

public:
  template <class Executor>
  Status Balance(Spacetree<Dim>& tree, const SpacetreeBalanceOptions& options, Executor& executor)
  {
    if (options.BalanceLevel < 1)
    {
      return Status::Invalid(
        "BalanceLevel must be at least 1, got " + std::to_string(options.BalanceLevel));
    }
    LevelMap<Dim> map;
    Status status = map.Build(tree, executor);
    if (!status.IsOk())
    {
      return status;
    }

    std::vector<std::vector<LatticeIndex<Dim>>> leavesByLevel(tree.MaxLevel + 1);
    for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
    {
      leavesByLevel[tree.LeafLevels[leaf]].push_back(tree.LeafAnchors[leaf]);
    }
    const auto directions = NeighborDirections<Dim>(options.FaceBalanceOnly);
    const int L = options.BalanceLevel;

    for (int level = tree.MaxLevel; level > L; --level)
    {
      if (executor.ShouldAbort())
      {
        return Status::Aborted();
      }
      executor.ReportProgress(0.1 + 0.8 * (tree.MaxLevel - level) / tree.MaxLevel);
      // The scan reads the map only; the splits it asks for are applied afterwards. Splitting is
      // idempotent ("until the sample cell is fine enough"), so the result does not depend on
      // the order of the requests, nor on the number of threads.
      auto& leaves = leavesByLevel[level];
      ScanKernel scan{ &map, &leaves, &directions, level, level - L, tree.GetCellSize(level), {},
        {} };
      executor.For(0, static_cast<std::int64_t>(leaves.size()), 4096, scan);
      const std::vector<LatticeIndex<Dim>> requests = scan.TakeFound();
      for (const LatticeIndex<Dim>& sample : requests)
      {
        for (int neighborLevel = map.LevelAt(sample); neighborLevel < level - L;
             neighborLevel = map.LevelAt(sample))
        {
          const LatticeIndex<Dim> neighborAnchor = map.AnchorOf(sample, neighborLevel);
          map.Split(neighborAnchor, neighborLevel);
          const std::int64_t half = tree.GetCellSize(neighborLevel + 1);
          for (int child = 0; child < CubeInfo<Dim>::VerticesPerCell; ++child)
          {
            LatticeIndex<Dim> childAnchor = neighborAnchor;
            for (int axis = 0; axis < Dim; ++axis)
            {
              childAnchor[axis] += ((child >> axis) & 1) * half;
            }
            leavesByLevel[neighborLevel + 1].push_back(childAnchor);
          }
        }
      }
      leaves.clear();
      leaves.shrink_to_fit();
    }

    status = map.CollectLeaves(tree, executor);
    if (!status.IsOk())
    {
      return status;
    }
    tree.BalanceLevel = L;
    tree.FaceBalanceOnly = options.FaceBalanceOnly;
    executor.ReportProgress(1.0);
    return Status::Ok();
  }
};

/// The largest level difference between adjacent leaves; 0 for a uniform tree.
template <int Dim, class Executor>
int MaximumLevelDifference(const Spacetree<Dim>& tree, bool facetsOnly, Executor& executor)
{
  LevelMap<Dim> map;
  if (!map.Build(tree, executor).IsOk())
  {
    return -1;
  }
  const auto directions = NeighborDirections<Dim>(facetsOnly);
  int worst = 0;
  for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
  {
    const int level = tree.LeafLevels[leaf];
    const std::int64_t size = tree.GetCellSize(level);
    const auto& anchor = tree.LeafAnchors[leaf];
    for (const auto& direction : directions)
    {
      // Every leaf touching this side: walk the lattice cells along the shared face.
      LatticeIndex<Dim> lo, hi;
      for (int axis = 0; axis < Dim; ++axis)
      {
        lo[axis] = direction[axis] < 0 ? anchor[axis] - 1
          : direction[axis] > 0        ? anchor[axis] + size
                                       : anchor[axis];
        hi[axis] = direction[axis] == 0 ? anchor[axis] + size : lo[axis] + 1;
      }
      bool inside = true;
      for (int axis = 0; axis < Dim; ++axis)
      {
        inside = inside && lo[axis] >= 0 && hi[axis] <= map.GetDimensions()[axis];
      }
      if (!inside)
      {
        continue;
      }
      LatticeIndex<Dim> cell = lo;
      for (;;)
      {
        const int difference = map.LevelAt(cell) - level;
        worst = std::max(worst, difference < 0 ? -difference : difference);
        int axis = 0;
        for (; axis < Dim; ++axis)
        {
          if (++cell[axis] < hi[axis])
          {
            break;
          }
          cell[axis] = lo[axis];
        }
        if (axis == Dim)
        {
          break;
        }
      }
    }
  }
  return worst;
}

} // namespace stm

#endif
