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

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

namespace stm
{

namespace detail
{
/// The voxel count of a material image, or an error for empty extents or missing values.
template <int Dim>
Status CountImageVoxels(const MaterialImage<Dim>& image, std::int64_t& voxelCount)
{
  voxelCount = 1;
  for (int axis = 0; axis < Dim; ++axis)
  {
    if (image.Dimensions[axis] < 1)
    {
      return Status::Invalid("image dimensions must be positive");
    }
    voxelCount *= image.Dimensions[axis];
  }
  if (image.Values == nullptr)
  {
    return Status::Invalid("the material image has no values");
  }
  return Status::Ok();
}

/// The material of a voxel (the background beyond the image); with bodyOnly 1 for the body and
/// 0 for the background.
template <int Dim>
std::int32_t MaterialOrBodyAt(
  const MaterialImage<Dim>& image, bool bodyOnly, const LatticeIndex<Dim>& voxel)
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
}

/// The index of a linear position (axis 0 fastest) in a lattice of `dims`.
template <int Dim>
LatticeIndex<Dim> UnlinearIndex(std::int64_t linear, const LatticeIndex<Dim>& dims)
{
  LatticeIndex<Dim> index;
  for (int axis = 0; axis < Dim; ++axis)
  {
    index[axis] = linear % dims[axis];
    linear /= dims[axis];
  }
  return index;
}

/// same[i] = 1 where the voxel start + i has the value of the voxel start + i + offset for every
/// offset (rows of `length` voxels; a loop the compiler vectorizes).
template <int Dim>
void SameAcrossRows(const MaterialImage<Dim>& image, std::int64_t start, std::int64_t length,
  const std::vector<std::int64_t>& offsets, std::vector<std::uint8_t>& same)
{
  same.assign(static_cast<std::size_t>(length), 1);
  const MaterialIndex* row = image.Values + start;
  for (const std::int64_t offset : offsets)
  {
    const MaterialIndex* other = row + offset;
    for (std::int64_t i = 0; i < length; ++i)
    {
      same[i] &= other[i] == row[i] ? 1 : 0;
    }
  }
}

/// Whether the row of `linear` (in a lattice of dims) has every index but axis 0's in
/// [1, dims - 2]: for voxels, all voxels around them exist; for corners (dims one more than the
/// image's), all voxels at them.
template <int Dim>
bool RowWithin(std::int64_t linear, const LatticeIndex<Dim>& dims)
{
  linear /= dims[0];
  bool within = true;
  for (int axis = 1; axis < Dim; ++axis)
  {
    const std::int64_t index = linear % dims[axis];
    linear /= dims[axis];
    within = within && index >= 1 && index <= dims[axis] - 2;
  }
  return within;
}

/// centreKept: 1 where the labels function keeps a voxel's material at its centre, 0 where not;
/// UniformlyKept where the 3^d voxels around it are all of its material (no other test needed).
/// componentKept: 1 or UniformlyKept where the voxel's face-connected component has a voxel that
/// keeps it, 2 where it has none.
constexpr std::uint8_t UniformlyKept = 3;

/// The local tests: the strict majority material at each corner (-1 for none; corners of a
/// lattice one larger than the image) and centreKept (see above), per voxel.
template <int Dim, class Executor>
Status ThinPartTests(const MaterialImage<Dim>& image, bool bodyOnly,
  std::vector<std::int32_t>& majority, std::vector<std::uint8_t>& centreKept, Executor& executor)
{
  std::int64_t voxelCount = 0;
  const Status valid = detail::CountImageVoxels<Dim>(image, voxelCount);
  if (!valid.IsOk())
  {
    return valid;
  }
  LatticeIndex<Dim> corners;
  std::int64_t cornerCount = 1;
  for (int axis = 0; axis < Dim; ++axis)
  {
    corners[axis] = image.Dimensions[axis] + 1;
    cornerCount *= corners[axis];
  }
  constexpr int Around = 1 << Dim;
  auto materialAt = [&](const LatticeIndex<Dim>& voxel) -> std::int32_t
  { return detail::MaterialOrBodyAt<Dim>(image, bodyOnly, voxel); };
  auto unlinear = [](std::int64_t linear, const LatticeIndex<Dim>& dims)
  { return detail::UnlinearIndex<Dim>(linear, dims); };

  // Most voxels lie inside a region of one material, where every test below has its answer
  // without counting: the kernels walk rows along axis 0 and answer those voxels (and corners)
  // from a comparison of whole rows, which is only possible away from the image border (AAL, 7
  // million voxels: 0.67 s with the count per voxel, 0.25 s with per-voxel comparisons, on 2
  // threads, the tree included).
  constexpr int Neighbours = Dim == 1 ? 3 : Dim == 2 ? 9 : Dim == 3 ? 27 : 81;
  std::array<std::int64_t, Neighbours> aroundVoxel{}; // linear offsets of the 3^d voxels
  std::array<int, Neighbours> centreWeights{};        // their weights at the centre (times 4^d)
  std::vector<std::int64_t> centreRows; // offsets of the other rows with voxels around a voxel
  std::vector<std::int64_t> cornerRows; // of the other rows with voxels at a corner
  {
    std::int64_t strides[Dim];
    std::int64_t stride = 1;
    for (int axis = 0; axis < Dim; ++axis)
    {
      strides[axis] = stride;
      stride *= image.Dimensions[axis];
    }
    for (int n = 0; n < Neighbours; ++n)
    {
      centreWeights[n] = 1;
      for (int axis = 0, code = n; axis < Dim; ++axis, code /= 3)
      {
        aroundVoxel[n] += (code % 3 - 1) * strides[axis];
        centreWeights[n] *= code % 3 == 1 ? 2 : 1;
      }
    }
    for (int n = 0; n < Neighbours; ++n)
    {
      if (n % 3 == 1 && aroundVoxel[n] != 0)
      {
        centreRows.push_back(aroundVoxel[n]);
      }
    }
    for (int k = 2; k < Around; k += 2)
    {
      std::int64_t offset = 0;
      for (int axis = 1; axis < Dim; ++axis)
      {
        offset += ((k >> axis) & 1) * strides[axis];
      }
      cornerRows.push_back(offset);
    }
  }
  // The material of the voxel at `linear`, as materialAt gives it.
  auto materialOf = [&image, bodyOnly](std::int64_t linear) -> std::int32_t
  {
    const MaterialIndex material = image.Values[linear];
    return bodyOnly ? (material == BackgroundMaterial ? 0 : 1) : material;
  };
  const std::int64_t rowLength = image.Dimensions[0];
  const std::int64_t rowGrain = std::max<std::int64_t>(1, (1 << 14) / rowLength);

  // The strict majority material of the voxels around each corner, or -1.
  majority.assign(static_cast<std::size_t>(cornerCount), -1);
  struct MajorityKernel
  {
    using Scratch = NoScratch;
    const decltype(materialAt)* MaterialAt;
    const decltype(unlinear)* Unlinear;
    const decltype(materialOf)* MaterialOf;
    const std::vector<std::int64_t>* CornerRows;
    const MaterialImage<Dim>* Image;
    const LatticeIndex<Dim>* Corners;
    std::int32_t* Majority;
    void operator()(Scratch&, std::int64_t beginRow, std::int64_t endRow) const
    {
      const std::int64_t length = (*this->Corners)[0]; // one more than a row of voxels
      const MaterialImage<Dim>& image = *this->Image;
      std::vector<std::uint8_t> same;
      for (std::int64_t row = beginRow; row < endRow; ++row)
      {
        const LatticeIndex<Dim> first = (*this->Unlinear)(row * length, *this->Corners);
        if (!detail::RowWithin<Dim>(row * length, *this->Corners) || length < 3)
        {
          for (std::int64_t i = 0; i < length; ++i)
          {
            this->Count(row * length + i, first, i);
          }
          continue;
        }
        // The voxels at corner i are i - 1 and i of the rows from `lowest`.
        std::int64_t lowest = 0;
        for (int axis = Dim - 1; axis >= 1; --axis)
        {
          lowest = lowest * image.Dimensions[axis] + first[axis] - 1;
        }
        lowest *= image.Dimensions[0];
        detail::SameAcrossRows<Dim>(image, lowest, length - 1, *this->CornerRows, same);
        const MaterialIndex* values = image.Values + lowest;
        this->Count(row * length, first, 0);
        for (std::int64_t i = 1; i < length - 1; ++i)
        {
          if (same[i - 1] && same[i] && values[i - 1] == values[i])
          {
            this->Majority[row * length + i] = (*this->MaterialOf)(lowest + i);
          }
          else
          {
            this->Count(row * length + i, first, i);
          }
        }
        this->Count(row * length + length - 1, first, length - 1);
      }
    }
    void Count(std::int64_t c, LatticeIndex<Dim> corner, std::int64_t i) const
    {
      corner[0] = i;
      {
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
  MajorityKernel majorityKernel{ &materialAt, &unlinear, &materialOf, &cornerRows, &image, &corners,
    majority.data() };
  executor.For(0, cornerCount / corners[0], rowGrain, majorityKernel);
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }

  // Whether the labels function keeps each voxel's material at its centre.
  centreKept.assign(static_cast<std::size_t>(voxelCount), 0);
  struct CentreKernel
  {
    using Scratch = NoScratch;
    const decltype(materialAt)* MaterialAt;
    const decltype(materialOf)* MaterialOf;
    const decltype(unlinear)* Unlinear;
    const std::vector<std::int64_t>* CentreRows;
    const std::array<std::int64_t, Neighbours>* AroundVoxel;
    const std::array<int, Neighbours>* Weights;
    const MaterialImage<Dim>* Image;
    std::uint8_t* Kept;
    void operator()(Scratch&, std::int64_t beginRow, std::int64_t endRow) const
    {
      const std::int64_t length = this->Image->Dimensions[0];
      std::vector<std::uint8_t> same;
      for (std::int64_t row = beginRow; row < endRow; ++row)
      {
        const std::int64_t start = row * length;
        if (!detail::RowWithin<Dim>(start, this->Image->Dimensions) || length < 3)
        {
          for (std::int64_t i = 0; i < length; ++i)
          {
            this->Kept[start + i] = this->Count(start + i, false);
          }
          continue;
        }
        // One material all around: its share is 1.
        detail::SameAcrossRows<Dim>(*this->Image, start, length, *this->CentreRows, same);
        const MaterialIndex* values = this->Image->Values + start;
        this->Kept[start] = this->Count(start, false);
        for (std::int64_t i = 1; i < length - 1; ++i)
        {
          const bool uniform = same[i - 1] && same[i] && same[i + 1] &&
            values[i - 1] == values[i] && values[i + 1] == values[i];
          this->Kept[start + i] = uniform ? UniformlyKept : this->Count(start + i, true);
        }
        this->Kept[start + length - 1] = this->Count(start + length - 1, false);
      }
    }
    std::uint8_t Count(std::int64_t v, bool inside) const
    {
      std::int32_t materials[Neighbours];
      if (inside)
      {
        for (int n = 0; n < Neighbours; ++n)
        {
          materials[n] = (*this->MaterialOf)(v + (*this->AroundVoxel)[n]);
        }
      }
      else
      {
        const LatticeIndex<Dim> voxel = (*this->Unlinear)(v, this->Image->Dimensions);
        for (int n = 0; n < Neighbours; ++n)
        {
          LatticeIndex<Dim> other = voxel;
          for (int axis = 0, code = n; axis < Dim; ++axis, code /= 3)
          {
            other[axis] += code % 3 - 1;
          }
          materials[n] = (*this->MaterialAt)(other);
        }
      }
      const std::int32_t own = materials[(Neighbours - 1) / 2];
      int ownSum = 0, total = 0;
      for (int n = 0; n < Neighbours; ++n)
      {
        ownSum += materials[n] == own ? (*this->Weights)[n] : 0;
        total += (*this->Weights)[n];
      }
      return 2 * ownSum > total ? 1 : 0;
    }
  };
  CentreKernel centreKernel{ &materialAt, &materialOf, &unlinear, &centreRows, &aroundVoxel,
    &centreWeights, &image, centreKept.data() };
  executor.For(0, voxelCount / rowLength, rowGrain, centreKernel);
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }
  return Status::Ok();
}

/// centreKept turned into componentKept (see UniformlyKept) for a whole image.
template <int Dim>
void KeepWholeComponents(
  const MaterialImage<Dim>& image, bool bodyOnly, std::vector<std::uint8_t>& kept)
{
  auto materialAt = [&](const LatticeIndex<Dim>& voxel) -> std::int32_t
  { return MaterialOrBodyAt<Dim>(image, bodyOnly, voxel); };
  auto unlinear = [](std::int64_t linear, const LatticeIndex<Dim>& dims)
  { return UnlinearIndex<Dim>(linear, dims); };

  // Whether each voxel's face-connected component has a voxel that keeps it: a search from each
  // voxel that does not, stopped at the first voxel that does (most components reach one
  // within a step or two; only components that have none are walked whole).
  // 1 or Uniform: kept, 0: unknown, 2: not kept.
  std::vector<std::uint8_t>& componentKept = kept;
  std::vector<std::int64_t> visited, stack;
  for (auto unknown = std::find(componentKept.begin(), componentKept.end(), 0);
       unknown != componentKept.end();
       unknown = std::find(unknown + 1, componentKept.end(), std::uint8_t{ 0 }))
  {
    const std::int64_t start = unknown - componentKept.begin();
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
          if (componentKept[index] == 1 || componentKept[index] == UniformlyKept)
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
}

/// The thin flags from the tests' majorities and componentKept.
template <int Dim, class Executor>
Status MarkThinVoxels(const MaterialImage<Dim>& image, bool bodyOnly,
  const std::vector<std::int32_t>& majority, const std::vector<std::uint8_t>& componentKept,
  std::vector<std::uint8_t>& thin, Executor& executor)
{
  std::int64_t voxelCount = 1;
  LatticeIndex<Dim> corners;
  for (int axis = 0; axis < Dim; ++axis)
  {
    voxelCount *= image.Dimensions[axis];
    corners[axis] = image.Dimensions[axis] + 1;
  }
  constexpr int Around = 1 << Dim;
  auto materialAt = [&](const LatticeIndex<Dim>& voxel) -> std::int32_t
  { return MaterialOrBodyAt<Dim>(image, bodyOnly, voxel); };
  auto unlinear = [](std::int64_t linear, const LatticeIndex<Dim>& dims)
  { return UnlinearIndex<Dim>(linear, dims); };

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
        // One material all around: its centre keeps it, and so does every corner of it (every
        // voxel around them is one of the 3^d).
        this->Thin[v] = this->ComponentKept[v] == UniformlyKept ? 0 : this->Test(v);
      }
    }
    std::uint8_t Test(std::int64_t v) const
    {
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
        return kept && joined ? 0 : 1;
      }
    }
  };
  ThinKernel thinKernel{ &materialAt, &unlinear, &image.Dimensions, &corners, majority.data(),
    componentKept.data(), thin.data() };
  executor.For(0, voxelCount, 1 << 14, thinKernel);
  return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
}
} // namespace detail

/// thin: one flag per voxel (axis 0 fastest), 1 for a thin voxel.
template <int Dim, class Executor>
Status ThinPartVoxels(const MaterialImage<Dim>& image, bool bodyOnly,
  std::vector<std::uint8_t>& thin, Executor& executor)
{
  std::vector<std::int32_t> majority;
  std::vector<std::uint8_t> kept;
  const Status tested = detail::ThinPartTests<Dim>(image, bodyOnly, majority, kept, executor);
  if (!tested.IsOk())
  {
    return tested;
  }
  detail::KeepWholeComponents<Dim>(image, bodyOnly, kept);
  return detail::MarkThinVoxels<Dim>(image, bodyOnly, majority, kept, thin, executor);
}

/// Voxels at a minority corner: a voxel of material m with a corner at which m holds less than
/// half of the 2^d voxels around it (a convex corner or edge of m's region; voxels beyond the
/// image count as background). A leaf larger than a voxel that covers such a voxel has that
/// corner as a mesh point, and the labels function there gives the leaf's part near it to another
/// material: an 8^3 block in a corner of a 16^3 image is one leaf whose corners all say
/// "background", and the cut loses it whole. Leaves of one voxel at these voxels bound the loss
/// to the corner's own voxel, as everywhere else. With bodyOnly the materials are the body and
/// the background. corner: one flag per voxel (axis 0 fastest), 1 at a minority corner.
template <int Dim, class Executor>
Status MinorityCornerVoxels(const MaterialImage<Dim>& image, bool bodyOnly,
  std::vector<std::uint8_t>& corner, Executor& executor)
{
  std::int64_t voxelCount = 0;
  const Status valid = detail::CountImageVoxels<Dim>(image, voxelCount);
  if (!valid.IsOk())
  {
    return valid;
  }
  corner.assign(static_cast<std::size_t>(voxelCount), 0);
  // Offsets of the rows beside a row (along the other axes): a voxel inside the image whose
  // neighbours along every axis have its value needs no count, and whole rows answer that in a
  // loop the compiler vectorizes (AAL upsampled 2.5 times, 111 million voxels: most of the
  // spacetree stage's 9 s with a lookup per neighbour).
  std::vector<std::int64_t> besideRows;
  {
    std::int64_t stride = image.Dimensions[0];
    for (int axis = 1; axis < Dim; ++axis)
    {
      besideRows.push_back(stride);
      besideRows.push_back(-stride);
      stride *= image.Dimensions[axis];
    }
  }
  struct CornerKernel
  {
    using Scratch = NoScratch;
    const MaterialImage<Dim>* Image;
    bool BodyOnly;
    const std::vector<std::int64_t>* BesideRows;
    std::uint8_t* Corner;

    std::int32_t MaterialAt(const LatticeIndex<Dim>& voxel) const
    {
      return detail::MaterialOrBodyAt<Dim>(*this->Image, this->BodyOnly, voxel);
    }

    void operator()(Scratch&, std::int64_t beginRow, std::int64_t endRow) const
    {
      const std::int64_t length = this->Image->Dimensions[0];
      std::vector<std::uint8_t> same;
      for (std::int64_t row = beginRow; row < endRow; ++row)
      {
        const std::int64_t start = row * length;
        if (length < 3 || !detail::RowWithin<Dim>(start, this->Image->Dimensions))
        {
          for (std::int64_t i = 0; i < length; ++i)
          {
            this->Check(start + i);
          }
          continue;
        }
        detail::SameAcrossRows<Dim>(*this->Image, start, length, *this->BesideRows, same);
        const MaterialIndex* values = this->Image->Values + start;
        this->Check(start);
        for (std::int64_t i = 1; i < length - 1; ++i)
        {
          if (!(same[i] && values[i - 1] == values[i] && values[i + 1] == values[i]))
          {
            this->Check(start + i);
          }
        }
        this->Check(start + length - 1);
      }
    }

    void Check(std::int64_t linear) const
    {
      constexpr int Around = 1 << Dim;
      const LatticeIndex<Dim> voxel = detail::UnlinearIndex<Dim>(linear, this->Image->Dimensions);
      const std::int32_t own = this->MaterialAt(voxel);
      // With every face neighbour of its material, m holds the voxel and its d neighbours
      // towards each corner: 1 + d of 2^d, never less than half. Most voxels end here.
      bool uniform = true;
      for (int axis = 0; axis < Dim && uniform; ++axis)
      {
        for (int step = -1; step <= 1 && uniform; step += 2)
        {
          LatticeIndex<Dim> neighbour = voxel;
          neighbour[axis] += step;
          uniform = neighbour[axis] >= 0 && neighbour[axis] < this->Image->Dimensions[axis] &&
            this->MaterialAt(neighbour) == own;
        }
      }
      if (uniform)
      {
        return;
      }
      for (int c = 0; c < Around && !this->Corner[linear]; ++c)
      {
        // Corner c of the voxel is at voxel + bits of c; the voxels around it are
        // corner - 1 + bits of k.
        int same = 0;
        for (int k = 0; k < Around; ++k)
        {
          LatticeIndex<Dim> around;
          for (int axis = 0; axis < Dim; ++axis)
          {
            around[axis] = voxel[axis] + ((c >> axis) & 1) - 1 + ((k >> axis) & 1);
          }
          same += this->MaterialAt(around) == own ? 1 : 0;
        }
        this->Corner[linear] = 2 * same < Around ? 1 : 0;
      }
    }
  };
  CornerKernel kernel{ &image, bodyOnly, &besideRows, corner.data() };
  const std::int64_t length = image.Dimensions[0];
  executor.For(0, voxelCount / length, std::max<std::int64_t>(1, (1 << 14) / length), kernel);
  return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
}

} // namespace stm

#endif
