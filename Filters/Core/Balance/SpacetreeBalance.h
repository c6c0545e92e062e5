// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSpacetreeBalance_h
#define stmCoreSpacetreeBalance_h

// Balancing (paper section 2.2): refine leaves until no two adjacent leaves differ by more than
// L levels. Adjacent means sharing a facet, or with FaceBalanceOnly unset, sharing any vertex.
// Balancing only splits leaves; it never coarsens and never changes a material.
//
// L may vary in space: every leaf has a local balance level (the region's inside a region, else
// its material's if one is given, else BalanceLevel), and two adjacent leaves must satisfy the
// smaller of their two levels.
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
#include <functional>
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
  /// Balance level of the leaves of each material index; 0 (or a missing entry) means
  /// BalanceLevel.
  std::vector<int> MaterialBalanceLevels;
  /// If set, the balance level at a leaf centre (given in lattice units, Dim values), or 0 where
  /// no region applies; it overrides the material's.
  std::function<int(const double* centre)> RegionBalanceLevel;

  /// The local balance level of a leaf.
  template <int Dim>
  int LocalLevel(
    const LatticeIndex<Dim>& anchor, const LatticeIndex<Dim>& size, MaterialIndex material) const
  {
    if (this->RegionBalanceLevel)
    {
      double centre[Dim];
      for (int axis = 0; axis < Dim; ++axis)
      {
        centre[axis] = anchor[axis] + 0.5 * size[axis];
      }
      const int regional = this->RegionBalanceLevel(centre);
      if (regional > 0)
      {
        return regional;
      }
    }
    if (material < this->MaterialBalanceLevels.size() && this->MaterialBalanceLevels[material] > 0)
    {
      return this->MaterialBalanceLevels[material];
    }
    return this->BalanceLevel;
  }

  bool HasLocalLevels() const
  {
    return static_cast<bool>(this->RegionBalanceLevel) ||
      std::any_of(this->MaterialBalanceLevels.begin(), this->MaterialBalanceLevels.end(),
        [](int level) { return level > 0; });
  }

  /// The smallest balance level any leaf can have (regions aside).
  int SmallestLevel() const
  {
    int smallest = this->BalanceLevel;
    for (int level : this->MaterialBalanceLevels)
    {
      smallest = level > 0 ? std::min(smallest, level) : smallest;
    }
    return this->RegionBalanceLevel ? 1 : smallest;
  }
};

template <int Dim>
class SpacetreeBalancer
{
  /// A cell that must lie in a leaf fine enough for a neighbour of the given level and local
  /// balance level.
  struct Request
  {
    LatticeIndex<Dim> Sample;
    int Level;
    int LocalLevel;
  };

  /// Finds, for the leaves of one level, the neighbouring cells that lie in too coarse a leaf.
  struct ScanKernel
  {
    using Scratch = NoScratch;
    const LevelMap<Dim>* Map;
    const SpacetreeBalanceOptions* Options;
    const std::vector<LatticeIndex<Dim>>* Leaves;
    const std::vector<LatticeIndex<Dim>>* Directions;
    int Level;
    bool LocalLevels;
    /// (first leaf of the range, requests found), one entry per range.
    mutable std::vector<std::pair<std::int64_t, std::vector<Request>>> Found;
    mutable std::mutex FoundLock;

    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      std::vector<Request> found;
      for (std::int64_t i = begin; i < end; ++i)
      {
        const LatticeIndex<Dim>& anchor = (*this->Leaves)[i];
        if (this->Map->LevelAt(anchor) != this->Level)
        {
          continue; // split since it was queued
        }
        const int leafLevel = this->LocalLevels
          ? this->Options->template LocalLevel<Dim>(
              anchor, this->Map->CellSize(this->Level), this->Map->MaterialAt(anchor))
          : this->Options->BalanceLevel;
        const LatticeIndex<Dim> size = this->Map->CellSize(this->Level);
        for (const auto& direction : *this->Directions)
        {
          LatticeIndex<Dim> sample;
          bool inside = true;
          for (int axis = 0; axis < Dim; ++axis)
          {
            sample[axis] = direction[axis] < 0 ? anchor[axis] - 1
              : direction[axis] > 0            ? anchor[axis] + size[axis]
                                               : anchor[axis];
            inside = inside && sample[axis] >= 0 && sample[axis] < this->Map->GetDimensions()[axis];
          }
          if (inside &&
            IsTooCoarse(
              *this->Map, *this->Options, this->LocalLevels, sample, this->Level, leafLevel))
          {
            found.push_back(Request{ sample, this->Level, leafLevel });
          }
        }
      }
      if (!found.empty())
      {
        std::lock_guard<std::mutex> lock(this->FoundLock);
        this->Found.emplace_back(begin, std::move(found));
      }
    }

    /// The requests found, in leaf order whatever the order in which the ranges ran.
    std::vector<Request> TakeFound() const
    {
      std::sort(this->Found.begin(), this->Found.end(),
        [](const auto& x, const auto& y) { return x.first < y.first; });
      std::vector<Request> all;
      for (auto& range : this->Found)
      {
        all.insert(all.end(), range.second.begin(), range.second.end());
      }
      this->Found.clear();
      return all;
    }
  };

  /// Whether the leaf containing the sample cell is too coarse next to a leaf of the given level
  /// and local balance level.
  static bool IsTooCoarse(const LevelMap<Dim>& map, const SpacetreeBalanceOptions& options,
    bool localLevels, const LatticeIndex<Dim>& sample, int level, int localLevel)
  {
    const int neighborLevel = map.LevelAt(sample);
    if (neighborLevel >= level - 1)
    {
      return false; // the common case: every balance level is at least 1
    }
    if (!localLevels)
    {
      return neighborLevel < level - localLevel;
    }
    const int neighborLocal = options.LocalLevel<Dim>(
      map.AnchorOf(sample, neighborLevel), map.CellSize(neighborLevel), map.MaterialAt(sample));
    return neighborLevel < level - std::min(localLevel, neighborLocal);
  }

public:
  template <class Executor>
  Status Balance(Spacetree<Dim>& tree, const SpacetreeBalanceOptions& options, Executor& executor)
  {
    if (options.BalanceLevel < 1)
    {
      return Status::Invalid(
        "BalanceLevel must be at least 1, got " + std::to_string(options.BalanceLevel));
    }
    for (int level : options.MaterialBalanceLevels)
    {
      if (level < 0)
      {
        return Status::Invalid("material balance levels must be at least 1 (or 0 for the default)");
      }
    }
    LevelMap<Dim> map;
    Status status = map.Build(tree, executor);
    if (!status.IsOk())
    {
      return status;
    }
    // Building the map is about a third of the run on the AAL atlas.
    if (executor.ShouldAbort())
    {
      return Status::Aborted();
    }
    executor.ReportProgress(0.3);

    std::vector<std::vector<LatticeIndex<Dim>>> leavesByLevel = tree.AnchorsByLevel();
    const auto directions = NeighborDirections<Dim>(options.FaceBalanceOnly);
    const int smallest = options.SmallestLevel();
    const bool localLevels = options.HasLocalLevels();

    // Progress follows the leaves scanned, not the levels: the finest levels (thin parts, one
    // voxel) may hold few leaves and the coarser ones most. Leaves added by splits are scanned
    // too, so the fraction is clamped.
    const double leavesToScan =
      static_cast<double>(std::max<std::int64_t>(1, tree.GetNumberOfLeaves()));
    double leavesScanned = 0.0;
    for (int level = tree.MaxLevel; level > smallest; --level)
    {
      if (executor.ShouldAbort())
      {
        return Status::Aborted();
      }
      executor.ReportProgress(0.3 + 0.6 * std::min(1.0, leavesScanned / leavesToScan));
      leavesScanned += static_cast<double>(leavesByLevel[level].size());
      // The scan reads the map only; the splits it asks for are applied afterwards. Splitting is
      // idempotent ("until the sample cell is fine enough"), so the result does not depend on
      // the order of the requests, nor on the number of threads.
      auto& leaves = leavesByLevel[level];
      ScanKernel scan{ &map, &options, &leaves, &directions, level, localLevels, {}, {} };
      executor.For(0, static_cast<std::int64_t>(leaves.size()), 4096, scan);
      const std::vector<Request> requests = scan.TakeFound();
      for (const Request& request : requests)
      {
        while (
          IsTooCoarse(map, options, localLevels, request.Sample, request.Level, request.LocalLevel))
        {
          const int neighborLevel = map.LevelAt(request.Sample);
          const LatticeIndex<Dim> neighborAnchor = map.AnchorOf(request.Sample, neighborLevel);
          map.Split(neighborAnchor, neighborLevel);
          tree.ForEachChild(neighborAnchor, neighborLevel,
            [&](const LatticeIndex<Dim>& child)
            { leavesByLevel[neighborLevel + 1].push_back(child); });
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
    tree.BalanceLevel = options.BalanceLevel;
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
    ForEachAdjacentCell<Dim>(tree, leaf, directions,
      [&](const LatticeIndex<Dim>& cell)
      {
        const int difference = map.LevelAt(cell) - level;
        worst = std::max(worst, difference < 0 ? -difference : difference);
      });
  }
  return worst;
}

/// The number of (leaf, adjacent lattice cell) pairs whose level difference exceeds the smaller
/// of the two leaves' local balance levels; 0 for a balanced tree.
template <int Dim, class Executor>
std::int64_t CountBalanceViolations(
  const Spacetree<Dim>& tree, const SpacetreeBalanceOptions& options, Executor& executor)
{
  LevelMap<Dim> map;
  if (!map.Build(tree, executor).IsOk())
  {
    return -1;
  }
  const auto directions = NeighborDirections<Dim>(options.FaceBalanceOnly);
  std::int64_t violations = 0;
  for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
  {
    const int level = tree.LeafLevels[leaf];
    const int local = options.LocalLevel<Dim>(
      tree.LeafAnchors[leaf], tree.GetCellSize(level), tree.LeafMaterials[leaf]);
    ForEachAdjacentCell<Dim>(tree, leaf, directions,
      [&](const LatticeIndex<Dim>& cell)
      {
        const int neighborLevel = map.LevelAt(cell);
        const int neighborLocal = options.LocalLevel<Dim>(
          map.AnchorOf(cell, neighborLevel), map.CellSize(neighborLevel), map.MaterialAt(cell));
        violations += level - neighborLevel > std::min(local, neighborLocal);
      });
  }
  return violations;
}

} // namespace stm

#endif
