// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreRootPieces_h
#define stmCoreRootPieces_h

// Pieces of a spacetree's root grid, for meshing an image piece by piece (pvbatch and pvserver
// under MPI, streaming).
//
// A piece owns a box of root cells. It is meshed from the voxels of its box grown by two root
// cells on every side (its ghost box), and keeps the cells of its own leaves. An owned leaf's
// cells depend on its own leaf and on the leaves adjacent to it (the hanging points on its
// facets), so the ghost leaves next to the owned box must be the whole tree's too. The leaves
// beyond the ghost box can change those of the ghost box's outer layer: a fine leaf just beyond
// it makes the balance split the root leaf next to it, whose halves put a hanging point on the
// facet of the next root cell (the core test FineLeavesBeyondTheGhostLayer builds that case;
// with one layer of ghosts the piece misses that point). They cannot reach the inner layer: the
// leaves of level k > 0 that a ripple from a root face makes lie within sum_{j >= k}
// (root edge / 2^j) < root edge / 2^(k-1) of it, so only leaves of level 1 reach the outer
// layer's far side, and level 1 next to level 0 splits nothing for any L >= 1. So the leaves of
// the owned box and of the inner ghost layer, and the cells of the owned box, are those of the
// whole image's tree. Two adjacent pieces therefore share their boundary's points and facets
// exactly, and the pieces together are the whole image's mesh.
//
// The ghost box's lower corner is rounded down to an even root index: a cell's parity at every
// level (which the checkerboard template follows) is then the same in the piece as in the whole
// grid, also for patterns with odd split counts.

#include "../Common/CubeInfo.h"
#include "../Common/Execution.h"
#include "SpacetreeBuild.h"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace stm
{

/// Layers of ghost root cells around a piece's box (see the top of this file), at least.
constexpr int GhostRootLayers = 2;

/// The voxels of ghost cells a piece's mesh keeps beyond its box, at least: the cuts' snapping
/// decides a point from its neighbours' decisions, in rounds, and without an exchange between
/// the pieces the whole mesh's decisions reach a piece's own points only through the cells the
/// piece has. With one kept layer of root cells of 4 or 6 voxels, stmMultiMaterialCut's pieces
/// of the nested ellipsoids (3 and 4 pieces) snapped other points than the whole mesh; with 8
/// voxels and more they did not. The snaps now exchange (three rings suffice then), but pieces
/// that cannot exchange (a rank without ghost cells) still rely on this margin. The default
/// root cells (16 voxels) keep one layer, as before.
constexpr std::int64_t MinimumKeptGhostVoxels = 16;

/// Layers of ghost root cells for root cells of `rootVoxels` voxels per axis: the outer layer,
/// which completes the inner ones' leaves and gives no cells, and as many inner layers as
/// MinimumKeptGhostVoxels needs (one at least).
template <int Dim>
int GhostRootLayersFor(const LatticeIndex<Dim>& rootVoxels)
{
  std::int64_t smallest = MinimumKeptGhostVoxels;
  for (int axis = 0; axis < Dim; ++axis)
  {
    smallest = std::min(smallest, std::max<std::int64_t>(1, rootVoxels[axis]));
  }
  const std::int64_t inner = (MinimumKeptGhostVoxels + smallest - 1) / smallest;
  return static_cast<int>(1 + std::max<std::int64_t>(GhostRootLayers - 1, inner));
}

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

  /// The box grown by `layers` root cells on every side (not clipped).
  RootBox Grown(std::int64_t layers) const
  {
    RootBox grown = *this;
    for (int axis = 0; axis < Dim; ++axis)
    {
      grown.Lower[axis] -= layers;
      grown.Upper[axis] += layers;
    }
    return grown;
  }
};

/// Root cells coloured by their indices modulo 3 along each axis: colour = sum over the axes of
/// (index mod 3) * 3^axis, 3^Dim colours. The closures of two root cells of one colour share no
/// point (their indices differ by 3 or more along some axis), and every root cell whose closure
/// holds a given point has a colour of its own (at most two indices per axis). The smoothing
/// orders its moves by these colours (BoundarySmoothOptions::CellRootColours), so the colours
/// must be those of the whole root grid also in a piece: `root` is a root cell's index in the
/// whole grid.
template <int Dim>
struct RootColouring
{
  static constexpr int NumberOfColours = Dim == 1 ? 3 : Dim == 2 ? 9 : Dim == 3 ? 27 : 81;
  static_assert(Dim >= 1 && Dim <= 4, "root colours fit a byte for dimensions 1 to 4");

  static std::uint8_t Colour(const LatticeIndex<Dim>& root)
  {
    int colour = 0;
    for (int axis = Dim - 1; axis >= 0; --axis)
    {
      colour = 3 * colour + static_cast<int>(((root[axis] % 3) + 3) % 3);
    }
    return static_cast<std::uint8_t>(colour);
  }

  /// The colour of the root cell of leaf `leaf` of `tree`, whose root index 0 is root
  /// `rootOffset` of the whole grid (a piece's ghost box; zeros for a whole image).
  static std::uint8_t LeafColour(
    const Spacetree<Dim>& tree, std::int64_t leaf, const LatticeIndex<Dim>& rootOffset)
  {
    LatticeIndex<Dim> root;
    for (int axis = 0; axis < Dim; ++axis)
    {
      root[axis] = rootOffset[axis] + tree.LeafAnchors[leaf][axis] / tree.GetRootCellSize()[axis];
    }
    return Colour(root);
  }
};

/// Whether leaf `leaf` of `tree` lies in the root cells of `box` (in the tree's root indices).
template <int Dim>
bool LeafInRootBox(const Spacetree<Dim>& tree, std::int64_t leaf, const RootBox<Dim>& box)
{
  LatticeIndex<Dim> root;
  for (int axis = 0; axis < Dim; ++axis)
  {
    root[axis] = tree.LeafAnchors[leaf][axis] / tree.GetRootCellSize()[axis];
  }
  return box.Contains(root);
}

/// One step of a bisection: `box`, holding pieces [first, first + count), is cut at `cut` across
/// `axis`, the lower side holding lowerCount of them; keeps the side that holds `piece`.
template <int Dim>
void KeepSideOfPiece(std::int64_t piece, int axis, std::int64_t cut, std::int64_t lowerCount,
  RootBox<Dim>& box, std::int64_t& first, std::int64_t& count)
{
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
    KeepSideOfPiece<Dim>(piece, axis, cut, lowerCount, box, first, count);
  }
  return box;
}

/// An estimate, from the image alone, of the mesh cells each root cell of `rootGridDimensions`
/// (root cell r covers voxels [r * rootVoxels, (r + 1) * rootVoxels)) ends up with, first axis
/// fastest: BoundaryVoxelCost per voxel whose material differs from the next voxel's along an
/// axis (the tree refines to voxels there), plus BodyVoxelCost per voxel of a material other
/// than the background. On the AAL brain mask a least-squares fit of the cells per root cell
/// gave 15 and 2.7 at 1 mm, 18 and 0.4 at 0.5 mm: boundary voxels carry the cost, and one
/// cell per body voxel is their mean. Rows of voxels run in parallel; the sums are integers, so
/// the estimate does not depend on the number of threads.
constexpr std::int64_t BoundaryVoxelCost = 16;
constexpr std::int64_t BodyVoxelCost = 1;

/// RootCellCosts of the root-cell layers [firstLayer, endLayer) along the last axis only, from a
/// slab of the image: its voxels from the first voxel of layer firstLayer on, of which those
/// past the layers (one row more, where the image goes on) only serve as the next voxels of the
/// last row. The costs are of the whole root grid, zero outside the layers, so that slabs that
/// share out the layers add up to the whole image's RootCellCosts: the processes that mesh
/// pieces of an image they read in parts balance them by cost without reading it whole. All
/// zero where the slab does not fit the layers (no cost: PieceRootBox without costs).
template <int Dim, class Executor>
std::vector<std::int64_t> RootCellCostsOfLayers(const MaterialImage<Dim>& slab,
  std::int64_t firstLayer, std::int64_t endLayer, const LatticeIndex<Dim>& rootVoxels,
  const LatticeIndex<Dim>& rootGridDimensions, Executor& executor)
{
  static_assert(Dim >= 2, "rows of voxels need a second axis");
  constexpr int last = Dim - 1;
  const LatticeIndex<Dim>& size = slab.Dimensions;
  std::vector<std::int64_t> costs(
    static_cast<std::size_t>(NumberOfLatticeCells<Dim>(rootGridDimensions)), 0);
  if (NumberOfLatticeCells<Dim>(size) <= 0 || costs.empty() || firstLayer < 0 ||
    endLayer > rootGridDimensions[last] || firstLayer >= endLayer)
  {
    return costs;
  }
  for (int axis = 0; axis < Dim; ++axis)
  {
    // The slab covers its layers' rows and at most one row more along the last axis.
    const std::int64_t spanned = axis == last ? (endLayer - firstLayer) * rootVoxels[axis] + 1
                                              : rootGridDimensions[axis] * rootVoxels[axis];
    if (rootVoxels[axis] < 1 || spanned < size[axis])
    {
      return costs;
    }
  }
  // One task per layer of root cells along the last axis: a task writes only its own layer's
  // costs.
  struct Kernel
  {
    using Scratch = NoScratch;
    const MaterialImage<Dim>* Image;
    LatticeIndex<Dim> RootVoxels;
    LatticeIndex<Dim> RootDims;
    std::int64_t FirstLayer;
    std::int64_t CountedRows; // along the last axis; a row more is only looked at
    std::int64_t* Costs;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      const LatticeIndex<Dim>& dims = this->Image->Dimensions;
      LatticeIndex<Dim> rowDims = dims; // the rows of voxels: every axis but the first
      rowDims[0] = 1;
      LatticeIndex<Dim> strides{};
      strides[0] = 1;
      for (int axis = 1; axis < Dim; ++axis)
      {
        strides[axis] = strides[axis - 1] * dims[axis - 1];
      }
      for (std::int64_t layer = begin; layer < end; ++layer)
      {
        LatticeIndex<Dim> rowLower{};
        LatticeIndex<Dim> rowUpper = rowDims;
        rowLower[last] = std::min(this->CountedRows, layer * this->RootVoxels[last]);
        rowUpper[last] = std::min(this->CountedRows, (layer + 1) * this->RootVoxels[last]);
        ForEachLatticePoint<Dim>(rowLower, rowUpper,
          [&](const LatticeIndex<Dim>& row)
          {
            const MaterialIndex* values = this->Image->Values + LinearIndex<Dim>(row, dims);
            LatticeIndex<Dim> root{};
            bool atEnd[Dim] = {};
            for (int axis = 1; axis < Dim; ++axis)
            {
              root[axis] = row[axis] / this->RootVoxels[axis];
              atEnd[axis] = row[axis] + 1 >= dims[axis];
            }
            root[last] += this->FirstLayer;
            for (std::int64_t x = 0; x < dims[0]; ++x)
            {
              const MaterialIndex material = values[x];
              bool boundary = x + 1 < dims[0] && values[x + 1] != material;
              for (int axis = 1; axis < Dim && !boundary; ++axis)
              {
                boundary = !atEnd[axis] && values[x + strides[axis]] != material;
              }
              const std::int64_t cost = (boundary ? BoundaryVoxelCost : 0) +
                (material != BackgroundMaterial ? BodyVoxelCost : 0);
              if (cost != 0)
              {
                root[0] = x / this->RootVoxels[0];
                this->Costs[LinearIndex<Dim>(root, this->RootDims)] += cost;
              }
            }
          });
      }
    }
  };
  const std::int64_t countedRows = std::min(size[last], (endLayer - firstLayer) * rootVoxels[last]);
  Kernel kernel{ &slab, rootVoxels, rootGridDimensions, firstLayer, countedRows, costs.data() };
  // Layers are counted from the slab's first one inside the kernel.
  executor.For(0, endLayer - firstLayer, 1, kernel);
  return costs;
}

template <int Dim, class Executor>
std::vector<std::int64_t> RootCellCosts(const MaterialImage<Dim>& image,
  const LatticeIndex<Dim>& rootVoxels, const LatticeIndex<Dim>& rootGridDimensions,
  Executor& executor)
{
  return RootCellCostsOfLayers<Dim>(
    image, 0, rootGridDimensions[Dim - 1], rootVoxels, rootGridDimensions, executor);
}

/// The root cells a piece is meshed from: `owned` grown by `ghostCells` on every side, its
/// lower corner rounded down to an even index, clipped to the grid. Empty for an empty box.
template <int Dim>
RootBox<Dim> GhostRootBox(const RootBox<Dim>& owned, const LatticeIndex<Dim>& rootGridDimensions,
  int ghostCells = GhostRootLayers)
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

/// A side's cost per piece, the fraction Cost / Pieces, compared exactly.
struct CostShare
{
  std::int64_t Cost = 0;
  std::int64_t Pieces = 1;
  bool operator<(const CostShare& other) const
  {
    return this->Cost * other.Pieces < other.Cost * this->Pieces;
  }
};

/// Piece `piece` of `pieces` of a root grid, the boxes balanced by `rootCellCosts` (per root
/// cell, first axis fastest, as RootCellCosts makes them): the grid is bisected recursively,
/// each time by the plane (any axis, between root cells) and the share of the pieces that
/// make the larger of the two sides' costs per piece smallest; among equal ones, the larger
/// cost per piece with the ghost layers each side is meshed with along the cut axis
/// (GhostRootBox). Balancing the costs with ghosts first would let a piece own nothing but
/// empty root cells next to a costly ghost layer. A side gets at least as many
/// root cells as pieces. With more pieces than root cells, no cost, or costs of the wrong size
/// it is PieceRootBox without costs; which pieces are empty is always the same as there.
template <int Dim>
RootBox<Dim> PieceRootBox(const LatticeIndex<Dim>& rootGridDimensions, int pieces, int piece,
  const std::vector<std::int64_t>& rootCellCosts)
{
  const std::int64_t gridCells = NumberOfLatticeCells<Dim>(rootGridDimensions);
  if (pieces < 1 || piece < 0 || piece >= pieces || gridCells <= 0 || pieces > gridCells ||
    static_cast<std::int64_t>(rootCellCosts.size()) != gridCells)
  {
    return PieceRootBox<Dim>(rootGridDimensions, pieces, piece);
  }
  RootBox<Dim> box;
  box.Upper = rootGridDimensions;
  std::int64_t first = 0; // the box holds pieces [first, first + count)
  std::int64_t count = pieces;
  std::vector<std::int64_t> layerCosts;
  while (count > 1)
  {
    // The best cut: the smallest larger cost per piece, without and then with the ghosts.
    bool found = false;
    int bestAxis = 0;
    std::int64_t bestCut = 0, bestLowerCount = 0;
    CostShare best, bestGhosted;
    const std::int64_t boxCells = box.GetNumberOfCells();
    for (int axis = 0; axis < Dim; ++axis)
    {
      const std::int64_t lower = box.Lower[axis];
      const std::int64_t upper = box.Upper[axis];
      const std::int64_t layerCells = boxCells / (upper - lower);
      // Costs of the layers across the axis, over the box's extent on the other axes, from the
      // ghost layers below and above the box too.
      const RootBox<Dim> boxGhosts = GhostRootBox<Dim>(box, rootGridDimensions);
      const std::int64_t from = boxGhosts.Lower[axis];
      const std::int64_t to = boxGhosts.Upper[axis];
      layerCosts.assign(static_cast<std::size_t>(to - from), 0);
      RootBox<Dim> slab = box;
      slab.Lower[axis] = from;
      slab.Upper[axis] = to;
      ForEachLatticePoint<Dim>(slab.Lower, slab.Upper,
        [&](const LatticeIndex<Dim>& root) {
          layerCosts[root[axis] - from] +=
            rootCellCosts[LinearIndex<Dim>(root, rootGridDimensions)];
        });
      std::vector<std::int64_t> prefix(
        layerCosts.size() + 1, 0); // prefix[i]: layers [from, from + i)
      for (std::size_t i = 0; i < layerCosts.size(); ++i)
      {
        prefix[i + 1] = prefix[i] + layerCosts[i];
      }
      const auto costOf = [&](std::int64_t a, std::int64_t b) // layers [a, b)
      { return prefix[b - from] - prefix[a - from]; };
      for (std::int64_t cut = lower + 1; cut < upper; ++cut)
      {
        RootBox<Dim> lowerSide = box;
        lowerSide.Upper[axis] = cut;
        RootBox<Dim> upperSide = box;
        upperSide.Lower[axis] = cut;
        const RootBox<Dim> lowerGhosts = GhostRootBox<Dim>(lowerSide, rootGridDimensions);
        const RootBox<Dim> upperGhosts = GhostRootBox<Dim>(upperSide, rootGridDimensions);
        const std::int64_t lowerCells = layerCells * (cut - lower);
        const std::int64_t upperCells = layerCells * (upper - cut);
        for (const std::int64_t lowerCount : { count / 2, count - count / 2 })
        {
          const std::int64_t upperCount = count - lowerCount;
          if (lowerCells < lowerCount || upperCells < upperCount)
          {
            continue;
          }
          const CostShare own = std::max(CostShare{ costOf(lower, cut), lowerCount },
            CostShare{ costOf(cut, upper), upperCount });
          const CostShare ghosted = std::max(
            CostShare{ costOf(lowerGhosts.Lower[axis], lowerGhosts.Upper[axis]), lowerCount },
            CostShare{ costOf(upperGhosts.Lower[axis], upperGhosts.Upper[axis]), upperCount });
          if (!found || own < best || (!(best < own) && ghosted < bestGhosted))
          {
            found = true;
            bestAxis = axis;
            bestCut = cut;
            bestLowerCount = lowerCount;
            best = own;
            bestGhosted = ghosted;
          }
        }
      }
    }
    if (!found || best.Cost == 0)
    {
      // No cost to balance here: the halves of the longest axis, as without costs.
      LatticeIndex<Dim> size;
      for (int axis = 0; axis < Dim; ++axis)
      {
        size[axis] = box.Upper[axis] - box.Lower[axis];
      }
      const RootBox<Dim> rest =
        PieceRootBox<Dim>(size, static_cast<int>(count), static_cast<int>(piece - first));
      for (int axis = 0; axis < Dim; ++axis)
      {
        box.Upper[axis] = box.Lower[axis] + rest.Upper[axis];
        box.Lower[axis] += rest.Lower[axis];
      }
      return box;
    }
    KeepSideOfPiece<Dim>(piece, bestAxis, bestCut, bestLowerCount, box, first, count);
  }
  return box;
}

} // namespace stm

#endif
