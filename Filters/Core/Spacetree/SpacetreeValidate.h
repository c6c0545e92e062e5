// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSpacetreeValidate_h
#define stmCoreSpacetreeValidate_h

// Validation of a spacetree that comes from outside the core (a file, another program): the
// algorithms assume its leaves partition the root grid, and would produce a broken mesh
// otherwise.

#include "../Common/CubeInfo.h"
#include "../Common/Status.h"
#include "Spacetree.h"

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace stm
{

namespace detail
{
/// Whether any of `count` bytes is non-zero, eight at a time.
inline bool AnyNonZeroByte(const std::uint8_t* bytes, std::int64_t count)
{
  std::uint64_t any = 0;
  std::int64_t i = 0;
  for (; i + 8 <= count; i += 8)
  {
    std::uint64_t word;
    std::memcpy(&word, bytes + i, 8);
    any |= word;
  }
  for (; i < count; ++i)
  {
    any |= bytes[i];
  }
  return any != 0;
}

/// Whether any of `count` bytes, each 0 or 1, is 0, eight at a time.
inline bool AnyZeroFlag(const std::uint8_t* flags, std::int64_t count)
{
  constexpr std::uint64_t AllOnes = 0x0101010101010101ULL;
  std::int64_t i = 0;
  for (; i + 8 <= count; i += 8)
  {
    std::uint64_t word;
    std::memcpy(&word, flags + i, 8);
    if (word != AllOnes)
    {
      return true;
    }
  }
  for (; i < count; ++i)
  {
    if (flags[i] == 0)
    {
      return true;
    }
  }
  return false;
}
} // namespace detail

template <int Dim>
Status ValidateSpacetree(const Spacetree<Dim>& tree)
{
  if (tree.MaxLevel < 0 || tree.MaxLevel > MaximumSupportedLevel)
  {
    return Status::Invalid(
      "the spacetree's MaxLevel must be between 0 and " + std::to_string(MaximumSupportedLevel));
  }
  if (tree.LeafAnchors.size() != tree.LeafLevels.size() ||
    tree.LeafMaterials.size() != tree.LeafLevels.size())
  {
    return Status::Invalid("the spacetree's leaf arrays have different lengths");
  }
  if (tree.CellSizes.size() != static_cast<std::size_t>(tree.MaxLevel) + 1)
  {
    return Status::Invalid("the spacetree's level table must have MaxLevel + 1 entries");
  }
  const std::int64_t limit = std::int64_t{ 1 } << 40;
  for (int axis = 0; axis < Dim; ++axis)
  {
    if (tree.VoxelSubdivision[axis] < 1 || tree.VoxelSubdivision[axis] > 256)
    {
      return Status::Invalid("the spacetree's voxel subdivision must be between 1 and 256");
    }
    for (int level = 0; level <= tree.MaxLevel; ++level)
    {
      const std::int64_t size = tree.CellSizes[level][axis];
      if (size < 1 || size > limit)
      {
        return Status::Invalid("the spacetree's cell sizes must be positive");
      }
      if (level > 0)
      {
        const std::int64_t parent = tree.CellSizes[level - 1][axis];
        if (parent % size != 0 || parent / size > MaximumSplitCount)
        {
          return Status::Invalid("level " + std::to_string(level) +
            " of the spacetree's level table does not split its parent level into 1 to " +
            std::to_string(MaximumSplitCount) + " cells per axis");
        }
      }
    }
  }
  for (int level = 0; level < tree.MaxLevel; ++level)
  {
    if (tree.CellSizes[level] == tree.CellSizes[level + 1])
    {
      return Status::Invalid(
        "level " + std::to_string(level + 1) + " of the spacetree's level table splits no axis");
    }
  }
  {
    std::int64_t count = 1;
    for (int axis = 0; axis < Dim; ++axis)
    {
      const std::int64_t roots = tree.RootGridDimensions[axis];
      const std::int64_t rootSize = tree.CellSizes[0][axis];
      if (roots >= 1 && (roots > limit / rootSize || count > limit / (roots * rootSize)))
      {
        return Status::OutOfRange("the spacetree's lattice is too large");
      }
      count *= roots >= 1 ? roots * rootSize : 1;
    }
  }
  for (int axis = 0; axis < Dim; ++axis)
  {
    if (tree.RootGridDimensions[axis] < 1 || tree.ImageDimensions[axis] < 1)
    {
      return Status::Invalid("the spacetree's root grid and image dimensions must be positive");
    }
    if (tree.ImageDimensions[axis] > limit / tree.VoxelSubdivision[axis] ||
      tree.ImageDimensions[axis] * tree.VoxelSubdivision[axis] >
        tree.RootGridDimensions[axis] * tree.GetRootCellSize()[axis])
    {
      return Status::Invalid("the spacetree's root grid does not cover its image");
    }
  }
  if (tree.MaterialLabels.empty() || tree.MaterialLabels.size() > 65536)
  {
    return Status::Invalid("the spacetree's material table must have 1 to 65536 entries");
  }
  const LatticeIndex<Dim> dims = tree.GetLatticeDimensions();
  const std::int64_t cells = NumberOfLatticeCells<Dim>(dims);
  if (cells > (std::int64_t{ 1 } << 40))
  {
    return Status::OutOfRange("the spacetree's lattice is too large");
  }
  std::vector<std::uint8_t> coverage(static_cast<std::size_t>(cells), 0);
  for (std::int64_t leaf = 0; leaf < tree.GetNumberOfLeaves(); ++leaf)
  {
    const int level = tree.LeafLevels[leaf];
    if (level > tree.MaxLevel)
    {
      return Status::Invalid("leaf " + std::to_string(leaf) + " has a level above MaxLevel");
    }
    if (tree.LeafMaterials[leaf] >= tree.MaterialLabels.size())
    {
      return Status::Invalid("leaf " + std::to_string(leaf) + " has an unknown material");
    }
    const LatticeIndex<Dim> size = tree.GetCellSize(level);
    const LatticeIndex<Dim>& anchor = tree.LeafAnchors[leaf];
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (anchor[axis] < 0 || anchor[axis] % size[axis] != 0 ||
        anchor[axis] + size[axis] > dims[axis])
      {
        return Status::Invalid("leaf " + std::to_string(leaf) +
          " lies outside the root grid or off its level's lattice");
      }
    }
    std::int64_t rows = 1;
    for (int axis = 1; axis < Dim; ++axis)
    {
      rows *= size[axis];
    }
    for (std::int64_t r = 0; r < rows; ++r)
    {
      LatticeIndex<Dim> cell = anchor;
      std::int64_t rest = r;
      for (int axis = 1; axis < Dim; ++axis)
      {
        cell[axis] += rest % size[axis];
        rest /= size[axis];
      }
      // A row of the lattice at a time, eight cells per test (AAL, 116 labels: the loop per
      // cell took 0.14 s of each stage that reads a tree, balance and tessellation).
      std::uint8_t* row = coverage.data() + LinearIndex<Dim>(cell, dims);
      if (detail::AnyNonZeroByte(row, size[0]))
      {
        return Status::Invalid("leaf " + std::to_string(leaf) + " overlaps another leaf");
      }
      std::memset(row, 1, static_cast<std::size_t>(size[0]));
    }
  }
  if (detail::AnyZeroFlag(coverage.data(), cells))
  {
    return Status::Invalid("the leaves leave a hole in the root grid");
  }
  return Status::Ok();
}

} // namespace stm

#endif
