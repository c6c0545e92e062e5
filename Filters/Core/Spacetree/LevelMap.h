// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreLevelMap_h
#define stmCoreLevelMap_h

// A dense map from every lattice cell of the root grid to the level and material of the leaf
// that covers it. It answers "which leaf contains this cell" in O(1), which is what balancing
// needs, and it turns back into the canonical leaf list. One byte of level and two of material
// per lattice cell.

#include "../Common/CubeInfo.h"
#include "../Common/Status.h"
#include "Spacetree.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace stm
{

template <int Dim>
class LevelMap
{
public:
  template <class Executor>
  Status Build(const Spacetree<Dim>& tree, Executor& executor)
  {
    this->MaxLevel = tree.MaxLevel;
    this->CellSizes = tree.CellSizes;
    this->RootGridDimensions = tree.RootGridDimensions;
    this->Dimensions = tree.GetLatticeDimensions();
    const std::int64_t cells = NumberOfLatticeCells<Dim>(this->Dimensions);
    // Left uninitialised: the leaves partition the lattice, so the fill writes every cell (and
    // touches the memory from the threads that will use it).
    this->Levels.reset(new std::uint8_t[static_cast<std::size_t>(cells)]);
    this->Materials.reset(new MaterialIndex[static_cast<std::size_t>(cells)]);

    struct FillKernel
    {
      using Scratch = NoScratch;
      LevelMap* Map;
      const Spacetree<Dim>* Tree;
      Executor* Exec;
      void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
      {
        // The fill writes every lattice cell (57 million on the AAL atlas refined for thin
        // parts): checked per chunk so that an abort does not wait for it.
        if (this->Exec->ShouldAbort())
        {
          return;
        }
        for (std::int64_t leaf = begin; leaf < end; ++leaf)
        {
          this->Map->Fill(this->Tree->LeafAnchors[leaf], this->Tree->LeafLevels[leaf],
            this->Tree->LeafMaterials[leaf]);
        }
      }
    } kernel{ this, &tree, &executor };
    executor.For(0, tree.GetNumberOfLeaves(), 4096, kernel);
    return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
  }

  const LatticeIndex<Dim>& GetDimensions() const { return this->Dimensions; }

  bool Contains(const LatticeIndex<Dim>& cell) const
  {
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (cell[axis] < 0 || cell[axis] >= this->Dimensions[axis])
      {
        return false;
      }
    }
    return true;
  }

  int LevelAt(const LatticeIndex<Dim>& cell) const
  {
    return this->Levels[LinearIndex<Dim>(cell, this->Dimensions)];
  }

  MaterialIndex MaterialAt(const LatticeIndex<Dim>& cell) const
  {
    return this->Materials[LinearIndex<Dim>(cell, this->Dimensions)];
  }

  const LatticeIndex<Dim>& CellSize(int level) const { return this->CellSizes[level]; }

  /// Anchor of the leaf of the given level that contains the cell.
  LatticeIndex<Dim> AnchorOf(const LatticeIndex<Dim>& cell, int level) const
  {
    const LatticeIndex<Dim> size = this->CellSize(level);
    LatticeIndex<Dim> anchor;
    for (int axis = 0; axis < Dim; ++axis)
    {
      anchor[axis] = cell[axis] - cell[axis] % size[axis];
    }
    return anchor;
  }

  /// Marks the region of a leaf as covered by a leaf of this level and material.
  void Fill(const LatticeIndex<Dim>& anchor, int level, MaterialIndex material)
  {
    const LatticeIndex<Dim> size = this->CellSize(level);
    this->ForEachRow(anchor, size,
      [&](std::int64_t rowStart)
      {
        for (std::int64_t i = 0; i < size[0]; ++i)
        {
          this->Levels[rowStart + i] = static_cast<std::uint8_t>(level);
          this->Materials[rowStart + i] = material;
        }
      });
  }

  /// Splits the leaf (level, anchor) into its children; the children keep its material.
  void Split(const LatticeIndex<Dim>& anchor, int level)
  {
    const LatticeIndex<Dim> size = this->CellSize(level);
    this->ForEachRow(anchor, size,
      [&](std::int64_t rowStart)
      {
        for (std::int64_t i = 0; i < size[0]; ++i)
        {
          this->Levels[rowStart + i] = static_cast<std::uint8_t>(level + 1);
        }
      });
  }

  /// Rebuilds the canonical leaf list of the tree from the map.
  template <class Executor>
  Status CollectLeaves(Spacetree<Dim>& tree, Executor& executor) const
  {
    const std::int64_t roots = NumberOfLatticeCells<Dim>(this->RootGridDimensions);
    std::vector<Spacetree<Dim>> perRoot(static_cast<std::size_t>(roots));
    struct CollectKernel
    {
      using Scratch = NoScratch;
      const LevelMap* Map;
      std::vector<Spacetree<Dim>>* PerRoot;
      void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
      {
        for (std::int64_t root = begin; root < end; ++root)
        {
          LatticeIndex<Dim> anchor;
          std::int64_t rest = root;
          for (int axis = 0; axis < Dim; ++axis)
          {
            anchor[axis] =
              (rest % this->Map->RootGridDimensions[axis]) * this->Map->CellSize(0)[axis];
            rest /= this->Map->RootGridDimensions[axis];
          }
          this->Map->CollectNode(anchor, 0, (*this->PerRoot)[root]);
        }
      }
    } kernel{ this, &perRoot };
    executor.For(0, roots, 16, kernel);
    if (executor.ShouldAbort())
    {
      return Status::Aborted();
    }
    std::int64_t total = 0;
    for (const auto& part : perRoot)
    {
      total += part.GetNumberOfLeaves();
    }
    tree.ClearLeaves();
    tree.ReserveLeaves(total);
    for (const auto& part : perRoot)
    {
      tree.AppendLeaves(part);
    }
    return Status::Ok();
  }

private:
  void CollectNode(const LatticeIndex<Dim>& anchor, int level, Spacetree<Dim>& out) const
  {
    if (this->LevelAt(anchor) == level)
    {
      out.AddLeaf(level, anchor, this->MaterialAt(anchor));
      return;
    }
    Spacetree<Dim>::VisitChildren(this->CellSizes, anchor, level,
      [&](const LatticeIndex<Dim>& child) { this->CollectNode(child, level + 1, out); });
  }

  /// Calls row(linearIndexOfFirstCell) for every axis-0 row of a box region.
  template <class RowFunction>
  void ForEachRow(
    const LatticeIndex<Dim>& anchor, const LatticeIndex<Dim> size, RowFunction&& row) const
  {
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
      row(LinearIndex<Dim>(cell, this->Dimensions));
    }
  }

  int MaxLevel = 0;
  std::vector<LatticeIndex<Dim>> CellSizes;
  LatticeIndex<Dim> RootGridDimensions{};
  LatticeIndex<Dim> Dimensions{};
  std::unique_ptr<std::uint8_t[]> Levels;
  std::unique_ptr<MaterialIndex[]> Materials;
};

} // namespace stm

#endif
