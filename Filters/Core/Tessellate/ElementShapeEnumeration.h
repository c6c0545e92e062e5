// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreElementShapeEnumeration_h
#define stmCoreElementShapeEnumeration_h

// Every element the tessellation of SpacetreeTessellation.h can put into a leaf of an L-balanced
// spacetree, enumerated: the finite set of shapes of the paper's section 4 ("the non-uniform
// meshing algorithm does generate only a finite number of different tetrahedra, the worst-case
// quality depending essentially on the balancing level"), from which quality bounds follow.
//
// Take a leaf C of level l. Balance level L (all neighbours, not only facet neighbours) keeps
// every leaf touching C's closure at level <= l + L, so a face on C's boundary at canonical
// level m can be split (into its children at m + 1) or irregular (a split edge on its boundary)
// only if m < l + L. The enumeration follows the tessellator's rules face by face - split: the
// cells of the children; unsplit and regular: the template; unsplit and irregular: the
// midpoint cone over the facets' cells, or with extended templates the cone from a corner over
// the shallow facets not containing it - but lets every face take every configuration its
// level allows, independently of its neighbours and of the tree around it. The result is a
// superset of the cells any real tree gives C, so a worst value over it bounds every mesh.
// Conditions the tessellator also checks but the enumeration does not (neighbouring faces that
// must agree, "the near facets are cones from the corner" of extended templates) only remove
// cells, so leaving them out keeps the superset.
//
// C's level coordinates enter through the checkerboard parity only; the enumeration runs C over
// the anchors (0 or 1 per axis, in level-l cells) that give different parities to the faces
// below it, and returns the cells relative to C's anchor.

#include "../Common/CubeInfo.h"
#include "../Common/Status.h"
#include "SpacetreeTessellation.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <numeric>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace stm
{

/// A similarity invariant of a point set: its squared distances, sorted, divided by their
/// greatest common divisor. Exact on integer points, independent of the points' order, of
/// translation, of the lattice's symmetries and of scaling.
template <int Dim>
std::vector<std::int64_t> SimilarityKey(const LatticeIndex<Dim>* points, int count)
{
  std::vector<std::int64_t> key;
  std::int64_t divisor = 0;
  for (int a = 0; a < count; ++a)
  {
    for (int b = a + 1; b < count; ++b)
    {
      std::int64_t squared = 0;
      for (int axis = 0; axis < Dim; ++axis)
      {
        const std::int64_t delta = points[b][axis] - points[a][axis];
        squared += delta * delta;
      }
      key.push_back(squared);
      divisor = std::gcd(divisor, squared);
    }
  }
  for (auto& squared : key)
  {
    squared /= divisor;
  }
  std::sort(key.begin(), key.end());
  return key;
}

struct ElementShapeEnumerationOptions
{
  CellTemplate Template = CellTemplate::Checkerboard;
  /// Simplices or Hybrid (Leaves has nothing to enumerate).
  TessellationOutput Output = TessellationOutput::Simplices;
  TemplateRule Templates = TemplateRule::RegularFaces;
  /// Largest level difference between leaves that share a point; 0 is a uniform tree.
  int BalanceLevel = 1;
};

template <int Dim>
class ElementShapeEnumerator
{
public:
  using Point = LatticeIndex<Dim>; // half lattice units, as in the tessellator

  /// Appends to cells every distinct cell the tessellation can give a leaf of level leafLevel
  /// of a tree with the level table cellSizes (lattice units, root first), in half lattice
  /// units relative to the leaf's anchor, positively oriented (CellDeterminant), in the
  /// tessellator's point order (CellPointCount).
  Status Enumerate(const std::vector<LatticeIndex<Dim>>& cellSizes, int leafLevel,
    const ElementShapeEnumerationOptions& options, TessellationCells<Dim>& cells)
  {
    const Status status = this->Setup(cellSizes, leafLevel, options);
    if (!status.IsOk())
    {
      return status;
    }
    std::vector<Cell> leafCells;
    std::set<std::vector<int>> parityPatterns;
    for (unsigned code = 0; code < (1u << Dim); ++code)
    {
      LatticeIndex<Dim> anchor;
      for (int axis = 0; axis < Dim; ++axis)
      {
        anchor[axis] = ((code >> axis) & 1u) * cellSizes[leafLevel][axis];
      }
      // Anchors that give the faces of every level the same parity give the same cells.
      if (!parityPatterns.insert(this->ParityPattern(anchor, leafLevel)).second)
      {
        continue;
      }
      this->Memo.clear();
      FaceCells result;
      this->AppendUnsplit(
        Face{ anchor, leafLevel, (1u << Dim) - 1u }, leafLevel < this->DeepestLevel, result);
      const Point origin = HalfUnits(anchor);
      for (Cell& cell : result.All)
      {
        for (int p = 0; p < cell.Count; ++p)
        {
          Point point = Unpack(cell.Points[p]);
          for (int axis = 0; axis < Dim; ++axis)
          {
            point[axis] -= origin[axis]; // inside the leaf: not negative
          }
          cell.Points[p] = Pack(point);
        }
      }
      leafCells.insert(leafCells.end(), result.All.begin(), result.All.end());
    }
    this->Memo.clear();
    Deduplicate(leafCells);
    TessellationCells<Dim> found;
    for (const Cell& cell : leafCells)
    {
      for (int p = 0; p < cell.Count; ++p)
      {
        found.Points.push_back(Unpack(cell.Points[p]));
      }
      found.Shapes.push_back(cell.Shape);
    }
    SpacetreeTessellator<Dim>::Orient(found);
    cells.Points.insert(cells.Points.end(), found.Points.begin(), found.Points.end());
    cells.Shapes.insert(cells.Shapes.end(), found.Shapes.begin(), found.Shapes.end());
    return Status::Ok();
  }

private:
  using Face = SpacetreeFace<Dim>;

  /// A cell with its points packed into one word each, in the tessellator's point order.
  struct Cell
  {
    std::array<std::uint64_t, (1 << Dim)> Points{};
    std::uint8_t Shape = 0;
    std::uint8_t Count = 0;
  };

  /// The cells a face can have: in any configuration, and in those where it is shallow (split
  /// at most once, into unsplit children that take their templates), which is what extended
  /// templates may cone over.
  struct FaceCells
  {
    std::vector<Cell> All;
    std::vector<Cell> Shallow;
  };

  static constexpr int BitsPerCoordinate = 62 / Dim;

  static std::uint64_t Pack(const Point& point)
  {
    std::uint64_t word = 0;
    for (int axis = 0; axis < Dim; ++axis)
    {
      word |= static_cast<std::uint64_t>(point[axis]) << (axis * BitsPerCoordinate);
    }
    return word;
  }

  static Point Unpack(std::uint64_t word)
  {
    constexpr std::uint64_t mask = (std::uint64_t{ 1 } << BitsPerCoordinate) - 1;
    Point point;
    for (int axis = 0; axis < Dim; ++axis)
    {
      point[axis] = static_cast<std::int64_t>((word >> (axis * BitsPerCoordinate)) & mask);
    }
    return point;
  }

  Status Setup(const std::vector<LatticeIndex<Dim>>& cellSizes, int leafLevel,
    const ElementShapeEnumerationOptions& options)
  {
    if (options.Output == TessellationOutput::Leaves)
    {
      return Status::Invalid("leaves output has no tessellation to enumerate");
    }
    if (options.BalanceLevel < 0)
    {
      return Status::Invalid("the balance level must not be negative");
    }
    if (options.Template == CellTemplate::Checkerboard && Dim > 3 &&
      options.Output == TessellationOutput::Simplices &&
      options.Templates != TemplateRule::MidpointEverywhere)
    {
      return Status::Invalid("the checkerboard template exists for dimensions 1 to 3 only");
    }
    if (cellSizes.empty() || leafLevel < 0 || leafLevel >= static_cast<int>(cellSizes.size()))
    {
      return Status::Invalid("the leaf level is not a level of the table");
    }
    for (int axis = 0; axis < Dim; ++axis)
    {
      // The leaf's anchor is at most one root size from the origin: points within two in
      // lattice units, four in half units.
      if (cellSizes[0][axis] < 1 ||
        4 * cellSizes[0][axis] >= (std::int64_t{ 1 } << BitsPerCoordinate))
      {
        return Status::OutOfRange("the level table is too large to enumerate");
      }
    }
    this->Options = options;
    this->Sizes = cellSizes;
    const int maxLevel = static_cast<int>(cellSizes.size()) - 1;
    this->DeepestLevel = std::min(leafLevel + options.BalanceLevel, maxLevel);

    this->Tables.Build(cellSizes.data(), static_cast<int>(cellSizes.size()), options.Template);
    return Status::Ok();
  }

  /// Per level from the leaf's down, the parity its faces' level coordinates inherit from the
  /// leaf's anchor.
  std::vector<int> ParityPattern(const LatticeIndex<Dim>& anchor, int leafLevel) const
  {
    std::vector<int> pattern;
    for (int level = leafLevel; level <= this->DeepestLevel; ++level)
    {
      std::int64_t sum = 0;
      for (int axis = 0; axis < Dim; ++axis)
      {
        sum += anchor[axis] / this->Sizes[level][axis];
      }
      pattern.push_back(static_cast<int>(sum & 1));
    }
    return pattern;
  }

  int CanonicalLevel(int level, unsigned axes) const
  {
    return this->Tables.CanonicalLevel(level, axes);
  }

  /// Whether an unsplit, regular face of dimension >= 2 takes its template (the tessellator's
  /// TakesTemplate without the regularity).
  bool HasTemplate(const Face& face) const
  {
    if (this->Options.Output == TessellationOutput::Hybrid)
    {
      return true;
    }
    return this->Options.Templates != TemplateRule::MidpointEverywhere &&
      (PopCount(face.FreeAxes) < 3 || this->Tables.TemplateAllowed[face.Level]);
  }

  /// The cells of a face over all admissible configurations, memoized by face.
  const FaceCells& CellsOf(Face face)
  {
    face.Level = this->CanonicalLevel(face.Level, face.FreeAxes);
    std::array<std::int64_t, Dim + 2> key;
    std::copy(face.Anchor.begin(), face.Anchor.end(), key.begin());
    key[Dim] = face.Level;
    key[Dim + 1] = face.FreeAxes;
    auto found = this->Memo.find(key);
    if (found != this->Memo.end())
    {
      return found->second;
    }
    FaceCells result;
    const int k = PopCount(face.FreeAxes);
    // Split or irregular needs a leaf of the next level touching the face.
    const bool deeper = face.Level < this->DeepestLevel;
    if (deeper)
    {
      this->ForEachChildFace(face,
        [&](Face child)
        {
          const FaceCells& childCells = this->CellsOf(child);
          result.All.insert(result.All.end(), childCells.All.begin(), childCells.All.end());
          child.Level = this->CanonicalLevel(child.Level, child.FreeAxes);
          if (this->NeedsShallow() && (k == 1 || this->HasTemplate(child)))
          {
            this->AppendTemplate(child, result.Shallow);
          }
        });
    }
    this->AppendUnsplit(face, deeper, result);
    Deduplicate(result.All);
    Deduplicate(result.Shallow);
    return this->Memo.emplace(key, std::move(result)).first->second;
  }

  bool NeedsShallow() const
  {
    return this->Options.Output == TessellationOutput::Simplices &&
      this->Options.Templates == TemplateRule::Extended;
  }

  /// The cells of an unsplit face (canonical level): its template if it is regular, and if it
  /// can be irregular (or has no template), the midpoint cone and the extended cones.
  void AppendUnsplit(const Face& face, bool canBeIrregular, FaceCells& result)
  {
    const int k = PopCount(face.FreeAxes);
    const bool hasTemplate = k == 1 || this->HasTemplate(face);
    if (hasTemplate)
    {
      this->AppendTemplate(face, result.All);
      if (this->NeedsShallow())
      {
        this->AppendTemplate(face, result.Shallow);
      }
    }
    if (k == 1 || (hasTemplate && !canBeIrregular))
    {
      return;
    }
    Point centre = HalfUnits(face.Anchor);
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (face.FreeAxes & (1u << axis))
      {
        centre[axis] += this->Sizes[face.Level][axis];
      }
    }
    for (int freeIndex = 0; freeIndex < k; ++freeIndex)
    {
      for (int side = 0; side < 2; ++side)
      {
        const FaceCells& facet = this->CellsOf(this->Facet(face, freeIndex, side));
        AppendCone(centre, facet.All, result.All);
        if (this->NeedsShallow())
        {
          AppendCone(centre, facet.Shallow, result.Shallow);
        }
      }
    }
    if (!this->NeedsShallow())
    {
      return;
    }
    // Extended templates: the cone from a corner over the (shallow) facets not containing it.
    for (unsigned c = 0; c < (1u << k); ++c)
    {
      const Point apex =
        BoxCorner<Dim>(HalfUnits(face.Anchor), this->Sizes[face.Level], face.FreeAxes, c);
      for (int freeIndex = 0; freeIndex < k; ++freeIndex)
      {
        const int farSide = 1 - static_cast<int>((c >> freeIndex) & 1u);
        const FaceCells& facet = this->CellsOf(this->Facet(face, freeIndex, farSide));
        AppendCone(apex, facet.Shallow, result.All);
        AppendCone(apex, facet.Shallow, result.Shallow);
      }
    }
  }

  static void AppendCone(const Point& apex, const std::vector<Cell>& base, std::vector<Cell>& out)
  {
    const std::uint64_t packedApex = Pack(apex);
    for (const Cell& cell : base)
    {
      Cell cone;
      cone.Shape = cell.Shape;
      cone.Count = static_cast<std::uint8_t>(cell.Count + 1);
      cone.Points[0] = packedApex;
      std::copy(cell.Points.begin(), cell.Points.begin() + cell.Count, cone.Points.begin() + 1);
      out.push_back(cone);
    }
  }

  /// The template of a face at its canonical level, exactly as the tessellator builds it.
  void AppendTemplate(const Face& face, std::vector<Cell>& out) const
  {
    std::int64_t sum = 0;
    for (int axis = 0; axis < Dim; ++axis)
    {
      sum += face.Anchor[axis] / this->Sizes[face.Level][axis];
    }
    TessellationCells<Dim> cells;
    AppendBoxTemplate<Dim>(this->Options.Template,
      this->Options.Output == TessellationOutput::Hybrid, HalfUnits(face.Anchor),
      this->Sizes[face.Level], static_cast<int>(sum & 1), face.FreeAxes, cells);
    const int k = PopCount(face.FreeAxes);
    auto point = cells.Points.begin();
    for (std::uint8_t shape : cells.Shapes)
    {
      Cell cell;
      cell.Shape = shape;
      cell.Count = static_cast<std::uint8_t>(CellPointCount(k, shape));
      for (int p = 0; p < cell.Count; ++p)
      {
        cell.Points[p] = Pack(*point++);
      }
      out.push_back(cell);
    }
  }

  static Point HalfUnits(const LatticeIndex<Dim>& latticePoint)
  {
    Point point;
    for (int axis = 0; axis < Dim; ++axis)
    {
      point[axis] = 2 * latticePoint[axis];
    }
    return point;
  }

  Face Facet(const Face& face, int freeIndex, int side) const
  {
    return FacetOf<Dim>(face, this->Sizes[face.Level], freeIndex, side);
  }

  template <class Visitor>
  void ForEachChildFace(const Face& face, Visitor&& visit) const
  {
    const LatticeIndex<Dim>& size = this->Sizes[face.Level];
    const LatticeIndex<Dim>& childSize = this->Sizes[face.Level + 1];
    ForEachChildAnchor<Dim>(face.Anchor, size, childSize, face.FreeAxes,
      [&](const LatticeIndex<Dim>& anchor) {
        visit(Face{ anchor, face.Level + 1, face.FreeAxes });
      });
  }

  /// Keeps one cell per point set: the same cell can come from several configurations.
  static void Deduplicate(std::vector<Cell>& cells)
  {
    using Key = std::pair<std::array<std::uint64_t, (1 << Dim)>, std::uint8_t>;
    std::vector<std::pair<Key, std::size_t>> keys;
    keys.reserve(cells.size());
    for (std::size_t i = 0; i < cells.size(); ++i)
    {
      Key key{ cells[i].Points, cells[i].Shape };
      std::sort(key.first.begin(), key.first.begin() + cells[i].Count);
      keys.emplace_back(key, i);
    }
    std::sort(keys.begin(), keys.end());
    std::vector<Cell> unique;
    unique.reserve(cells.size());
    for (std::size_t i = 0; i < keys.size(); ++i)
    {
      if (i == 0 || keys[i].first != keys[i - 1].first)
      {
        unique.push_back(cells[keys[i].second]);
      }
    }
    cells.swap(unique);
  }

  ElementShapeEnumerationOptions Options;
  std::vector<LatticeIndex<Dim>> Sizes;
  /// The finest level a face on the leaf's boundary can be split into.
  int DeepestLevel = 0;
  TessellationLevelTables<Dim> Tables;
  std::map<std::array<std::int64_t, Dim + 2>, FaceCells> Memo;
};

/// The level table of isotropic refinement by factor per axis, levels 0 to levels - 1.
template <int Dim>
std::vector<LatticeIndex<Dim>> IsotropicCellSizes(int factor, int levels)
{
  std::vector<LatticeIndex<Dim>> sizes(static_cast<std::size_t>(levels));
  std::int64_t size = 1;
  for (int level = levels - 1; level >= 0; --level)
  {
    sizes[level].fill(size);
    size *= factor;
  }
  return sizes;
}

} // namespace stm

#endif
