// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreRefinementPlan_h
#define stmCoreRefinementPlan_h

// The level table of a spacetree: how large the cells of every level are, per axis.
//
// Levels are planned from the voxel up. Each step coarser multiplies the cell edges by the split
// counts of a refinement pattern: a fixed list (finest level first, the last entry repeating for
// all coarser levels, an axis that has reached the root cell size is no longer split), or
// "automatic": at every step the subset of axes to double that leaves the cells closest to
// cubes in physical units. The root cell size is either given per axis, or the largest the
// pattern reaches without exceeding MaxCellSize voxels on any axis and without growing beyond
// what the image needs. Below the voxel, levels are added (splitting the longest axes in two)
// until the cells are no larger than FinestSize, so that size criteria can refine below the
// image resolution.

#include "../Common/CubeInfo.h"
#include "../Common/Status.h"
#include "Spacetree.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace stm
{

/// Split counts per axis of one level of a refinement pattern.
template <int Dim>
using SplitCounts = std::array<int, Dim>;

template <int Dim>
struct RefinementPlanOptions
{
  /// Split counts, finest level first, the last entry repeating for all coarser levels; empty
  /// means automatic.
  std::vector<SplitCounts<Dim>> Pattern;
  /// Physical voxel edges per axis (positive); used by the automatic pattern and FinestSize.
  std::array<double, Dim> Spacing = UnitSpacing();
  /// Largest root cell edge in voxels, on every axis (>= 1); used when RootCellSize is unset.
  std::int64_t MaxCellSize = 16;
  /// Root cell edges in voxels; all zero chooses them automatically.
  LatticeIndex<Dim> RootCellSize{};
  /// Physical cell edge the finest level must not exceed; 0 or a size no smaller than the
  /// voxel adds no level below the voxel.
  double FinestSize = 0;

  static std::array<double, Dim> UnitSpacing()
  {
    std::array<double, Dim> spacing;
    spacing.fill(1.0);
    return spacing;
  }
};

/// The level table the plan produces.
template <int Dim>
struct RefinementPlan
{
  /// Cell edges per level in lattice units, root first.
  std::vector<LatticeIndex<Dim>> CellSizes;
  /// Lattice units per voxel.
  LatticeIndex<Dim> VoxelSubdivision{};
  /// The level whose cells are one voxel.
  int VoxelLevel = 0;

  int GetMaxLevel() const { return static_cast<int>(this->CellSizes.size()) - 1; }

  /// Largest physical edge of a cell of each level.
  std::vector<double> LargestEdges(const std::array<double, Dim>& spacing) const
  {
    std::vector<double> edges;
    for (const auto& size : this->CellSizes)
    {
      double largest = 0;
      for (int axis = 0; axis < Dim; ++axis)
      {
        largest = std::max(
          largest, static_cast<double>(size[axis]) / this->VoxelSubdivision[axis] * spacing[axis]);
      }
      edges.push_back(largest);
    }
    return edges;
  }

  /// The coarsest level whose cells have no physical edge longer than limit (the finest level
  /// when none is that small).
  int CoarsestLevelWithin(double limit, const std::vector<double>& largestEdges) const
  {
    const double tolerance = 1e-9 * limit;
    for (int level = 0; level < static_cast<int>(largestEdges.size()); ++level)
    {
      if (largestEdges[level] <= limit + tolerance)
      {
        return level;
      }
    }
    return this->GetMaxLevel();
  }

  /// Root cells per axis that cover an image of imageDimensions voxels (the last ones padded).
  LatticeIndex<Dim> RootGridDimensions(const LatticeIndex<Dim>& imageDimensions) const
  {
    LatticeIndex<Dim> roots;
    for (int axis = 0; axis < Dim; ++axis)
    {
      const std::int64_t extent = imageDimensions[axis] * this->VoxelSubdivision[axis];
      roots[axis] = (extent + this->CellSizes[0][axis] - 1) / this->CellSizes[0][axis];
    }
    return roots;
  }

  void ApplyTo(Spacetree<Dim>& tree) const
  {
    tree.MaxLevel = this->GetMaxLevel();
    tree.CellSizes = this->CellSizes;
    tree.VoxelSubdivision = this->VoxelSubdivision;
  }
};

/// Checks the split counts of a pattern: each in 1..MaximumSplitCount, none all ones.
template <int Dim>
Status ValidatePattern(const std::vector<SplitCounts<Dim>>& pattern)
{
  for (std::size_t entry = 0; entry < pattern.size(); ++entry)
  {
    bool splits = false;
    for (int axis = 0; axis < Dim; ++axis)
    {
      const int count = pattern[entry][axis];
      if (count < 1 || count > MaximumSplitCount)
      {
        return Status::Invalid("refinement pattern entry " + std::to_string(entry + 1) +
          ": split counts must be between 1 and " + std::to_string(MaximumSplitCount) + ", got " +
          std::to_string(count));
      }
      splits = splits || count > 1;
    }
    if (!splits)
    {
      return Status::Invalid("refinement pattern entry " + std::to_string(entry + 1) +
        " splits no axis (all counts are 1)");
    }
  }
  return Status::Ok();
}

namespace detail
{
inline int SmallestPrimeFactor(std::int64_t value)
{
  for (int factor = 2; static_cast<std::int64_t>(factor) * factor <= value; ++factor)
  {
    if (value % factor == 0)
    {
      return factor;
    }
  }
  return static_cast<int>(value);
}

/// Ratio of the longest to the shortest physical edge.
template <int Dim>
double AspectRatio(const LatticeIndex<Dim>& voxels, const std::array<double, Dim>& spacing)
{
  double shortest = voxels[0] * spacing[0], longest = shortest;
  for (int axis = 1; axis < Dim; ++axis)
  {
    shortest = std::min(shortest, voxels[axis] * spacing[axis]);
    longest = std::max(longest, voxels[axis] * spacing[axis]);
  }
  return longest / shortest;
}
} // namespace detail

template <int Dim>
Status PlanRefinement(const LatticeIndex<Dim>& imageDimensions,
  const RefinementPlanOptions<Dim>& options, RefinementPlan<Dim>& plan)
{
  Status status = ValidatePattern<Dim>(options.Pattern);
  if (!status.IsOk())
  {
    return status;
  }
  bool rootGiven = false;
  for (int axis = 0; axis < Dim; ++axis)
  {
    if (!(options.Spacing[axis] > 0) || !std::isfinite(options.Spacing[axis]))
    {
      return Status::Invalid("voxel spacing must be positive and finite");
    }
    if (imageDimensions[axis] < 1)
    {
      return Status::Invalid("image dimensions must be positive");
    }
    if (options.RootCellSize[axis] < 0)
    {
      return Status::Invalid("root cell sizes must be positive");
    }
    rootGiven = rootGiven || options.RootCellSize[axis] != 0;
  }
  if (rootGiven)
  {
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (options.RootCellSize[axis] < 1)
      {
        return Status::Invalid("root cell sizes must be positive on every axis");
      }
      if (options.RootCellSize[axis] > imageDimensions[axis] && imageDimensions[axis] > 1)
      {
        return Status::Invalid("the root cell size " + std::to_string(options.RootCellSize[axis]) +
          " along axis " + std::to_string(axis) + " is larger than the image (" +
          std::to_string(imageDimensions[axis]) + " voxels)");
      }
    }
  }
  else if (options.MaxCellSize < 1)
  {
    return Status::Invalid(
      "MaxCellSize must be at least 1 voxel, got " + std::to_string(options.MaxCellSize));
  }
  if (options.FinestSize < 0 || !std::isfinite(options.FinestSize))
  {
    return Status::Invalid("the finest cell size must be positive");
  }

  // Voxel level and coarser, in voxels, finest first.
  std::vector<LatticeIndex<Dim>> upward{ Spacetree<Dim>::UnitSize() };
  for (int step = 0;; ++step)
  {
    const LatticeIndex<Dim>& current = upward.back();
    std::array<bool, Dim> growable;
    bool anyGrowable = false;
    for (int axis = 0; axis < Dim; ++axis)
    {
      growable[axis] = rootGiven ? current[axis] < options.RootCellSize[axis]
                                 : current[axis] < imageDimensions[axis];
      anyGrowable = anyGrowable || growable[axis];
    }
    if (!anyGrowable)
    {
      break;
    }
    SplitCounts<Dim> splits;
    splits.fill(1);
    if (options.Pattern.empty())
    {
      // Automatic: the nonempty subset of axes whose multiplication leaves the cell closest to
      // a cube; ties go to the larger subset, then to the lower axes.
      double bestRatio = 0;
      int bestSize = 0;
      unsigned best = 0;
      for (unsigned subset = 1; subset < (1u << Dim); ++subset)
      {
        LatticeIndex<Dim> grown = current;
        SplitCounts<Dim> counts;
        counts.fill(1);
        bool valid = true;
        for (int axis = 0; axis < Dim && valid; ++axis)
        {
          if (!(subset & (1u << axis)))
          {
            continue;
          }
          if (rootGiven)
          {
            valid = growable[axis];
            counts[axis] =
              valid ? detail::SmallestPrimeFactor(options.RootCellSize[axis] / current[axis]) : 1;
          }
          else
          {
            counts[axis] = 2;
            valid = current[axis] * 2 <= options.MaxCellSize;
          }
          grown[axis] *= counts[axis];
        }
        bool growsNeeded = false;
        for (int axis = 0; axis < Dim; ++axis)
        {
          growsNeeded = growsNeeded || ((subset & (1u << axis)) && growable[axis]);
        }
        if (!valid || !growsNeeded)
        {
          continue;
        }
        const double ratio = detail::AspectRatio<Dim>(grown, options.Spacing);
        const int size = PopCount(subset);
        if (best == 0 || ratio < bestRatio * (1 - 1e-9) ||
          (ratio <= bestRatio * (1 + 1e-9) && size > bestSize))
        {
          best = subset;
          bestRatio = ratio;
          bestSize = size;
          splits = counts;
        }
      }
      // Without a given root, stop rather than make the cells less cubic (MaxCellSize reached
      // on some axes).
      if (best == 0 ||
        (!rootGiven && bestRatio > detail::AspectRatio<Dim>(current, options.Spacing) * (1 + 1e-9)))
      {
        break;
      }
    }
    else
    {
      const SplitCounts<Dim>& entry =
        options.Pattern[std::min<std::size_t>(step, options.Pattern.size() - 1)];
      bool growsNeeded = false;
      for (int axis = 0; axis < Dim; ++axis)
      {
        if (rootGiven)
        {
          if (!growable[axis])
          {
            continue; // this axis has reached the root cell size
          }
          splits[axis] = entry[axis];
          if (options.RootCellSize[axis] % (current[axis] * entry[axis]) != 0)
          {
            return Status::Invalid("the root cell size " +
              std::to_string(options.RootCellSize[axis]) + " along axis " + std::to_string(axis) +
              " is not reachable with the refinement pattern (" + std::to_string(current[axis]) +
              " voxels times " + std::to_string(entry[axis]) + ")");
          }
        }
        else
        {
          splits[axis] = entry[axis];
          if (current[axis] * entry[axis] > options.MaxCellSize)
          {
            splits.fill(0); // the next level would exceed MaxCellSize
            break;
          }
        }
        growsNeeded = growsNeeded || (growable[axis] && entry[axis] > 1);
      }
      if (splits[0] == 0)
      {
        break;
      }
      if (!growsNeeded)
      {
        if (rootGiven)
        {
          return Status::Invalid(
            "the refinement pattern never splits an axis the root cell size needs to grow");
        }
        break; // the pattern grows no axis the image still needs
      }
    }
    LatticeIndex<Dim> next = current;
    for (int axis = 0; axis < Dim; ++axis)
    {
      next[axis] *= splits[axis];
    }
    upward.push_back(next);
    if (static_cast<int>(upward.size()) > MaximumSupportedLevel + 1)
    {
      return Status::OutOfRange("the refinement pattern needs more than " +
        std::to_string(MaximumSupportedLevel) + " levels");
    }
  }

  // Below the voxel: halve the longest axes until no edge exceeds FinestSize.
  std::vector<SplitCounts<Dim>> downward;
  LatticeIndex<Dim> subdivision = Spacetree<Dim>::UnitSize();
  if (options.FinestSize > 0)
  {
    std::array<double, Dim> edge = options.Spacing;
    const double limit = options.FinestSize * (1 + 1e-9);
    for (;;)
    {
      const double longest = *std::max_element(edge.begin(), edge.end());
      if (longest <= limit)
      {
        break;
      }
      SplitCounts<Dim> splits;
      for (int axis = 0; axis < Dim; ++axis)
      {
        splits[axis] = edge[axis] > limit && edge[axis] >= longest / std::sqrt(2.0) ? 2 : 1;
        edge[axis] /= splits[axis];
        subdivision[axis] *= splits[axis];
        if (subdivision[axis] > 256)
        {
          return Status::OutOfRange("the finest cell size asks for cells below 1/256 of a voxel");
        }
      }
      downward.push_back(splits);
    }
  }

  const int levels = static_cast<int>(upward.size() + downward.size());
  if (levels > MaximumSupportedLevel + 1)
  {
    return Status::OutOfRange(
      "the spacetree would need more than " + std::to_string(MaximumSupportedLevel) + " levels");
  }
  plan.CellSizes.assign(static_cast<std::size_t>(levels), LatticeIndex<Dim>{});
  plan.VoxelSubdivision = subdivision;
  plan.VoxelLevel = static_cast<int>(upward.size()) - 1;
  for (int i = 0; i < static_cast<int>(upward.size()); ++i)
  {
    for (int axis = 0; axis < Dim; ++axis)
    {
      plan.CellSizes[plan.VoxelLevel - i][axis] = upward[i][axis] * subdivision[axis];
    }
  }
  LatticeIndex<Dim> size = subdivision;
  for (std::size_t i = 0; i < downward.size(); ++i)
  {
    for (int axis = 0; axis < Dim; ++axis)
    {
      size[axis] /= downward[i][axis];
    }
    plan.CellSizes[plan.VoxelLevel + 1 + i] = size;
  }
  // The lattice must stay addressable: 2^40 cells at most.
  for (int axis = 0; axis < Dim; ++axis)
  {
    if (imageDimensions[axis] > (std::int64_t{ 1 } << 40) / subdivision[axis])
    {
      return Status::OutOfRange("the refined lattice is too large");
    }
  }
  return Status::Ok();
}

/// Parses a refinement pattern: "auto" (an empty list), or comma-separated entries of split
/// counts joined by 'x', finest level first, e.g. "2x2x1,2x2x2". Every entry must have `counts`
/// numbers. False with a message on a syntax error; the counts themselves are checked by
/// ValidatePattern.
inline bool ParseRefinementPattern(
  const std::string& text, int counts, std::vector<std::vector<int>>& pattern, std::string& error)
{
  pattern.clear();
  std::string trimmed;
  for (char c : text)
  {
    if (c != ' ' && c != '\t')
    {
      trimmed += static_cast<char>(c == 'X' ? 'x' : c);
    }
  }
  if (trimmed.empty() || trimmed == "auto")
  {
    return true;
  }
  std::size_t start = 0;
  while (start <= trimmed.size())
  {
    const std::size_t end = std::min(trimmed.find(',', start), trimmed.size());
    const std::string entry = trimmed.substr(start, end - start);
    std::vector<int> values;
    std::size_t position = 0;
    while (position <= entry.size())
    {
      const std::size_t next = std::min(entry.find('x', position), entry.size());
      const std::string number = entry.substr(position, next - position);
      const bool digits = !number.empty() &&
        number.find_first_not_of("0123456789", number[0] == '-' ? 1 : 0) == std::string::npos &&
        number != "-" && number.size() < 9;
      if (!digits)
      {
        error = "refinement pattern \"" + text + "\": \"" + entry +
          "\" is not a list of split counts such as 2x2x1";
        return false;
      }
      values.push_back(std::stoi(number));
      position = next + 1;
    }
    if (static_cast<int>(values.size()) != counts)
    {
      error = "refinement pattern \"" + text + "\": entry \"" + entry + "\" has " +
        std::to_string(values.size()) + " split counts; the image needs " + std::to_string(counts);
      return false;
    }
    pattern.push_back(values);
    start = end + 1;
  }
  return true;
}

} // namespace stm

#endif
