// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreRootPieces_h
#define stmCoreRootPieces_h

// Pieces of a spacetree's root grid, for meshing an image piece by piece (pvbatch and pvserver
// under MPI, streaming).
//
// A piece owns a box of root cells. It is meshed from the voxels of its box grown by one root
// cell on every side (its ghost box), and keeps the cells of its own leaves. The build, the
// balance and the tessellation of a leaf depend only on the leaves within one root cell of it:
// the balance's ripple from a leaf of level l reaches cells of level l - k at most
// sum_k (root edge / 2^k) < one root edge away (a third of that for 3^d patterns), so the leaves
// of the owned box, and the cells made of them, are those of the whole image's tree. Two
// adjacent pieces therefore share their boundary's points and facets exactly, and the pieces
// together are the whole image's mesh.
//
// The ghost box's lower corner is rounded down to an even root index: a cell's parity at every
// level (which the checkerboard template follows) is then the same in the piece as in the whole
// grid, also for patterns with odd split counts.

#include "../Common/CubeInfo.h"

#include <algorithm>
#include <cstdint>

namespace stm
{

/// A box [Lower, Upper) of root cells.
template <int Dim>
struct RootBox
{
  LatticeIndex<Dim> Lower{};
  LatticeIndex<Dim> Upper{};

  bool IsEmpty() const
  {
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (this->Upper[axis] <= this->Lower[axis])
      {
        return true;
      }
    }
    return false;
  }

  std::int64_t GetNumberOfCells() const
  {
    std::int64_t cells = 1;
    for (int axis = 0; axis < Dim; ++axis)
    {
      cells *= std::max<std::int64_t>(0, this->Upper[axis] - this->Lower[axis]);
    }
    return cells;
  }

  bool Contains(const LatticeIndex<Dim>& root) const
  {
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (root[axis] < this->Lower[axis] || root[axis] >= this->Upper[axis])
      {
        return false;
      }
    }
    return true;
  }
};

/// Piece `piece` of `pieces` (0 <= piece < pieces) of a root grid: the grid is bisected
/// recursively, each time across the middle of its longest axis (the lowest of equal ones), and
/// the pieces are shared between the halves in proportion to their cells, so the boxes
/// partition the grid. While there are no more pieces than root cells every box gets cells;
/// beyond, min(pieces, cells) boxes get one cell each and the others are empty.
template <int Dim>
RootBox<Dim> PieceRootBox(const LatticeIndex<Dim>& rootGridDimensions, int pieces, int piece)
{
  RootBox<Dim> box;
  box.Upper = rootGridDimensions;
  if (pieces < 1 || piece < 0 || piece >= pieces || box.IsEmpty())
  {
    box.Upper = box.Lower;
    return box;
  }
  std::int64_t first = 0; // the box holds pieces [first, first + count)
  std::int64_t count = pieces;
  while (count > 1)
  {
    int axis = 0;
    for (int a = 1; a < Dim; ++a)
    {
      if (box.Upper[a] - box.Lower[a] > box.Upper[axis] - box.Lower[axis])
      {
        axis = a;
      }
    }
    const std::int64_t length = box.Upper[axis] - box.Lower[axis];
    if (length < 2)
    {
      // One root cell: the first piece of the range gets it.
      if (piece != first)
      {
        box.Upper = box.Lower;
      }
      return box;
    }
    const std::int64_t layer = box.GetNumberOfCells() / length;
    const std::int64_t cut = box.Lower[axis] + length / 2;
    const std::int64_t lowerCells = layer * (cut - box.Lower[axis]);
    const std::int64_t upperCells = layer * (box.Upper[axis] - cut);
    const std::int64_t cells = lowerCells + upperCells;
    // Every piece of a side gets a cell while the side has enough; else every cell a piece.
    const std::int64_t least =
      count <= cells ? std::max<std::int64_t>(1, count - upperCells) : lowerCells;
    const std::int64_t most =
      count <= cells ? std::min<std::int64_t>(count - 1, lowerCells) : count - upperCells;
    const std::int64_t lowerCount =
      std::clamp<std::int64_t>((count * lowerCells + cells / 2) / cells, least, most);
    if (piece < first + lowerCount)
    {
      box.Upper[axis] = cut;
      count = lowerCount;
    }
    else
    {
      box.Lower[axis] = cut;
      first += lowerCount;
      count -= lowerCount;
    }
  }
  return box;
}

/// The root cells a piece is meshed from: `owned` grown by `ghostCells` on every side, its
/// lower corner rounded down to an even index, clipped to the grid. Empty for an empty box.
template <int Dim>
RootBox<Dim> GhostRootBox(
  const RootBox<Dim>& owned, const LatticeIndex<Dim>& rootGridDimensions, int ghostCells = 1)
{
  if (owned.IsEmpty())
  {
    return owned;
  }
  RootBox<Dim> box;
  for (int axis = 0; axis < Dim; ++axis)
  {
    const std::int64_t lower = std::max<std::int64_t>(0, owned.Lower[axis] - ghostCells);
    box.Lower[axis] = lower - lower % 2;
    box.Upper[axis] = std::min(rootGridDimensions[axis], owned.Upper[axis] + ghostCells);
  }
  return box;
}

} // namespace stm

#endif
