// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreThinPartPieces_h
#define stmCoreThinPartPieces_h

// Thin parts (ThinParts.h) of an image that no piece holds whole: each piece reads a box of the
// image and classifies the voxels of that box as the whole image's classification does, without
// the rest of the image.
//
// Every test of the thin-part rules but one reads the voxels within one voxel of the voxel it
// tests, so a piece that reads its box grown by one voxel answers them itself. Rule (a) asks
// whether a voxel's whole face-connected component has a voxel that keeps its material at its
// centre, and a component can cross every piece. The pieces own disjoint boxes that cover the
// image, and each reads a box that holds its own grown by at least one voxel. Each piece labels
// the components within the box it reads and notes which of them have a kept voxel of its own
// box (only there is the centre test its own and exact). A voxel the piece reads but does not own
// is owned by another piece, which labelled it too: the two labels name parts of one component.
// Joining every such pair, over all voxels read by a piece other than their owner, joins all parts
// of every component: two face neighbours in one component are both read by the owner of the
// first, so a path through the component runs through the owners' labels and the joins between
// them. So the pieces:
//   1. Classify: run the local tests and label the components of the box they read;
//   2. send each piece whose box they read the labels of the voxels it owns (ComponentsIn), and
//      Join the labels they receive for their own voxels with their own labels;
//   3. send all pieces their Records (the joins and the flags of the components that cross their
//      own box's border), and Finish with every piece's records: a union-find over the components
//      that cross borders, the same on every piece, gives each component its whole flag.
// The exchanges are the caller's (an MPI controller in the filter, plain copies in the tests).

#include "ThinParts.h"

#include <algorithm>
#include <limits>
#include <tuple>
#include <unordered_map>

namespace stm
{

/// A box of voxels [Lower, Upper) of an image, per axis.
template <int Dim>
struct VoxelBox
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

  std::int64_t GetNumberOfVoxels() const
  {
    std::int64_t count = 1;
    for (int axis = 0; axis < Dim; ++axis)
    {
      count *= std::max<std::int64_t>(0, this->Upper[axis] - this->Lower[axis]);
    }
    return count;
  }

  LatticeIndex<Dim> GetDimensions() const
  {
    LatticeIndex<Dim> dims;
    for (int axis = 0; axis < Dim; ++axis)
    {
      dims[axis] = std::max<std::int64_t>(0, this->Upper[axis] - this->Lower[axis]);
    }
    return dims;
  }

  bool Contains(const LatticeIndex<Dim>& voxel) const
  {
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (voxel[axis] < this->Lower[axis] || voxel[axis] >= this->Upper[axis])
      {
        return false;
      }
    }
    return true;
  }

  bool Contains(const VoxelBox& other) const
  {
    for (int axis = 0; axis < Dim && !other.IsEmpty(); ++axis)
    {
      if (other.Lower[axis] < this->Lower[axis] || other.Upper[axis] > this->Upper[axis])
      {
        return false;
      }
    }
    return true;
  }

  VoxelBox Intersection(const VoxelBox& other) const
  {
    VoxelBox box;
    for (int axis = 0; axis < Dim; ++axis)
    {
      box.Lower[axis] = std::max(this->Lower[axis], other.Lower[axis]);
      box.Upper[axis] = std::min(this->Upper[axis], other.Upper[axis]);
    }
    return box;
  }

  /// Grown by `layers` voxels on every side and clipped to an image of `dims` voxels.
  VoxelBox Grown(std::int64_t layers, const LatticeIndex<Dim>& dims) const
  {
    VoxelBox box;
    for (int axis = 0; axis < Dim; ++axis)
    {
      box.Lower[axis] = std::max<std::int64_t>(0, this->Lower[axis] - layers);
      box.Upper[axis] = std::min<std::int64_t>(dims[axis], this->Upper[axis] + layers);
    }
    return box;
  }

  /// Calls f(linear index in the box, voxel) for every voxel, axis 0 fastest.
  template <class F>
  void ForEach(F&& f) const
  {
    if (this->IsEmpty())
    {
      return;
    }
    LatticeIndex<Dim> voxel = this->Lower;
    for (std::int64_t i = 0, count = this->GetNumberOfVoxels(); i < count; ++i)
    {
      f(i, voxel);
      for (int axis = 0; axis < Dim; ++axis)
      {
        if (++voxel[axis] < this->Upper[axis])
        {
          break;
        }
        voxel[axis] = this->Lower[axis];
      }
    }
  }
};

/// One piece's part of the thin-part classification of a distributed image (the file's comment).
template <int Dim>
class ThinPartPiece
{
public:
  /// Step 1. image: the voxels of `read`, a box of an image of wholeDims voxels that holds `owned`
  /// grown by one voxel (clipped to the image); piece: this piece's number among all.
  template <class Executor>
  Status Classify(const MaterialImage<Dim>& image, const VoxelBox<Dim>& read,
    const VoxelBox<Dim>& owned, const LatticeIndex<Dim>& wholeDims, bool bodyOnly, int piece,
    Executor& executor)
  {
    *this = ThinPartPiece();
    this->Read = read;
    this->Owned = owned;
    this->Piece = piece;
    this->BodyOnly = bodyOnly;
    if (owned.IsEmpty())
    {
      return Status::Ok(); // a piece without voxels takes part in the exchanges with nothing
    }
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (image.Dimensions[axis] != read.Upper[axis] - read.Lower[axis])
      {
        return Status::Invalid("the piece's image is not the size of the box it reads");
      }
    }
    if (!read.Contains(owned.Grown(1, wholeDims)) || read.Lower[0] < 0)
    {
      return Status::Invalid("a piece must read its own voxels grown by one voxel");
    }
    if (read.GetNumberOfVoxels() > std::numeric_limits<std::int32_t>::max())
    {
      return Status::Invalid("a piece reads more than 2^31 voxels");
    }
    this->Image = image;
    const Status tested =
      detail::ThinPartTests<Dim>(image, bodyOnly, this->Majority, this->Kept, executor);
    if (!tested.IsOk())
    {
      return tested;
    }
    this->LabelComponents();
    return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
  }

  /// Step 2, sending: the component of every voxel of `box` (within the box read), axis 0
  /// fastest; what the piece that owns `box` needs from this one.
  std::vector<std::int32_t> ComponentsIn(const VoxelBox<Dim>& box) const
  {
    std::vector<std::int32_t> components(
      static_cast<std::size_t>(box.IsEmpty() ? 0 : box.GetNumberOfVoxels()));
    if (!box.IsEmpty() && this->Read.Contains(box))
    {
      box.ForEach([&](std::int64_t i, const LatticeIndex<Dim>& voxel)
        { components[static_cast<std::size_t>(i)] = this->Labels[this->ReadIndex(voxel)]; });
    }
    return components;
  }

  /// Step 2, receiving: piece `other`'s ComponentsIn(box) for a box of own voxels it reads.
  Status Join(int other, const VoxelBox<Dim>& box, const std::vector<std::int32_t>& components)
  {
    if (box.IsEmpty())
    {
      return Status::Ok();
    }
    if (!this->Owned.Contains(box) ||
      static_cast<std::int64_t>(components.size()) != box.GetNumberOfVoxels())
    {
      return Status::Invalid("a piece sent components for voxels that are not this piece's");
    }
    std::int32_t lastOwn = -1, lastOther = -1;
    box.ForEach(
      [&](std::int64_t i, const LatticeIndex<Dim>& voxel)
      {
        const std::int32_t own = this->Labels[this->ReadIndex(voxel)];
        const std::int32_t theirs = components[static_cast<std::size_t>(i)];
        if (own != lastOwn || theirs != lastOther) // runs along axis 0 repeat the pair
        {
          this->Joins.push_back({ other, theirs, own });
          lastOwn = own;
          lastOther = theirs;
        }
      });
    std::sort(this->Joins.begin(), this->Joins.end());
    this->Joins.erase(std::unique(this->Joins.begin(), this->Joins.end()), this->Joins.end());
    return Status::Ok();
  }

  /// Step 3, sending: RecordWidth numbers per record; every piece needs every piece's records.
  static constexpr int RecordWidth = 4;
  std::vector<std::int64_t> Records() const
  {
    std::vector<std::int64_t> records;
    // A flag: -1, piece, component, flag.
    std::vector<std::uint8_t> listed(this->ComponentKept.size(), 0);
    auto addFlag = [&](std::int32_t component)
    {
      if (!listed[static_cast<std::size_t>(component)])
      {
        listed[static_cast<std::size_t>(component)] = 1;
        records.insert(records.end(),
          { -1, this->Piece, component, this->ComponentKept[static_cast<std::size_t>(component)] });
      }
    };
    for (std::size_t c = 0; c < this->Crosses.size(); ++c)
    {
      if (this->Crosses[c])
      {
        addFlag(static_cast<std::int32_t>(c));
      }
    }
    // A join: the other piece, its component, this piece (as its own), own component.
    for (const ComponentJoin& join : this->Joins)
    {
      addFlag(join.Own);
      records.insert(records.end(), { join.Other, join.Theirs, this->Piece, join.Own });
    }
    return records;
  }

  /// Step 3, receiving: every piece's Records one after the other; thin: one flag per voxel of the
  /// box read (axis 0 fastest), the whole image's flags on every voxel whose voxels within one
  /// voxel are read or beyond the image (the box read shrunk by one voxel at its inner sides).
  template <class Executor>
  Status Finish(
    const std::vector<std::int64_t>& records, std::vector<std::uint8_t>& thin, Executor& executor)
  {
    thin.clear();
    if (records.size() % RecordWidth != 0)
    {
      return Status::Invalid("the pieces' thin-part records are cut short");
    }
    // A union-find over the components named in the records (the same on every piece).
    std::unordered_map<std::int64_t, std::int64_t> nodes;
    std::vector<std::int64_t> parents;
    std::vector<std::uint8_t> kept;
    auto node = [&](std::int64_t piece, std::int64_t component)
    {
      const auto inserted = nodes.emplace((piece << 32) | component, parents.size());
      if (inserted.second)
      {
        parents.push_back(static_cast<std::int64_t>(parents.size()));
        kept.push_back(0);
      }
      return inserted.first->second;
    };
    auto root = [&](std::int64_t n)
    {
      while (parents[n] != n)
      {
        parents[n] = parents[parents[n]];
        n = parents[n];
      }
      return n;
    };
    for (std::size_t at = 0; at < records.size(); at += RecordWidth)
    {
      const std::int64_t* record = records.data() + at;
      if (record[0] == -1)
      {
        kept[node(record[1], record[2])] |= record[3] != 0 ? 1 : 0;
      }
      else
      {
        const std::int64_t a = root(node(record[0], record[1]));
        const std::int64_t b = root(node(record[2], record[3]));
        parents[std::max(a, b)] = std::min(a, b);
      }
    }
    for (std::size_t n = 0; n < parents.size(); ++n)
    {
      kept[root(n)] |= kept[n];
    }
    std::vector<std::uint8_t> wholeKept = this->ComponentKept;
    for (std::size_t c = 0; c < wholeKept.size(); ++c)
    {
      const auto found = nodes.find((std::int64_t{ this->Piece } << 32) | std::int64_t(c));
      if (found != nodes.end())
      {
        wholeKept[c] = kept[root(found->second)];
      }
    }
    if (this->Owned.IsEmpty())
    {
      return Status::Ok();
    }
    // componentKept as detail::MarkThinVoxels reads it.
    for (std::size_t v = 0; v < this->Kept.size(); ++v)
    {
      if (this->Kept[v] != detail::UniformlyKept)
      {
        this->Kept[v] = wholeKept[static_cast<std::size_t>(this->Labels[v])] ? 1 : 2;
      }
    }
    this->Labels = std::vector<std::int32_t>();
    return detail::MarkThinVoxels<Dim>(
      this->Image, this->BodyOnly, this->Majority, this->Kept, thin, executor);
  }

  /// The number of thin voxels of the own box in Finish's flags.
  std::int64_t CountOwnThinVoxels(const std::vector<std::uint8_t>& thin) const
  {
    std::int64_t count = 0;
    if (thin.size() == static_cast<std::size_t>(this->Read.GetNumberOfVoxels()))
    {
      this->Owned.ForEach([&](std::int64_t, const LatticeIndex<Dim>& voxel)
        { count += thin[this->ReadIndex(voxel)]; });
    }
    return count;
  }

private:
  struct ComponentJoin
  {
    std::int64_t Other;
    std::int32_t Theirs;
    std::int32_t Own;
    bool operator<(const ComponentJoin& b) const
    {
      return std::tie(this->Other, this->Theirs, this->Own) < std::tie(b.Other, b.Theirs, b.Own);
    }
    bool operator==(const ComponentJoin& b) const
    {
      return this->Other == b.Other && this->Theirs == b.Theirs && this->Own == b.Own;
    }
  };

  std::size_t ReadIndex(const LatticeIndex<Dim>& voxel) const
  {
    std::int64_t linear = 0;
    for (int axis = Dim - 1; axis >= 0; --axis)
    {
      linear = linear * (this->Read.Upper[axis] - this->Read.Lower[axis]) + voxel[axis] -
        this->Read.Lower[axis];
    }
    return static_cast<std::size_t>(linear);
  }

  /// Labels the face-connected components of one material in the box read (numbered in the
  /// order of their first voxels), whether each has a kept voxel of the own box, and whether it
  /// has a voxel beyond the own box.
  void LabelComponents()
  {
    const std::int64_t count = this->Read.GetNumberOfVoxels();
    std::vector<std::int32_t>& parents = this->Labels;
    parents.resize(static_cast<std::size_t>(count));
    auto root = [&parents](std::int32_t v)
    {
      while (parents[v] != v)
      {
        parents[v] = parents[parents[v]];
        v = parents[v];
      }
      return v;
    };
    auto materialOf = [this](std::int64_t v) -> std::int32_t
    {
      const MaterialIndex material = this->Image.Values[v];
      return this->BodyOnly ? (material == BackgroundMaterial ? 0 : 1) : material;
    };
    std::int64_t strides[Dim];
    for (std::int64_t axis = 0, stride = 1; axis < Dim; ++axis)
    {
      strides[axis] = stride;
      stride *= this->Image.Dimensions[axis];
    }
    const VoxelBox<Dim> local{ LatticeIndex<Dim>{}, this->Image.Dimensions };
    local.ForEach(
      [&](std::int64_t v, const LatticeIndex<Dim>& voxel)
      {
        parents[v] = static_cast<std::int32_t>(v);
        const std::int32_t own = materialOf(v);
        for (int axis = 0; axis < Dim; ++axis)
        {
          if (voxel[axis] > 0 && materialOf(v - strides[axis]) == own)
          {
            const std::int32_t a = root(static_cast<std::int32_t>(v));
            const std::int32_t b = root(static_cast<std::int32_t>(v - strides[axis]));
            parents[std::max(a, b)] = std::min(a, b);
          }
        }
      });
    // Every parent precedes its child, so one pass in order points every voxel at its root, and
    // a second numbers the roots in order and gives the others their root's number.
    for (std::int64_t v = 0; v < count; ++v)
    {
      parents[v] = parents[parents[v]];
    }
    std::int32_t components = 0;
    for (std::int64_t v = 0; v < count; ++v)
    {
      const std::int32_t r = parents[v];
      parents[v] = r == v ? components++ : parents[r];
    }
    this->ComponentKept.assign(static_cast<std::size_t>(components), 0);
    this->Crosses.assign(static_cast<std::size_t>(components), 0);
    this->Read.ForEach(
      [&](std::int64_t v, const LatticeIndex<Dim>& voxel)
      {
        const auto c = static_cast<std::size_t>(parents[v]);
        if (this->Owned.Contains(voxel))
        {
          this->ComponentKept[c] |= this->Kept[v] != 0 ? 1 : 0;
        }
        else
        {
          this->Crosses[c] = 1;
        }
      });
  }

  VoxelBox<Dim> Read;
  VoxelBox<Dim> Owned;
  int Piece = 0;
  bool BodyOnly = false;
  MaterialImage<Dim> Image;
  std::vector<std::int32_t> Majority;
  /// centreKept of detail::ThinPartTests, and componentKept in Finish.
  std::vector<std::uint8_t> Kept;
  /// Per voxel read, its component.
  std::vector<std::int32_t> Labels;
  /// Per component, whether a voxel of the own box keeps it, and whether it has a voxel read but
  /// not owned.
  std::vector<std::uint8_t> ComponentKept;
  std::vector<std::uint8_t> Crosses;
  std::vector<ComponentJoin> Joins;
};

} // namespace stm

#endif
