// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreThinParts_h
#define stmCoreThinParts_h

// Thin parts of a material image: the voxels that a cut at the labels function would lose or
// pinch off at voxel size. The labels function (the d-linear interpolation of each material's
// voxel indicator on the dual grid) takes at a voxel corner the share of each material among
// the 2^d voxels around it, and a mesh whose points are voxel corners interpolates these shares
// in between; a material is kept where its share is the largest. A voxel of material m is thin
// when
//  (a) its face-connected component of m has no voxel whose centre surely keeps m: the average
//      of the shares over the voxel's 2^d corners (the labels function at its centre, which
//      weighs the 3^d voxels around it by 2^(number of axes on which they are not offset) / 4^d)
//      gives m more than one half nowhere in the component. (A strict maximum is not enough:
//      a mesh interpolates the corners on its own simplices, and the peeling compares m with
//      the largest share of the later materials only.) Specks, lines, blocks two voxels wide in
//      3D and curved layers one voxel thick would be lost, or kept only around a corner, away
//      from every voxel centre; or
//  (b) a face neighbour of material m shares a face none of whose 2^(d-1) corners has m as the
//      strict majority (the two would be cut apart at that face).
// Refining thin voxels to half their size (on every axis) puts mesh points at their centres and
// face centres, where m's share is 1, so every face-connected component of every material keeps
// a connected piece that holds its voxel centres. With bodyOnly the materials are the body (every
// non-background material) and the background, as for the binary cut of the body. Voxels beyond the
// image count as background, as the labels function has it.

#include "../Common/CubeInfo.h"
#include "../Common/Execution.h"
#include "../Common/Status.h"
#include "SpacetreeBuild.h"

#include <cstdint>
#include <vector>

namespace stm
{

/// thin: one flag per voxel (axis 0 fastest), 1 for a thin voxel.
template <int Dim, class Executor>
Status ThinPartVoxels(const MaterialImage<Dim>& image, bool bodyOnly,
  std::vector<std::uint8_t>& thin, Executor& executor)
{
  LatticeIndex<Dim> corners;
  std::int64_t voxelCount = 1, cornerCount = 1;
  for (int axis = 0; axis < Dim; ++axis)
  {
    if (image.Dimensions[axis] < 1)
    {
      return Status::Invalid("image dimensions must be positive");
    }
    corners[axis] = image.Dimensions[axis] + 1;
    voxelCount *= image.Dimensions[axis];
    cornerCount *= corners[axis];
  }
  if (image.Values == nullptr)
  {
    return Status::Invalid("the material image has no values");
  }
  constexpr int Around = 1 << Dim;
  auto materialAt = [&](const LatticeIndex<Dim>& voxel) -> std::int32_t
  {
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (voxel[axis] < 0 || voxel[axis] >= image.Dimensions[axis])
      {
        return BackgroundMaterial;
      }
    }
    const MaterialIndex material = image.Values[LinearIndex<Dim>(voxel, image.Dimensions)];
    return bodyOnly ? (material == BackgroundMaterial ? 0 : 1) : material;
  };
  auto unlinear = [](std::int64_t linear, const LatticeIndex<Dim>& dims)
  {
    LatticeIndex<Dim> index;
    for (int axis = 0; axis < Dim; ++axis)
    {
      index[axis] = linear % dims[axis];
      linear /= dims[axis];
    }
    return index;
  };

  // The strict majority material of the voxels around each corner, or -1.
  std::vector<std::int32_t> majority(static_cast<std::size_t>(cornerCount), -1);
  struct MajorityKernel
  {
    using Scratch = NoScratch;
    const decltype(materialAt)* MaterialAt;
    const decltype(unlinear)* Unlinear;
    const LatticeIndex<Dim>* Corners;
    std::int32_t* Majority;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t c = begin; c < end; ++c)
      {
        const LatticeIndex<Dim> corner = (*this->Unlinear)(c, *this->Corners);
        std::int32_t materials[Around];
        for (int k = 0; k < Around; ++k)
        {
          LatticeIndex<Dim> voxel = corner;
          for (int axis = 0; axis < Dim; ++axis)
          {
            voxel[axis] -= (k >> axis) & 1 ? 0 : 1;
          }
          materials[k] = (*this->MaterialAt)(voxel);
        }
        int best = 0, bestCount = 0;
        bool tie = false;
        for (int k = 0; k < Around; ++k)
        {
          int count = 0;
          for (int j = 0; j < Around; ++j)
          {
            count += materials[j] == materials[k] ? 1 : 0;
          }
          if (count > bestCount)
          {
            best = k;
            bestCount = count;
            tie = false;
          }
          else if (count == bestCount && materials[k] != materials[best])
          {
            tie = true;
          }
        }
        this->Majority[c] = tie ? -1 : materials[best];
      }
    }
  };
  MajorityKernel majorityKernel{ &materialAt, &unlinear, &corners, majority.data() };
  executor.For(0, cornerCount, 1 << 14, majorityKernel);
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }

  // Whether the labels function keeps each voxel's material at its centre.
  std::vector<std::uint8_t> centreKept(static_cast<std::size_t>(voxelCount), 0);
  struct CentreKernel
  {
    using Scratch = NoScratch;
    const decltype(materialAt)* MaterialAt;
    const decltype(unlinear)* Unlinear;
    const LatticeIndex<Dim>* Dimensions;
    std::uint8_t* Kept;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      constexpr int Neighbours = Dim == 1 ? 3 : Dim == 2 ? 9 : Dim == 3 ? 27 : 81;
      std::int32_t materials[Neighbours];
      int weights[Neighbours];
      for (std::int64_t v = begin; v < end; ++v)
      {
        const LatticeIndex<Dim> voxel = (*this->Unlinear)(v, *this->Dimensions);
        for (int n = 0; n < Neighbours; ++n)
        {
          LatticeIndex<Dim> other = voxel;
          int weight = 1;
          for (int axis = 0, code = n; axis < Dim; ++axis, code /= 3)
          {
            other[axis] += code % 3 - 1;
            weight *= code % 3 == 1 ? 2 : 1;
          }
          materials[n] = (*this->MaterialAt)(other);
          weights[n] = weight;
        }
        const std::int32_t own = materials[(Neighbours - 1) / 2];
        int ownSum = 0, total = 0;
        for (int n = 0; n < Neighbours; ++n)
        {
          ownSum += materials[n] == own ? weights[n] : 0;
          total += weights[n];
        }
        const bool kept = 2 * ownSum > total;
        this->Kept[v] = kept ? 1 : 0;
      }
    }
  };
  CentreKernel centreKernel{ &materialAt, &unlinear, &image.Dimensions, centreKept.data() };
  executor.For(0, voxelCount, 1 << 14, centreKernel);
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }

  // Whether each voxel's face-connected component has a voxel that keeps it: a search from each
  // voxel that does not, stopped at the first voxel that does (most components reach one
  // within a step or two; only components that have none are walked whole).
  std::vector<std::uint8_t> componentKept = centreKept; // 1: kept, 0: unknown, 2: not kept
  std::vector<std::int64_t> visited, stack;
  for (std::int64_t start = 0; start < voxelCount; ++start)
  {
    if (componentKept[start] != 0)
    {
      continue;
    }
    const std::int32_t own = materialAt(unlinear(start, image.Dimensions));
    visited.assign(1, start);
    stack.assign(1, start);
    componentKept[start] = 2;
    bool found = false;
    while (!stack.empty() && !found)
    {
      const LatticeIndex<Dim> voxel = unlinear(stack.back(), image.Dimensions);
      stack.pop_back();
      for (int axis = 0; axis < Dim && !found; ++axis)
      {
        for (const int step : { -1, 1 })
        {
          LatticeIndex<Dim> neighbour = voxel;
          neighbour[axis] += step;
          if (neighbour[axis] < 0 || neighbour[axis] >= image.Dimensions[axis] ||
            materialAt(neighbour) != own)
          {
            continue;
          }
          const std::int64_t index = LinearIndex<Dim>(neighbour, image.Dimensions);
          if (componentKept[index] == 1)
          {
            found = true;
            break;
          }
          if (componentKept[index] == 0)
          {
            componentKept[index] = 2;
            visited.push_back(index);
            stack.push_back(index);
          }
        }
      }
    }
    for (const std::int64_t index : visited)
    {
      componentKept[index] = found ? 1 : 2;
    }
  }
  std::vector<std::uint8_t>().swap(centreKept);

  thin.assign(static_cast<std::size_t>(voxelCount), 0);
  struct ThinKernel
  {
    using Scratch = NoScratch;
    const decltype(materialAt)* MaterialAt;
    const decltype(unlinear)* Unlinear;
    const LatticeIndex<Dim>* Dimensions;
    const LatticeIndex<Dim>* Corners;
    const std::int32_t* Majority;
    const std::uint8_t* ComponentKept;
    std::uint8_t* Thin;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t v = begin; v < end; ++v)
      {
        const LatticeIndex<Dim> voxel = (*this->Unlinear)(v, *this->Dimensions);
        const std::int32_t own = (*this->MaterialAt)(voxel);
        auto majorityAt = [&](const LatticeIndex<Dim>& corner)
        { return this->Majority[LinearIndex<Dim>(corner, *this->Corners)]; };
        const bool kept = this->ComponentKept[v] == 1; // (a)
        bool joined = true; // (b): every face to a same-material neighbour has such a corner
        for (int axis = 0; axis < Dim && kept && joined; ++axis)
        {
          for (const int side : { 0, 1 })
          {
            LatticeIndex<Dim> neighbour = voxel;
            neighbour[axis] += side == 1 ? 1 : -1;
            if (neighbour[axis] < 0 || neighbour[axis] >= (*this->Dimensions)[axis] ||
              (*this->MaterialAt)(neighbour) != own)
            {
              continue;
            }
            bool shared = false;
            for (int k = 0; k < Around / 2 && !shared; ++k)
            {
              LatticeIndex<Dim> corner = voxel;
              corner[axis] += side;
              for (int other = 0, bit = 0; other < Dim; ++other)
              {
                if (other != axis)
                {
                  corner[other] += (k >> bit++) & 1;
                }
              }
              shared = majorityAt(corner) == own;
            }
            joined = joined && shared;
          }
        }
        this->Thin[v] = kept && joined ? 0 : 1;
      }
    }
  };
  ThinKernel thinKernel{ &materialAt, &unlinear, &image.Dimensions, &corners, majority.data(),
    componentKept.data(), thin.data() };
  executor.For(0, voxelCount, 1 << 14, thinKernel);
  return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
}

} // namespace stm

#endif
