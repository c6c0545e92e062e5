// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSpacetreeGrading_h
#define stmCoreSpacetreeGrading_h

// Grading, a size criterion: a leaf may be at most G times larger than the finest leaf within its
// own size. Size is a cell's longest physical edge; "within its own size" means within that many
// lattice units of the leaf along every axis. Unlike balancing, which only looks at adjacent
// leaves, grading bounds how fast the cell size may grow with the distance from fine features.
//
// A leaf F forces every leaf L with size(L) > G size(F) that lies within size(L) of F to split.
// For each such level l, the leaves of level <= l that meet F's neighbourhood of radius
// CellSize(l) are split until they are finer than l. Leaves are visited from fine to coarse;
// the leaves a split creates are coarser than F or as fine, so they are visited later.

#include "../Common/CubeInfo.h"
#include "../Common/Execution.h"
#include "../Common/Status.h"
#include "../Spacetree/LevelMap.h"
#include "../Spacetree/Spacetree.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace stm
{

template <int Dim>
class SpacetreeGrader
{
public:
  /// latticeSpacing: the physical edge of one lattice unit per axis.
  template <class Executor>
  Status Grade(Spacetree<Dim>& tree, double grading, const std::array<double, Dim>& latticeSpacing,
    Executor& executor)
  {
    if (!(grading >= 1.5) || !std::isfinite(grading))
    {
      return Status::Invalid("the grading factor must be at least 1.5");
    }
    std::vector<double> edges(tree.MaxLevel + 1, 0.0);
    for (int level = 0; level <= tree.MaxLevel; ++level)
    {
      for (int axis = 0; axis < Dim; ++axis)
      {
        edges[level] = std::max(edges[level], tree.GetCellSize(level)[axis] * latticeSpacing[axis]);
      }
    }
    LevelMap<Dim> map;
    Status status = map.Build(tree, executor);
    if (!status.IsOk())
    {
      return status;
    }
    std::vector<std::vector<LatticeIndex<Dim>>> leavesByLevel = tree.AnchorsByLevel();
    const LatticeIndex<Dim>& dims = map.GetDimensions();
    for (int level = tree.MaxLevel; level > 0; --level)
    {
      if (executor.ShouldAbort())
      {
        return Status::Aborted();
      }
      executor.ReportProgress(0.1 + 0.8 * (tree.MaxLevel - level) / tree.MaxLevel);
      // The coarsest level whose leaves are still small enough next to a leaf of this level.
      int coarsestAllowed = level;
      while (
        coarsestAllowed > 0 && edges[coarsestAllowed - 1] <= grading * edges[level] * (1 + 1e-9))
      {
        --coarsestAllowed;
      }
      if (coarsestAllowed == 0)
      {
        continue;
      }
      auto& leaves = leavesByLevel[level];
      // Index loop: splits may append leaves of this very level.
      for (std::size_t i = 0; i < leaves.size(); ++i)
      {
        const LatticeIndex<Dim> anchor = leaves[i];
        if (map.LevelAt(anchor) != level)
        {
          continue;
        }
        for (int coarse = coarsestAllowed - 1; coarse >= 0; --coarse)
        {
          this->RefineAround(tree, map, dims, anchor, level, coarse, leavesByLevel);
        }
      }
      leaves.clear();
      leaves.shrink_to_fit();
    }
    status = map.CollectLeaves(tree, executor);
    executor.ReportProgress(1.0);
    return status;
  }

private:
  /// Splits the leaves of level <= coarse that meet the neighbourhood of radius CellSize(coarse)
  /// of the leaf (level, anchor) until they are finer than coarse.
  void RefineAround(Spacetree<Dim>& tree, LevelMap<Dim>& map, const LatticeIndex<Dim>& dims,
    const LatticeIndex<Dim>& anchor, int level, int coarse,
    std::vector<std::vector<LatticeIndex<Dim>>>& leavesByLevel)
  {
    const LatticeIndex<Dim>& radius = tree.GetCellSize(coarse);
    const LatticeIndex<Dim> size = tree.GetCellSize(level);
    LatticeIndex<Dim> lo, hi;
    for (int axis = 0; axis < Dim; ++axis)
    {
      lo[axis] = std::max<std::int64_t>(0, anchor[axis] - radius[axis]);
      hi[axis] = std::min<std::int64_t>(dims[axis], anchor[axis] + size[axis] + radius[axis]);
    }
    // One sample per level-`coarse` grid cell that meets the box: a leaf of level <= coarse
    // covers the whole grid cell.
    LatticeIndex<Dim> first;
    for (int axis = 0; axis < Dim; ++axis)
    {
      first[axis] = lo[axis] - lo[axis] % radius[axis];
    }
    ForEachLatticePoint<Dim>(first, hi, radius,
      [&](const LatticeIndex<Dim>& cell)
      {
        LatticeIndex<Dim> sample;
        for (int axis = 0; axis < Dim; ++axis)
        {
          sample[axis] = std::max(cell[axis], lo[axis]);
        }
        for (int sampleLevel = map.LevelAt(sample); sampleLevel <= coarse;
             sampleLevel = map.LevelAt(sample))
        {
          const LatticeIndex<Dim> leafAnchor = map.AnchorOf(sample, sampleLevel);
          map.Split(leafAnchor, sampleLevel);
          tree.ForEachChild(leafAnchor, sampleLevel,
            [&](const LatticeIndex<Dim>& child)
            { leavesByLevel[sampleLevel + 1].push_back(child); });
        }
      });
  }
};

/// Whether every leaf is at most `grading` times larger than the finest leaf within its own size
/// (the grading criterion's post-condition), by brute force over leaf pairs; for tests.
template <int Dim>
bool IsGraded(
  const Spacetree<Dim>& tree, double grading, const std::array<double, Dim>& latticeSpacing)
{
  auto edge = [&](int level)
  {
    double largest = 0;
    for (int axis = 0; axis < Dim; ++axis)
    {
      largest = std::max(largest, tree.GetCellSize(level)[axis] * latticeSpacing[axis]);
    }
    return largest;
  };
  for (std::int64_t big = 0; big < tree.GetNumberOfLeaves(); ++big)
  {
    const int bigLevel = tree.LeafLevels[big];
    const LatticeIndex<Dim>& bigSize = tree.GetCellSize(bigLevel);
    for (std::int64_t small = 0; small < tree.GetNumberOfLeaves(); ++small)
    {
      const int smallLevel = tree.LeafLevels[small];
      if (edge(bigLevel) <= grading * edge(smallLevel) * (1 + 1e-9))
      {
        continue;
      }
      bool near = true;
      for (int axis = 0; axis < Dim && near; ++axis)
      {
        const std::int64_t gapLow =
          tree.LeafAnchors[small][axis] - (tree.LeafAnchors[big][axis] + bigSize[axis]);
        const std::int64_t gapHigh = tree.LeafAnchors[big][axis] -
          (tree.LeafAnchors[small][axis] + tree.GetCellSize(smallLevel)[axis]);
        near = std::max(gapLow, gapHigh) < bigSize[axis];
      }
      if (near)
      {
        return false;
      }
    }
  }
  return true;
}

} // namespace stm

#endif
