// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSpacetree_h
#define stmCoreSpacetree_h

// The spacetree S = (I_0, ..., I_k) of the paper (section 2.1), stored as its leaves.
//
// Lattice units: the edge of the finest possible cell along each axis. A voxel spans
// VoxelSubdivision[axis] lattice units (1 unless cells are refined below the voxel). A cell of
// level l spans CellSizes[l][axis] lattice units along each axis; every level's edges divide
// the coarser level's, so a cell of level l splits into CellSizes[l] / CellSizes[l + 1]
// children per axis (the refinement pattern of that level: 2^d, 3^d, 2x2x1, ...). A leaf's
// lower corner (its anchor) is a multiple of its edges. Level 0 cells form the root grid I_0,
// which covers the image and is padded with background where the image does not fill it. The
// leaves partition the root grid, so the leaf list and the level table determine the tree.
//
// Materials are small indices into MaterialLabels. Index 0 is the background: every voxel
// outside the body of interest and all padding. Every leaf is homogeneous: all voxels it
// covers have its material.

#include "../Common/CubeInfo.h"

#include <cstdint>
#include <vector>

namespace stm
{

using MaterialIndex = std::uint16_t;
constexpr MaterialIndex BackgroundMaterial = 0;

/// Largest number of levels below the root the lattice arithmetic supports.
constexpr int MaximumSupportedLevel = 20;

/// Largest split count of one axis in one level of a refinement pattern.
constexpr int MaximumSplitCount = 8;

/// Calls visit(childAnchor) for the children (edges childSize) of a box spanning freeAxes, in
/// lattice order.
template <int Dim, class Visitor>
void ForEachChildAnchor(const LatticeIndex<Dim>& anchor, const LatticeIndex<Dim>& size,
  const LatticeIndex<Dim>& childSize, unsigned freeAxes, Visitor&& visit)
{
  LatticeIndex<Dim> upper, step;
  for (int axis = 0; axis < Dim; ++axis)
  {
    const bool free = (freeAxes & (1u << axis)) != 0;
    upper[axis] = anchor[axis] + (free ? size[axis] : 1);
    step[axis] = free ? childSize[axis] : 1;
  }
  ForEachLatticePoint<Dim>(
    anchor, upper, step, [&](const LatticeIndex<Dim>& child) { visit(child); });
}

template <int Dim>
class Spacetree
{
public:
  /// Root cells per axis.
  LatticeIndex<Dim> RootGridDimensions{};
  /// The finest level.
  int MaxLevel = 0;
  /// Edges of the cells of each level in lattice units, levels 0 (root) to MaxLevel.
  std::vector<LatticeIndex<Dim>> CellSizes{ UnitSize() };
  /// Lattice units per voxel along each axis.
  LatticeIndex<Dim> VoxelSubdivision = UnitSize();
  /// Voxels of the source image per axis; cells beyond it are padding.
  LatticeIndex<Dim> ImageDimensions{};
  /// Label value of each material index; entry 0 is the background label.
  std::vector<std::int64_t> MaterialLabels;
  /// Largest level difference between adjacent leaves that the tree is known to satisfy;
  /// negative when the tree has not been balanced.
  int BalanceLevel = -1;
  bool FaceBalanceOnly = false;

  // The leaves, structure of arrays, in canonical order: root cells in linear order, and
  // inside each root cell depth first with children in linear order (axis 0 fastest).
  std::vector<std::uint8_t> LeafLevels;
  std::vector<LatticeIndex<Dim>> LeafAnchors;
  std::vector<MaterialIndex> LeafMaterials;

  static LatticeIndex<Dim> UnitSize()
  {
    LatticeIndex<Dim> unit;
    unit.fill(1);
    return unit;
  }

  /// The level table of 2^Dim refinement with maxLevel levels below the root: a level-l cell
  /// has edge 2^(maxLevel - l) on every axis.
  static std::vector<LatticeIndex<Dim>> UniformCellSizes(int maxLevel)
  {
    std::vector<LatticeIndex<Dim>> sizes(static_cast<std::size_t>(maxLevel) + 1);
    for (int level = 0; level <= maxLevel; ++level)
    {
      sizes[level].fill(std::int64_t{ 1 } << (maxLevel - level));
    }
    return sizes;
  }

  /// Sets the level table to 2^Dim refinement with maxLevel levels at voxel resolution.
  void SetUniformRefinement(int maxLevel)
  {
    this->MaxLevel = maxLevel;
    this->CellSizes = UniformCellSizes(maxLevel);
    this->VoxelSubdivision = UnitSize();
  }

  std::int64_t GetNumberOfLeaves() const
  {
    return static_cast<std::int64_t>(this->LeafLevels.size());
  }

  const LatticeIndex<Dim>& GetCellSize(int level) const { return this->CellSizes[level]; }
  const LatticeIndex<Dim>& GetRootCellSize() const { return this->CellSizes[0]; }

  /// Children per axis of a cell of the given level (< MaxLevel).
  LatticeIndex<Dim> GetSplitCounts(int level) const
  {
    LatticeIndex<Dim> splits;
    for (int axis = 0; axis < Dim; ++axis)
    {
      splits[axis] = this->CellSizes[level][axis] / this->CellSizes[level + 1][axis];
    }
    return splits;
  }

  /// Calls visit(childAnchor) for the children of a cell of the given level, in canonical order.
  template <class Visitor>
  void ForEachChild(const LatticeIndex<Dim>& anchor, int level, Visitor&& visit) const
  {
    VisitChildren(this->CellSizes, anchor, level, visit);
  }

  /// ForEachChild for a bare level table.
  template <class Visitor>
  static void VisitChildren(const std::vector<LatticeIndex<Dim>>& cellSizes,
    const LatticeIndex<Dim>& anchor, int level, Visitor&& visit)
  {
    ForEachChildAnchor<Dim>(anchor, cellSizes[level], cellSizes[level + 1], (1u << Dim) - 1u,
      [&](const LatticeIndex<Dim>& child) { visit(child); });
  }

  /// Lattice cells per axis covered by the root grid.
  LatticeIndex<Dim> GetLatticeDimensions() const
  {
    LatticeIndex<Dim> dims;
    for (int axis = 0; axis < Dim; ++axis)
    {
      dims[axis] = this->RootGridDimensions[axis] * this->CellSizes[0][axis];
    }
    return dims;
  }

  /// Lattice cells covered by a leaf of the given level.
  std::int64_t GetCellVolume(int level) const
  {
    return NumberOfLatticeCells<Dim>(this->CellSizes[level]);
  }

  void ClearLeaves()
  {
    this->LeafLevels.clear();
    this->LeafAnchors.clear();
    this->LeafMaterials.clear();
  }

  void AddLeaf(int level, const LatticeIndex<Dim>& anchor, MaterialIndex material)
  {
    this->LeafLevels.push_back(static_cast<std::uint8_t>(level));
    this->LeafAnchors.push_back(anchor);
    this->LeafMaterials.push_back(material);
  }

  void ReserveLeaves(std::int64_t count)
  {
    this->LeafLevels.reserve(count);
    this->LeafAnchors.reserve(count);
    this->LeafMaterials.reserve(count);
  }

  /// The anchors of the leaves, grouped by level.
  std::vector<std::vector<LatticeIndex<Dim>>> AnchorsByLevel() const
  {
    std::vector<std::vector<LatticeIndex<Dim>>> anchors(
      static_cast<std::size_t>(this->MaxLevel) + 1);
    for (std::size_t leaf = 0; leaf < this->LeafLevels.size(); ++leaf)
    {
      anchors[this->LeafLevels[leaf]].push_back(this->LeafAnchors[leaf]);
    }
    return anchors;
  }

  /// Appends the leaves of another tree with the same level table.
  void AppendLeaves(const Spacetree& other)
  {
    this->LeafLevels.insert(
      this->LeafLevels.end(), other.LeafLevels.begin(), other.LeafLevels.end());
    this->LeafAnchors.insert(
      this->LeafAnchors.end(), other.LeafAnchors.begin(), other.LeafAnchors.end());
    this->LeafMaterials.insert(
      this->LeafMaterials.end(), other.LeafMaterials.begin(), other.LeafMaterials.end());
  }
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

/// Calls visit(cell) for every lattice cell outside a leaf that touches it in one of the given
/// directions (NeighborDirections), within the lattice. A visitor that returns bool stops the
/// walk by returning false; returns false if it was stopped.
template <int Dim, class Visitor>
bool ForEachAdjacentCell(const Spacetree<Dim>& tree, std::int64_t leaf,
  const std::vector<LatticeIndex<Dim>>& directions, Visitor&& visit)
{
  const LatticeIndex<Dim> size = tree.GetCellSize(tree.LeafLevels[leaf]);
  const LatticeIndex<Dim> latticeDims = tree.GetLatticeDimensions();
  const auto& anchor = tree.LeafAnchors[leaf];
  for (const auto& direction : directions)
  {
    LatticeIndex<Dim> lo, hi;
    bool inside = true;
    for (int axis = 0; axis < Dim; ++axis)
    {
      lo[axis] = direction[axis] < 0 ? anchor[axis] - 1
        : direction[axis] > 0        ? anchor[axis] + size[axis]
                                     : anchor[axis];
      hi[axis] = direction[axis] == 0 ? anchor[axis] + size[axis] : lo[axis] + 1;
      inside = inside && lo[axis] >= 0 && hi[axis] <= latticeDims[axis];
    }
    if (inside && !ForEachLatticePoint<Dim>(lo, hi, visit))
    {
      return false;
    }
  }
  return true;
}

} // namespace stm

#endif
