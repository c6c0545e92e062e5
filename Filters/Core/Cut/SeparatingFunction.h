// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSeparatingFunction_h
#define stmCoreSeparatingFunction_h

// Separating functions from voxels (the paper's section 3.1): the body-of-interest indicator of
// the voxels (-1 inside, +1 outside), and its d-linear interpolation on the dual grid, whose
// nodes are the voxel centres. At a voxel corner the interpolant is the exact average of the 2^d
// voxels around it, so for the indicator it takes the values i / 2^(d-1) (eq. 2), 0 on a flat
// interface. Voxels beyond the image are outside.

#include "../Common/Execution.h"
#include "../Common/Status.h"
#include "../Spacetree/Spacetree.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace stm
{

namespace detail
{
/// The dual cell a point in voxel units lies in: its lowest voxel, and the point's place in it
/// per axis (0 to 1).
template <int Dim>
LatticeIndex<Dim> DualCell(const double* position, double* weights)
{
  LatticeIndex<Dim> lower;
  for (int axis = 0; axis < Dim; ++axis)
  {
    const double dual = position[axis] - 0.5;
    const double floor = std::floor(dual);
    lower[axis] = static_cast<std::int64_t>(floor);
    weights[axis] = dual - floor;
  }
  return lower;
}

/// d-linear interpolation on the dual grid of any field with At(voxel), at a point in voxel
/// units (0: the outer corner of the first voxel; voxel i is centred at i + 1/2).
template <int Dim, class Field>
double SampleDual(const Field& field, const double* position)
{
  double weights[Dim];
  const LatticeIndex<Dim> lower = DualCell<Dim>(position, weights);
  double sum = 0.0;
  for (unsigned corner = 0; corner < (1u << Dim); ++corner)
  {
    double weight = 1.0;
    LatticeIndex<Dim> voxel = lower;
    for (int axis = 0; axis < Dim; ++axis)
    {
      const bool upper = (corner >> axis) & 1u;
      voxel[axis] += upper ? 1 : 0;
      weight *= upper ? weights[axis] : 1.0 - weights[axis];
    }
    if (weight != 0.0)
    {
      sum += weight * field.At(voxel);
    }
  }
  return sum;
}

/// SampleDual and its gradient (per voxel unit along each axis); on a dual cell's face the
/// derivative across it is the upper cell's.
template <int Dim, class Field>
double SampleDualWithGradient(const Field& field, const double* position, double* gradient)
{
  double weights[Dim];
  const LatticeIndex<Dim> lower = DualCell<Dim>(position, weights);
  for (int axis = 0; axis < Dim; ++axis)
  {
    gradient[axis] = 0.0;
  }
  double sum = 0.0;
  for (unsigned corner = 0; corner < (1u << Dim); ++corner)
  {
    LatticeIndex<Dim> voxel = lower;
    double factors[Dim];
    for (int axis = 0; axis < Dim; ++axis)
    {
      const bool upper = (corner >> axis) & 1u;
      voxel[axis] += upper ? 1 : 0;
      factors[axis] = upper ? weights[axis] : 1.0 - weights[axis];
    }
    const double value = field.At(voxel);
    double weight = 1.0;
    for (int axis = 0; axis < Dim; ++axis)
    {
      weight *= factors[axis];
      double others = (corner >> axis) & 1u ? 1.0 : -1.0;
      for (int other = 0; other < Dim; ++other)
      {
        others *= other == axis ? 1.0 : factors[other];
      }
      if (others != 0.0)
      {
        gradient[axis] += others * value;
      }
    }
    if (weight != 0.0)
    {
      sum += weight * value;
    }
  }
  return sum;
}
} // namespace detail

/// Values at the voxel centres of an image (axis 0 fastest).
template <int Dim, class Value>
struct VoxelField
{
  LatticeIndex<Dim> Dimensions{};
  const Value* Values = nullptr;
  /// The value of every voxel beyond the image.
  double Outside = 1.0;

  double At(const LatticeIndex<Dim>& voxel) const
  {
    std::int64_t index = 0;
    for (int axis = Dim - 1; axis >= 0; --axis)
    {
      if (voxel[axis] < 0 || voxel[axis] >= this->Dimensions[axis])
      {
        return this->Outside;
      }
      index = index * this->Dimensions[axis] + voxel[axis];
    }
    return static_cast<double>(this->Values[index]);
  }

  /// d-linear interpolation on the dual grid at a point in voxel units (0: the outer corner of
  /// the first voxel; voxel i is centred at i + 1/2).
  double Sample(const double* position) const { return detail::SampleDual<Dim>(*this, position); }

  /// Sample and its gradient (per voxel unit along each axis); on a dual cell's face the
  /// derivative across it is the upper cell's. Vertex snapping projects along it.
  double SampleWithGradient(const double* position, double* gradient) const
  {
    return detail::SampleDualWithGradient<Dim>(*this, position, gradient);
  }
};

/// Values at the voxel centres of a box of an image (a sub-extent, as a piece reads it), with
/// the image closed at its boundary: a voxel beyond the image takes the magnitude of the nearest
/// voxel of the image, at least Floor (> 0). So a field that is negative inside (a gray image
/// against a threshold) has its zero set on the image's boundary wherever the inside reaches it,
/// as the body indicator has, and every value depends only on voxels within one voxel of where
/// it is sampled: a box that holds the voxels within one voxel of every sampled point gives the
/// whole image's values. A voxel of the image outside the box is NaN (the box is too small).
template <int Dim, class Value>
struct ClosedVoxelField
{
  /// The whole image's dimensions.
  LatticeIndex<Dim> Dimensions{};
  /// The box held: Values covers [BoxFirst, BoxFirst + BoxDimensions) (axis 0 fastest).
  LatticeIndex<Dim> BoxFirst{};
  LatticeIndex<Dim> BoxDimensions{};
  const Value* Values = nullptr;
  double Floor = 1e-300;

  double At(const LatticeIndex<Dim>& voxel) const
  {
    bool beyond = false;
    std::int64_t index = 0;
    for (int axis = Dim - 1; axis >= 0; --axis)
    {
      std::int64_t nearest = voxel[axis];
      if (nearest < 0 || nearest >= this->Dimensions[axis])
      {
        beyond = true;
        nearest =
          std::min<std::int64_t>(std::max<std::int64_t>(nearest, 0), this->Dimensions[axis] - 1);
      }
      const std::int64_t inBox = nearest - this->BoxFirst[axis];
      if (inBox < 0 || inBox >= this->BoxDimensions[axis])
      {
        return std::nan("");
      }
      index = index * this->BoxDimensions[axis] + inBox;
    }
    const double value = static_cast<double>(this->Values[index]);
    return beyond ? std::max(this->Floor, std::abs(value)) : value;
  }

  double Sample(const double* position) const { return detail::SampleDual<Dim>(*this, position); }

  double SampleWithGradient(const double* position, double* gradient) const
  {
    return detail::SampleDualWithGradient<Dim>(*this, position, gradient);
  }
};

/// The body-of-interest indicator of a spacetree's voxels: -1 where the leaf covering the voxel
/// is a body material, +1 for the background. Every voxel is written once (by the leaf holding
/// its first lattice cell), so leaves fill it in parallel.
template <int Dim, class Executor>
Status BodyIndicator(
  const Spacetree<Dim>& tree, std::vector<std::int8_t>& indicator, Executor& executor)
{
  std::int64_t voxels = 1;
  for (int axis = 0; axis < Dim; ++axis)
  {
    voxels *= tree.ImageDimensions[axis];
  }
  indicator.assign(static_cast<std::size_t>(voxels), 1);
  struct FillKernel
  {
    using Scratch = NoScratch;
    const Spacetree<Dim>* Tree;
    std::int8_t* Indicator;
    Executor* Exec;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      const Spacetree<Dim>& tree = *this->Tree;
      // Abort is polled every 256 leaves: each poll asks VTK which thread this is.
      for (std::int64_t leaf = begin;
           leaf < end && ((leaf - begin) % 256 != 0 || !this->Exec->ShouldAbort()); ++leaf)
      {
        if (tree.LeafMaterials[leaf] == BackgroundMaterial)
        {
          continue;
        }
        const LatticeIndex<Dim>& anchor = tree.LeafAnchors[leaf];
        const LatticeIndex<Dim>& size = tree.GetCellSize(tree.LeafLevels[leaf]);
        LatticeIndex<Dim> first, last;
        bool empty = false;
        for (int axis = 0; axis < Dim; ++axis)
        {
          const std::int64_t sub = tree.VoxelSubdivision[axis];
          first[axis] = (anchor[axis] + sub - 1) / sub;
          last[axis] = std::min<std::int64_t>(
            (anchor[axis] + size[axis] + sub - 1) / sub, tree.ImageDimensions[axis]);
          empty = empty || first[axis] >= last[axis];
        }
        if (empty)
        {
          continue;
        }
        ForEachLatticePoint<Dim>(first, last,
          [&](const LatticeIndex<Dim>& voxel)
          {
            std::int64_t index = 0;
            for (int axis = Dim - 1; axis >= 0; --axis)
            {
              index = index * tree.ImageDimensions[axis] + voxel[axis];
            }
            this->Indicator[index] = -1;
          });
      }
    }
  };
  FillKernel kernel{ &tree, indicator.data(), &executor };
  executor.For(0, tree.GetNumberOfLeaves(), 1024, kernel);
  return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
}

} // namespace stm

#endif
