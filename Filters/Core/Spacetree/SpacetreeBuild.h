// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSpacetreeBuild_h
#define stmCoreSpacetreeBuild_h

// Builds the spacetree of a material image (paper section 2.1) on a level table planned by
// PlanRefinement: the root grid I_0 covers the image with root cells, and a cell is split into
// the children of its level's pattern while it holds more than one material (so that every
// material interface is resolved at voxel size) or while it covers a voxel whose minimum level
// is finer than the cell (the size criteria: per label, in a region, a sizing field).

#include "../Common/CubeInfo.h"
#include "../Common/Execution.h"
#include "../Common/Status.h"
#include "RefinementPlan.h"
#include "Spacetree.h"

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

namespace stm
{

/// A Dim-dimensional image of material indices, axis 0 fastest, one entry per voxel.
template <int Dim>
struct MaterialImage
{
  LatticeIndex<Dim> Dimensions{};
  const MaterialIndex* Values = nullptr;
};

template <int Dim>
class SpacetreeBuilder
{
public:
  /// Plans the levels from the options and builds the tree with the label criterion only.
  template <class Executor>
  Status Build(const MaterialImage<Dim>& image, const std::vector<std::int64_t>& materialLabels,
    const RefinementPlanOptions<Dim>& options, Spacetree<Dim>& tree, Executor& executor)
  {
    RefinementPlan<Dim> plan;
    const Status status = PlanRefinement<Dim>(image.Dimensions, options, plan);
    if (!status.IsOk())
    {
      return status;
    }
    return this->Build(image, materialLabels, plan, nullptr, tree, executor);
  }

  /// minimumLevels, if not null, holds per voxel the coarsest level a leaf covering it may have.
  template <class Executor>
  Status Build(const MaterialImage<Dim>& image, const std::vector<std::int64_t>& materialLabels,
    const RefinementPlan<Dim>& plan, const std::uint8_t* minimumLevels, Spacetree<Dim>& tree,
    Executor& executor)
  {
    std::int64_t voxels = 1;
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (image.Dimensions[axis] < 1)
      {
        return Status::Invalid("image dimensions must be positive");
      }
      voxels *= image.Dimensions[axis];
    }
    if (voxels < 2)
    {
      return Status::Invalid("the image has a single voxel; a spacetree needs at least two");
    }
    if (image.Values == nullptr)
    {
      return Status::Invalid("the material image has no values");
    }
    if (materialLabels.empty())
    {
      return Status::Invalid("the material table must hold at least the background label");
    }
    if (plan.CellSizes.empty())
    {
      return Status::Invalid("the refinement plan has no levels");
    }

    tree = Spacetree<Dim>();
    plan.ApplyTo(tree);
    tree.ImageDimensions = image.Dimensions;
    tree.MaterialLabels = materialLabels;
    tree.RootGridDimensions = plan.RootGridDimensions(image.Dimensions);

    const std::int64_t roots = NumberOfLatticeCells<Dim>(tree.RootGridDimensions);
    std::vector<Spacetree<Dim>> perRoot(static_cast<std::size_t>(roots));
    RefineKernel<Executor> kernel{ &image, &tree, minimumLevels, &perRoot, &executor };
    executor.For(0, roots, 1, kernel);
    if (executor.ShouldAbort())
    {
      return Status::Aborted();
    }

    std::int64_t total = 0;
    bool bodyFound = false;
    for (const auto& part : perRoot)
    {
      total += part.GetNumberOfLeaves();
      bodyFound = bodyFound ||
        std::any_of(part.LeafMaterials.begin(), part.LeafMaterials.end(),
          [](MaterialIndex m) { return m != BackgroundMaterial; });
    }
    if (!bodyFound)
    {
      return Status::Invalid("the body of interest is empty: no voxel has one of its labels");
    }
    tree.ReserveLeaves(total);
    for (auto& part : perRoot)
    {
      tree.AppendLeaves(part);
      part = Spacetree<Dim>();
    }
    return Status::Ok();
  }

  /// The voxels a cell covers, clipped to the image: [first, last) per axis. Returns false when
  /// the cell lies entirely in the padding.
  static bool CoveredVoxels(const MaterialImage<Dim>& image, const Spacetree<Dim>& tree,
    const LatticeIndex<Dim>& anchor, int level, LatticeIndex<Dim>& first, LatticeIndex<Dim>& last,
    bool& clipped)
  {
    clipped = false;
    for (int axis = 0; axis < Dim; ++axis)
    {
      const std::int64_t subdivision = tree.VoxelSubdivision[axis];
      const std::int64_t end = anchor[axis] + tree.GetCellSize(level)[axis];
      first[axis] = anchor[axis] / subdivision;
      last[axis] =
        std::min<std::int64_t>((end + subdivision - 1) / subdivision, image.Dimensions[axis]);
      clipped = clipped || last[axis] * subdivision < end;
      if (last[axis] <= first[axis])
      {
        return false;
      }
    }
    return true;
  }

  /// Calls row(linearIndexOfFirstVoxel, length) for every axis-0 row of a voxel box; stops
  /// early, returning false, when row returns false.
  template <class RowFunction>
  static bool ForEachVoxelRow(const LatticeIndex<Dim>& dims, const LatticeIndex<Dim>& first,
    const LatticeIndex<Dim>& last, RowFunction&& row)
  {
    const std::int64_t rowLength = last[0] - first[0];
    LatticeIndex<Dim> cursor = first;
    for (;;)
    {
      if (!row(LinearIndex<Dim>(cursor, dims), rowLength))
      {
        return false;
      }
      int axis = 1;
      for (; axis < Dim; ++axis)
      {
        if (++cursor[axis] < last[axis])
        {
          break;
        }
        cursor[axis] = first[axis];
      }
      if (axis == Dim)
      {
        return true;
      }
    }
  }

  /// The material of a cell if it is homogeneous, otherwise -1. Voxels outside the image count
  /// as background.
  static int UniformMaterial(const MaterialImage<Dim>& image, const Spacetree<Dim>& tree,
    const LatticeIndex<Dim>& anchor, int level)
  {
    LatticeIndex<Dim> first, last;
    bool clipped;
    if (!CoveredVoxels(image, tree, anchor, level, first, last, clipped))
    {
      return BackgroundMaterial; // entirely padding
    }
    const MaterialIndex value =
      clipped ? BackgroundMaterial : image.Values[LinearIndex<Dim>(first, image.Dimensions)];
    const bool uniform = ForEachVoxelRow(image.Dimensions, first, last,
      [&](std::int64_t start, std::int64_t length)
      {
        const MaterialIndex* values = image.Values + start;
        for (std::int64_t i = 0; i < length; ++i)
        {
          if (values[i] != value)
          {
            return false;
          }
        }
        return true;
      });
    return uniform ? value : -1;
  }

  /// Whether a voxel covered by the cell asks for a level finer than the cell's.
  static bool NeedsFinerLevel(const MaterialImage<Dim>& image, const Spacetree<Dim>& tree,
    const std::uint8_t* minimumLevels, const LatticeIndex<Dim>& anchor, int level)
  {
    LatticeIndex<Dim> first, last;
    bool clipped;
    if (minimumLevels == nullptr || level >= tree.MaxLevel ||
      !CoveredVoxels(image, tree, anchor, level, first, last, clipped))
    {
      return false;
    }
    return !ForEachVoxelRow(image.Dimensions, first, last,
      [&](std::int64_t start, std::int64_t length)
      {
        const std::uint8_t* levels = minimumLevels + start;
        for (std::int64_t i = 0; i < length; ++i)
        {
          if (levels[i] > level)
          {
            return false;
          }
        }
        return true;
      });
  }

private:
  template <class Executor>
  struct RefineKernel
  {
    using Scratch = NoScratch;
    const MaterialImage<Dim>* Image;
    const Spacetree<Dim>* Tree;
    const std::uint8_t* MinimumLevels;
    std::vector<Spacetree<Dim>>* PerRoot;
    Executor* Exec;

    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t root = begin; root < end; ++root)
      {
        if (this->Exec->ShouldAbort())
        {
          return;
        }
        LatticeIndex<Dim> anchor;
        std::int64_t rest = root;
        for (int axis = 0; axis < Dim; ++axis)
        {
          anchor[axis] =
            (rest % this->Tree->RootGridDimensions[axis]) * this->Tree->GetRootCellSize()[axis];
          rest /= this->Tree->RootGridDimensions[axis];
        }
        this->Refine(anchor, 0, (*this->PerRoot)[root]);
        this->Exec->ReportProgress(static_cast<double>(root + 1) / this->PerRoot->size());
      }
    }

    void Refine(const LatticeIndex<Dim>& anchor, int level, Spacetree<Dim>& out) const
    {
      const int material = UniformMaterial(*this->Image, *this->Tree, anchor, level);
      if (material >= 0 &&
        !NeedsFinerLevel(*this->Image, *this->Tree, this->MinimumLevels, anchor, level))
      {
        out.AddLeaf(level, anchor, static_cast<MaterialIndex>(material));
        return;
      }
      this->Tree->ForEachChild(anchor, level,
        [&](const LatticeIndex<Dim>& child) { this->Refine(child, level + 1, out); });
    }
  };
};

} // namespace stm

#endif
