// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSpacetreeBuild_h
#define stmCoreSpacetreeBuild_h

// Builds the spacetree of a material image (paper section 2.1): the root grid I_0 is the
// coarsest grid of power-of-two cells no larger than MaxCellSize that covers the image, and a
// cell is split into its 2^Dim children while it holds more than one material, so that every
// material interface is resolved at voxel size.

#include "../Common/CubeInfo.h"
#include "../Common/Execution.h"
#include "../Common/Status.h"
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

struct SpacetreeBuildOptions
{
  /// Largest leaf edge in voxels (>= 1); root cells are the largest power of two not above it.
  std::int64_t MaxCellSize = 16;
};

/// Largest level count the lattice arithmetic supports (cell edges up to 2^20 voxels).
constexpr int MaximumSupportedLevel = 20;

template <int Dim>
class SpacetreeBuilder
{
public:
  template <class Executor>
  Status Build(const MaterialImage<Dim>& image, const std::vector<std::int64_t>& materialLabels,
    const SpacetreeBuildOptions& options, Spacetree<Dim>& tree, Executor& executor)
  {
    std::int64_t voxels = 1;
    std::int64_t largestExtent = 1;
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (image.Dimensions[axis] < 1)
      {
        return Status::Invalid("image dimensions must be positive");
      }
      voxels *= image.Dimensions[axis];
      largestExtent = std::max<std::int64_t>(largestExtent, image.Dimensions[axis]);
    }
    if (voxels < 2)
    {
      return Status::Invalid("the image has a single voxel; a spacetree needs at least two");
    }
    if (image.Values == nullptr)
    {
      return Status::Invalid("the material image has no values");
    }
    if (options.MaxCellSize < 1)
    {
      return Status::Invalid(
        "MaxCellSize must be at least 1 voxel, got " + std::to_string(options.MaxCellSize));
    }
    if (materialLabels.empty())
    {
      return Status::Invalid("the material table must hold at least the background label");
    }

    // Root cells: as large as MaxCellSize allows, but no larger than needed to cover the image.
    int maxLevel = 0;
    while (maxLevel < MaximumSupportedLevel &&
      (std::int64_t{ 2 } << maxLevel) <= options.MaxCellSize &&
      (std::int64_t{ 1 } << maxLevel) < largestExtent)
    {
      ++maxLevel;
    }

    tree = Spacetree<Dim>();
    tree.MaxLevel = maxLevel;
    tree.ImageDimensions = image.Dimensions;
    tree.MaterialLabels = materialLabels;
    const std::int64_t rootSize = tree.GetRootCellSize();
    for (int axis = 0; axis < Dim; ++axis)
    {
      tree.RootGridDimensions[axis] = (image.Dimensions[axis] + rootSize - 1) / rootSize;
    }

    const std::int64_t roots = NumberOfLatticeCells<Dim>(tree.RootGridDimensions);
    std::vector<Spacetree<Dim>> perRoot(static_cast<std::size_t>(roots));
    RefineKernel<Executor> kernel{ &image, &tree, &perRoot, &executor };
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
      tree.LeafLevels.insert(tree.LeafLevels.end(), part.LeafLevels.begin(), part.LeafLevels.end());
      tree.LeafAnchors.insert(
        tree.LeafAnchors.end(), part.LeafAnchors.begin(), part.LeafAnchors.end());
      tree.LeafMaterials.insert(
        tree.LeafMaterials.end(), part.LeafMaterials.begin(), part.LeafMaterials.end());
      part = Spacetree<Dim>();
    }
    return Status::Ok();
  }

  /// The material of a cube region if it is homogeneous, otherwise -1. Voxels outside the
  /// image count as background.
  static int UniformMaterial(
    const MaterialImage<Dim>& image, const LatticeIndex<Dim>& anchor, std::int64_t size)
  {
    LatticeIndex<Dim> end;
    bool clipped = false;
    for (int axis = 0; axis < Dim; ++axis)
    {
      end[axis] = std::min<std::int64_t>(anchor[axis] + size, image.Dimensions[axis]);
      clipped = clipped || end[axis] < anchor[axis] + size;
      if (end[axis] <= anchor[axis])
      {
        return BackgroundMaterial; // entirely padding
      }
    }
    const MaterialIndex first =
      clipped ? BackgroundMaterial : image.Values[LinearIndex<Dim>(anchor, image.Dimensions)];
    const std::int64_t rowLength = end[0] - anchor[0];
    LatticeIndex<Dim> row = anchor;
    for (;;)
    {
      const MaterialIndex* values = image.Values + LinearIndex<Dim>(row, image.Dimensions);
      for (std::int64_t i = 0; i < rowLength; ++i)
      {
        if (values[i] != first)
        {
          return -1;
        }
      }
      int axis = 1;
      for (; axis < Dim; ++axis)
      {
        if (++row[axis] < end[axis])
        {
          break;
        }
        row[axis] = anchor[axis];
      }
      if (axis == Dim)
      {
        return first;
      }
    }
  }

private:
  template <class Executor>
  struct RefineKernel
  {
    using Scratch = NoScratch;
    const MaterialImage<Dim>* Image;
    const Spacetree<Dim>* Tree;
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
            (rest % this->Tree->RootGridDimensions[axis]) * this->Tree->GetRootCellSize();
          rest /= this->Tree->RootGridDimensions[axis];
        }
        this->Refine(anchor, 0, (*this->PerRoot)[root]);
        this->Exec->ReportProgress(static_cast<double>(root + 1) / this->PerRoot->size());
      }
    }

    void Refine(const LatticeIndex<Dim>& anchor, int level, Spacetree<Dim>& out) const
    {
      const std::int64_t size = this->Tree->GetCellSize(level);
      const int material = UniformMaterial(*this->Image, anchor, size);
      if (material >= 0)
      {
        out.AddLeaf(level, anchor, static_cast<MaterialIndex>(material));
        return;
      }
      const std::int64_t half = size / 2;
      for (int child = 0; child < CubeInfo<Dim>::VerticesPerCell; ++child)
      {
        LatticeIndex<Dim> childAnchor = anchor;
        for (int axis = 0; axis < Dim; ++axis)
        {
          childAnchor[axis] += ((child >> axis) & 1) * half;
        }
        this->Refine(childAnchor, level + 1, out);
      }
    }
  };
};

} // namespace stm

#endif
