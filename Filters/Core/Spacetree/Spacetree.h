// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSpacetree_h
#define stmCoreSpacetree_h

// The spacetree S = (I_0, ..., I_k) of the paper (section 2.1), stored as its leaves.
//
// Lattice units: the edge of the finest possible cell, which is one voxel. A leaf at level l
// is a Dim-cube of edge 2^(MaxLevel - l) lattice units whose lower corner (its anchor) is a
// multiple of that edge. Level 0 cells form the root grid I_0, which covers the image and is
// padded with background where the image does not fill it. The leaves partition the root grid,
// so the leaf list alone determines the tree.
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

template <int Dim>
class Spacetree
{
public:
  /// Root cells per axis.
  LatticeIndex<Dim> RootGridDimensions{};
  /// The finest level; root cells have edge 2^MaxLevel lattice units.
  int MaxLevel = 0;
  /// Voxels of the source image per axis; cells beyond it are padding.
  LatticeIndex<Dim> ImageDimensions{};
  /// Label value of each material index; entry 0 is the background label.
  std::vector<std::int64_t> MaterialLabels;
  /// Largest level difference between adjacent leaves that the tree is known to satisfy;
  /// negative when the tree has not been balanced.
  int BalanceLevel = -1;
  bool FaceBalanceOnly = false;

  // The leaves, structure of arrays, in canonical order: root cells in linear order, and
  // inside each root cell depth first with children in linear order (a Morton order).
  std::vector<std::uint8_t> LeafLevels;
  std::vector<LatticeIndex<Dim>> LeafAnchors;
  std::vector<MaterialIndex> LeafMaterials;

  std::int64_t GetNumberOfLeaves() const
  {
    return static_cast<std::int64_t>(this->LeafLevels.size());
  }

  std::int64_t GetRootCellSize() const { return std::int64_t{ 1 } << this->MaxLevel; }

  std::int64_t GetCellSize(int level) const
  {
    return std::int64_t{ 1 } << (this->MaxLevel - level);
  }

  /// Lattice cells per axis covered by the root grid.
  LatticeIndex<Dim> GetLatticeDimensions() const
  {
    LatticeIndex<Dim> dims;
    for (int axis = 0; axis < Dim; ++axis)
    {
      dims[axis] = this->RootGridDimensions[axis] * this->GetRootCellSize();
    }
    return dims;
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
};

} // namespace stm

#endif
