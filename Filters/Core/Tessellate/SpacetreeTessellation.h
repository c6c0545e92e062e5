// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSpacetreeTessellation_h
#define stmCoreSpacetreeTessellation_h

// Direct conforming simplicial tessellation of the spacetree leaves (paper sections 2.3, 2.4).
//
// Every k-face F of the spacetree (a k-box of some level) gets a triangulation that depends on
// F and the tree only, which makes the mesh consistent across faces by construction, for any
// level difference and any refinement pattern:
//  - F is split if a finer leaf touches it; its triangulation is then the union of those of its
//    children faces at the next level;
//  - otherwise, if no leaf corner lies on F's boundary besides F's corners, F is regular and
//    takes the template of its level;
//  - otherwise the centre of F is inserted and joined to the triangulations of its 2k facets
//    (the recursive midpoint rule).
// A leaf is treated as an unsplit Dim-face.
//
// With anisotropic patterns the same geometric face can be a face of cells of several levels
// (a pattern that does not split any of its axes); it is always handled at the finest such level,
// its canonical level, so that it has one triangulation. At the canonical level at least one of
// its axes is split by the next level. If all its axes are, F is split exactly when the first
// next-level lattice point inside F is a leaf corner (the set V); otherwise the level of the
// leaves around F decides, read from a level map. An edge is split exactly when its first
// next-level point is in V, so regularity reads one bit per edge.
//
// Templates: Checkerboard (Dim <= 3, the paper's choice) cuts a square along the diagonal
// between its corners of even level-coordinate sum and a cube into the tetrahedron of its even
// corners plus one tetrahedron per odd corner (5 in all); a cell takes it only where its square
// faces have the cell's own level as canonical level (patterns that leave at most one axis
// unsplit), and the midpoint rule otherwise. Kuhn cuts a k-box into the k! simplices along
// monotone corner paths, in any dimension and for any pattern.
//
// Points live on the lattice of half lattice units (face centres of the finest cells); the
// used ones are numbered in lattice order through a bitset rank, so the numbering does not
// depend on the number of threads. Simplices are emitted leaf by leaf in leaf order.

#include "../Common/CubeInfo.h"
#include "../Common/Execution.h"
#include "../Common/LatticeBitset.h"
#include "../Common/Status.h"
#include "../Spacetree/LevelMap.h"
#include "../Spacetree/Spacetree.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <numeric>
#include <utility>
#include <vector>

namespace stm
{

enum class CellTemplate
{
  Checkerboard = 0,
  Kuhn = 1
};

struct SpacetreeTessellationOptions
{
  CellTemplate Template = CellTemplate::Checkerboard;
  /// Tessellate the background leaves too, not only the body of interest.
  bool IncludeBackground = false;
};

/// Exact orientation of a simplex given by Dim+1 integer points: the sign of the determinant of
/// the edge vectors from the first point.
template <int Dim>
std::int64_t SimplexDeterminant(const LatticeIndex<Dim>* points)
{
  std::array<std::array<std::int64_t, Dim>, Dim> m;
  for (int row = 0; row < Dim; ++row)
  {
    for (int col = 0; col < Dim; ++col)
    {
      m[row][col] = points[row + 1][col] - points[0][col];
    }
  }
  if constexpr (Dim == 1)
  {
    return m[0][0];
  }
  else if constexpr (Dim == 2)
  {
    return m[0][0] * m[1][1] - m[0][1] * m[1][0];
  }
  else if constexpr (Dim == 3)
  {
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
      m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
      m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  }
  else
  {
    // Bareiss fraction-free elimination: exact for integer matrices.
    std::int64_t sign = 1;
    std::int64_t previous = 1;
    for (int k = 0; k < Dim - 1; ++k)
    {
      if (m[k][k] == 0)
      {
        int swap = k + 1;
        while (swap < Dim && m[swap][k] == 0)
        {
          ++swap;
        }
        if (swap == Dim)
        {
          return 0;
        }
        std::swap(m[k], m[swap]);
        sign = -sign;
      }
      for (int i = k + 1; i < Dim; ++i)
      {
        for (int j = k + 1; j < Dim; ++j)
        {
          m[i][j] = (m[i][j] * m[k][k] - m[i][k] * m[k][j]) / previous;
        }
      }
      previous = m[k][k];
    }
    return sign * m[Dim - 1][Dim - 1];
  }
}

template <int Dim>
class SpacetreeTessellator
{
public:
  using Point = LatticeIndex<Dim>; // in half lattice units

  /// A k-face of the spacetree: a box of the edges of Level at Anchor, spanning the axes set in
  /// FreeAxes.
  struct Face
  {
    LatticeIndex<Dim> Anchor;
    int Level;
    unsigned FreeAxes;
  };

  struct Scratch
  {
    std::vector<Point> Simplices;
    std::array<std::vector<Point>, Dim + 1> FacetBuffers;
  };

  /// Counts the simplices of every selected leaf and numbers the points they use.
  template <class Executor>
  Status Prepare(
    const Spacetree<Dim>& tree, const SpacetreeTessellationOptions& options, Executor& executor)
  {
    if (options.Template == CellTemplate::Checkerboard && Dim > 3)
    {
      return Status::Invalid("the checkerboard template exists for dimensions 1 to 3 only");
    }
    this->Tree = &tree;
    this->Sizes = tree.CellSizes.data();
    this->MaxLevel = tree.MaxLevel;
    this->Options = options;
    this->BuildLevelTables();
    this->BuildRegularCellTables();
    if (this->NeedsLevelMap)
    {
      this->Map.reset(new LevelMap<Dim>());
      const Status status = this->Map->Build(tree, executor);
      if (!status.IsOk())
      {
        return status;
      }
    }

    const LatticeIndex<Dim> latticeDims = tree.GetLatticeDimensions();
    LatticeIndex<Dim> vertexDims, pointDims;
    for (int axis = 0; axis < Dim; ++axis)
    {
      vertexDims[axis] = latticeDims[axis] + 1;
      pointDims[axis] = 2 * latticeDims[axis] + 1;
    }
    this->LatticeDimensions = latticeDims;
    this->VertexSet = LatticeBitset<Dim>(vertexDims);
    this->PointSet = LatticeBitset<Dim>(pointDims);

    const std::int64_t leaves = tree.GetNumberOfLeaves();
    MarkVerticesKernel markVertices{ this };
    executor.For(0, leaves, 8192, markVertices);
    if (executor.ShouldAbort())
    {
      return Status::Aborted();
    }
    executor.ReportProgress(0.1);

    this->SimplexOffsets.assign(static_cast<std::size_t>(leaves + 1), 0);
    CountKernel<Executor> count{ this, &executor };
    executor.For(0, leaves, 2048, count);
    if (executor.ShouldAbort())
    {
      return Status::Aborted();
    }
    // Exclusive prefix sum: SimplexOffsets[leaf] becomes the leaf's first simplex.
    std::int64_t running = 0;
    for (std::int64_t leaf = 0; leaf <= leaves; ++leaf)
    {
      const std::int64_t here = this->SimplexOffsets[leaf];
      this->SimplexOffsets[leaf] = running;
      running += here;
    }
    this->NumberOfPoints = this->PointSet.BuildRank();
    executor.ReportProgress(0.5);
    return Status::Ok();
  }

  std::int64_t GetNumberOfSimplices() const { return this->SimplexOffsets.back(); }
  std::int64_t GetNumberOfPoints() const { return this->NumberOfPoints; }

  /// Writes (Dim+1) point ids per simplex, positively oriented, and the material index of each
  /// simplex. IdType is the integer type of the output connectivity.
  template <class IdType, class Executor>
  Status WriteSimplices(IdType* connectivity, MaterialIndex* materials, Executor& executor)
  {
    if (this->NeedsLevelMap && !this->Map)
    {
      // Prepare's map was released by an earlier WriteSimplices.
      this->Map.reset(new LevelMap<Dim>());
      const Status status = this->Map->Build(*this->Tree, executor);
      if (!status.IsOk())
      {
        return status;
      }
    }
    WriteKernel<IdType, Executor> write{ this, connectivity, materials, &executor };
    executor.For(0, this->Tree->GetNumberOfLeaves(), 2048, write);
    this->Map.reset();
    return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
  }

  /// Calls visit(pointId, halfUnitPoint) for every point, from any thread, each point once.
  template <class Visitor, class Executor>
  Status VisitPoints(Visitor& visit, Executor& executor) const
  {
    PointKernel<Visitor> kernel{ this, &visit };
    executor.For(0, this->PointSet.GetNumberOfWords(), 4096, kernel);
    return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
  }

  /// Whether a leaf belongs to the output.
  bool IsSelected(std::int64_t leaf) const
  {
    return this->Options.IncludeBackground || this->Tree->LeafMaterials[leaf] != BackgroundMaterial;
  }

  /// The leaf as a Dim-face.
  Face LeafFace(std::int64_t leaf) const
  {
    return Face{ this->Tree->LeafAnchors[leaf], this->Tree->LeafLevels[leaf], (1u << Dim) - 1u };
  }

  /// Whether a leaf takes its level's cell template: no leaf corner on its boundary besides its
  /// corners, and a template that fits its faces. Its simplices are then
  /// RegularCellSimplices(leaf) over its corners.
  bool IsRegularLeaf(std::int64_t leaf) const
  {
    const Face cell = this->LeafFace(leaf);
    return this->TemplateAllowed[cell.Level] && this->IsBoundaryRegular(cell);
  }

  /// Corner codes (bit i: far side along axis i), Dim+1 per simplex, positively oriented, of the
  /// template of a regular leaf.
  const std::vector<std::uint8_t>& RegularCellSimplices(std::int64_t leaf) const
  {
    return this->RegularCellTables[this->Parity(this->LeafFace(leaf))];
  }

  /// Appends the Dim-simplices of a leaf (Dim+1 half-unit points each), unoriented.
  void TessellateLeaf(std::int64_t leaf, Scratch& scratch) const
  {
    this->TriangulateUnsplit(this->LeafFace(leaf), scratch.Simplices, scratch);
  }

  /// Reorders the points of each simplex in the buffer so that its orientation is positive.
  static void Orient(std::vector<Point>& simplices)
  {
    for (std::size_t first = 0; first < simplices.size(); first += Dim + 1)
    {
      if (SimplexDeterminant<Dim>(&simplices[first]) < 0)
      {
        std::swap(simplices[first], simplices[first + 1]);
      }
    }
  }

private:
  /// The level tables: for every level and axis set, the canonical level of a face of that level
  /// spanning those axes; whether a cell of each level may take the cell template; whether
  /// some face needs the level map.
  void BuildLevelTables()
  {
    const int levels = this->Tree->MaxLevel + 1;
    // ShrinkMasks[m]: the axes whose edge level m makes shorter than level m - 1.
    std::vector<unsigned> shrinkMasks(levels, 0u);
    for (int level = 1; level < levels; ++level)
    {
      for (int axis = 0; axis < Dim; ++axis)
      {
        if (this->Tree->GetCellSize(level)[axis] < this->Tree->GetCellSize(level - 1)[axis])
        {
          shrinkMasks[level] |= 1u << axis;
        }
      }
    }
    constexpr unsigned allAxes = (1u << Dim) - 1u;
    this->CanonicalLevels.assign(static_cast<std::size_t>(levels) << Dim, 0);
    this->NeedsLevelMap = false;
    for (int level = 0; level < levels; ++level)
    {
      for (unsigned axes = 0; axes <= allAxes; ++axes)
      {
        int canonical = level;
        while (canonical + 1 < levels && (shrinkMasks[canonical + 1] & axes) == 0)
        {
          ++canonical;
        }
        this->CanonicalLevels[(static_cast<std::size_t>(level) << Dim) | axes] =
          static_cast<std::int8_t>(canonical);
        if (canonical + 1 < levels && PopCount(axes) >= 2 &&
          (shrinkMasks[canonical + 1] & axes) != axes)
        {
          this->NeedsLevelMap = true;
        }
      }
    }
    this->TemplateAllowed.assign(levels, 1);
    if (this->Options.Template == CellTemplate::Checkerboard && Dim == 3)
    {
      // The cube template agrees with its square faces only if they are handled at its level:
      // the next level splits at least two of the three axes.
      for (int level = 0; level + 1 < levels; ++level)
      {
        this->TemplateAllowed[level] = PopCount(shrinkMasks[level + 1]) >= 2;
      }
    }
  }

  int CanonicalLevel(int level, unsigned axes) const
  {
    return this->CanonicalLevels[(static_cast<std::size_t>(level) << Dim) | axes];
  }

  const LatticeIndex<Dim>& Size(const Face& face) const { return this->Sizes[face.Level]; }

  /// Parity of the sum of the level coordinates of a face's anchor.
  int Parity(const Face& face) const
  {
    const LatticeIndex<Dim> size = this->Size(face);
    std::int64_t sum = 0;
    for (int axis = 0; axis < Dim; ++axis)
    {
      sum += face.Anchor[axis] / size[axis];
    }
    return static_cast<int>(sum & 1);
  }

  /// Tabulates the template of a regular cell for both anchor parities, oriented once, so
  /// that regular leaves (most of them) skip the recursion and the determinants.
  void BuildRegularCellTables()
  {
    for (int parity = 0; parity < 2; ++parity)
    {
      std::vector<Point> simplices;
      this->AppendTemplate(
        Point{}, Spacetree<Dim>::UnitSize(), parity, (1u << Dim) - 1u, simplices);
      Orient(simplices);
      auto& table = this->RegularCellTables[parity];
      table.clear();
      for (const Point& point : simplices)
      {
        unsigned code = 0;
        for (int axis = 0; axis < Dim; ++axis)
        {
          code |= static_cast<unsigned>(point[axis] / 2) << axis;
        }
        table.push_back(static_cast<std::uint8_t>(code));
      }
    }
  }

  /// The corners of a leaf in half units, indexed by corner code.
  std::array<Point, CubeInfo<Dim>::VerticesPerCell> LeafCorners(std::int64_t leaf) const
  {
    const Face cell = this->LeafFace(leaf);
    const LatticeIndex<Dim> size = this->Size(cell);
    std::array<Point, CubeInfo<Dim>::VerticesPerCell> corners;
    for (int c = 0; c < CubeInfo<Dim>::VerticesPerCell; ++c)
    {
      for (int axis = 0; axis < Dim; ++axis)
      {
        corners[c][axis] = 2 * (cell.Anchor[axis] + ((c >> axis) & 1) * size[axis]);
      }
    }
    return corners;
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

  /// Corner c (bit i of c selects the far side along the i-th free axis) of a box in half units.
  static Point Corner(
    const Point& anchor, const LatticeIndex<Dim>& size, unsigned freeAxes, unsigned c)
  {
    Point point = anchor;
    int freeIndex = 0;
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (freeAxes & (1u << axis))
      {
        point[axis] += ((c >> freeIndex) & 1u) * 2 * size[axis];
        ++freeIndex;
      }
    }
    return point;
  }

  /// Whether a face at its canonical level is split by finer leaves.
  bool IsSplit(const Face& face) const
  {
    if (face.Level == this->MaxLevel)
    {
      return false;
    }
    const LatticeIndex<Dim> size = this->Size(face);
    const LatticeIndex<Dim> childSize = this->Sizes[face.Level + 1];
    LatticeIndex<Dim> inner = face.Anchor;
    bool allSplit = true;
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (face.FreeAxes & (1u << axis))
      {
        inner[axis] += childSize[axis];
        allSplit = allSplit && childSize[axis] < size[axis];
      }
    }
    if (allSplit)
    {
      return this->VertexSet.Test(inner);
    }
    // The face has no next-level point inside: ask the cells around it whether they are split.
    const unsigned fixedAxes = ((1u << Dim) - 1u) & ~face.FreeAxes;
    unsigned side = 0;
    do
    {
      LatticeIndex<Dim> cell = face.Anchor;
      bool inside = true;
      for (int axis = 0; axis < Dim; ++axis)
      {
        if (side & (1u << axis))
        {
          --cell[axis];
        }
        inside = inside && cell[axis] >= 0 && cell[axis] < this->LatticeDimensions[axis];
      }
      if (inside && this->Map->LevelAt(cell) > face.Level)
      {
        return true;
      }
      side = (side - fixedAxes) & fixedAxes;
    } while (side != 0);
    return false;
  }

  /// No leaf corner on the boundary besides the face's corners: no edge of the face is split.
  bool IsBoundaryRegular(const Face& face) const
  {
    if (face.Level == this->MaxLevel)
    {
      return true; // no leaf is finer
    }
    const LatticeIndex<Dim> size = this->Size(face);
    for (int edgeAxis = 0; edgeAxis < Dim; ++edgeAxis)
    {
      if (!(face.FreeAxes & (1u << edgeAxis)))
      {
        continue;
      }
      const int edgeLevel = this->CanonicalLevel(face.Level, 1u << edgeAxis);
      if (edgeLevel == this->MaxLevel)
      {
        continue; // this axis is never split again
      }
      const std::int64_t step = this->Sizes[edgeLevel + 1][edgeAxis];
      const unsigned others = face.FreeAxes & ~(1u << edgeAxis);
      // Enumerate the subsets of the other free axes: each is one edge parallel to edgeAxis.
      unsigned subset = 0;
      do
      {
        LatticeIndex<Dim> inner = face.Anchor;
        inner[edgeAxis] += step;
        for (int axis = 0; axis < Dim; ++axis)
        {
          if (subset & (1u << axis))
          {
            inner[axis] += size[axis];
          }
        }
        if (this->VertexSet.Test(inner))
        {
          return false;
        }
        subset = (subset - others) & others;
      } while (subset != 0);
    }
    return true;
  }

  /// Appends the k-simplices (k+1 points each) of a face of the spacetree.
  void Triangulate(Face face, std::vector<Point>& out, Scratch& scratch) const
  {
    if (face.FreeAxes == 0)
    {
      out.push_back(HalfUnits(face.Anchor));
      return;
    }
    face.Level = this->CanonicalLevel(face.Level, face.FreeAxes);
    if (this->IsSplit(face))
    {
      const LatticeIndex<Dim> size = this->Size(face);
      const LatticeIndex<Dim> childSize = this->Sizes[face.Level + 1];
      Face child{ face.Anchor, face.Level + 1, face.FreeAxes };
      for (;;)
      {
        this->Triangulate(child, out, scratch);
        int axis = 0;
        for (; axis < Dim; ++axis)
        {
          if (!(face.FreeAxes & (1u << axis)))
          {
            continue;
          }
          child.Anchor[axis] += childSize[axis];
          if (child.Anchor[axis] < face.Anchor[axis] + size[axis])
          {
            break;
          }
          child.Anchor[axis] = face.Anchor[axis];
        }
        if (axis == Dim)
        {
          return;
        }
      }
    }
    if (face.FreeAxes == (face.FreeAxes & (~face.FreeAxes + 1u)))
    {
      // An unsplit edge: its two end points.
      const Point first = HalfUnits(face.Anchor);
      Point second = first;
      for (int axis = 0; axis < Dim; ++axis)
      {
        second[axis] += (face.FreeAxes & (1u << axis)) ? 2 * this->Size(face)[axis] : 0;
      }
      out.push_back(first);
      out.push_back(second);
      return;
    }
    this->TriangulateUnsplit(face, out, scratch);
  }

  void TriangulateUnsplit(const Face& face, std::vector<Point>& out, Scratch& scratch) const
  {
    const int k = PopCount(face.FreeAxes);
    if ((k < 3 || this->TemplateAllowed[face.Level]) && this->IsBoundaryRegular(face))
    {
      const int parity =
        k >= 2 && this->Options.Template == CellTemplate::Checkerboard ? this->Parity(face) : 0;
      this->AppendTemplate(HalfUnits(face.Anchor), this->Size(face), parity, face.FreeAxes, out);
      return;
    }
    // Recursive midpoint rule: cone from the centre over the triangulated facets.
    std::vector<Point>& facets = scratch.FacetBuffers[k - 1];
    facets.clear();
    const LatticeIndex<Dim> size = this->Size(face);
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (!(face.FreeAxes & (1u << axis)))
      {
        continue;
      }
      for (int side = 0; side < 2; ++side)
      {
        Face facet{ face.Anchor, face.Level, face.FreeAxes & ~(1u << axis) };
        facet.Anchor[axis] += side * size[axis];
        this->Triangulate(facet, facets, scratch);
      }
    }
    Point centre = HalfUnits(face.Anchor);
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (face.FreeAxes & (1u << axis))
      {
        centre[axis] += size[axis];
      }
    }
    for (std::size_t first = 0; first < facets.size(); first += k)
    {
      out.push_back(centre);
      out.insert(out.end(), facets.begin() + first, facets.begin() + first + k);
    }
  }

  /// Appends the template of a box (anchor in half units) spanning freeAxes; parity is that of
  /// the sum of the level coordinates of its anchor.
  void AppendTemplate(const Point& anchor, const LatticeIndex<Dim>& size, int parity,
    unsigned freeAxes, std::vector<Point>& out) const
  {
    const int k = PopCount(freeAxes);
    std::array<Point, CubeInfo<Dim>::VerticesPerCell> corners;
    for (unsigned c = 0; c < (1u << k); ++c)
    {
      corners[c] = Corner(anchor, size, freeAxes, c);
    }
    auto corner = [&corners](unsigned c) -> const Point& { return corners[c]; };
    if (k == 1)
    {
      out.push_back(corner(0));
      out.push_back(corner(1));
      return;
    }
    if (this->Options.Template == CellTemplate::Kuhn)
    {
      std::array<int, Dim> order{};
      std::iota(order.begin(), order.begin() + k, 0);
      do
      {
        unsigned c = 0;
        out.push_back(corner(c));
        for (int step = 0; step < k; ++step)
        {
          c |= 1u << order[step];
          out.push_back(corner(c));
        }
      } while (std::next_permutation(order.begin(), order.begin() + k));
      return;
    }
    // Checkerboard: the parity of the level coordinates decides, so that the choice depends on
    // the face alone.
    const bool anchorEven = parity == 0;
    if (k == 2)
    {
      // Corners 0=(0,0) 1=(1,0) 2=(0,1) 3=(1,1).
      const Point c0 = corner(0), c1 = corner(1), c2 = corner(2), c3 = corner(3);
      if (anchorEven)
      {
        out.insert(out.end(), { c0, c1, c3, c0, c3, c2 });
      }
      else
      {
        out.insert(out.end(), { c1, c3, c2, c1, c2, c0 });
      }
      return;
    }
    // k == 3: the even corners form the central tetrahedron; each odd corner with its three
    // (even) neighbours forms a corner tetrahedron.
    std::array<unsigned, 4> even{}, odd{};
    int evenCount = 0, oddCount = 0;
    for (unsigned c = 0; c < 8; ++c)
    {
      const bool cornerEven = ((PopCount(c) & 1) == 0) == anchorEven;
      if (cornerEven)
      {
        even[evenCount++] = c;
      }
      else
      {
        odd[oddCount++] = c;
      }
    }
    out.insert(out.end(), { corner(even[0]), corner(even[1]), corner(even[2]), corner(even[3]) });
    for (unsigned o : odd)
    {
      out.insert(out.end(), { corner(o), corner(o ^ 1u), corner(o ^ 2u), corner(o ^ 4u) });
    }
  }

  struct MarkVerticesKernel
  {
    using Scratch = NoScratch;
    SpacetreeTessellator* Self;
    void operator()(NoScratch&, std::int64_t begin, std::int64_t end) const
    {
      const Spacetree<Dim>& tree = *this->Self->Tree;
      for (std::int64_t leaf = begin; leaf < end; ++leaf)
      {
        const LatticeIndex<Dim> size = tree.GetCellSize(tree.LeafLevels[leaf]);
        for (int c = 0; c < CubeInfo<Dim>::VerticesPerCell; ++c)
        {
          LatticeIndex<Dim> corner = tree.LeafAnchors[leaf];
          for (int axis = 0; axis < Dim; ++axis)
          {
            corner[axis] += ((c >> axis) & 1) * size[axis];
          }
          this->Self->VertexSet.Set(corner);
        }
      }
    }
  };

  template <class Executor>
  struct CountKernel
  {
    using Scratch = typename SpacetreeTessellator::Scratch;
    SpacetreeTessellator* Self;
    Executor* Exec;
    void operator()(Scratch& scratch, std::int64_t begin, std::int64_t end) const
    {
      if (this->Exec->ShouldAbort())
      {
        return;
      }
      for (std::int64_t leaf = begin; leaf < end; ++leaf)
      {
        if (!this->Self->IsSelected(leaf))
        {
          continue;
        }
        if (this->Self->IsRegularLeaf(leaf))
        {
          for (const Point& corner : this->Self->LeafCorners(leaf))
          {
            this->Self->PointSet.Set(corner);
          }
          this->Self->SimplexOffsets[leaf] =
            static_cast<std::int64_t>(this->Self->RegularCellSimplices(leaf).size()) / (Dim + 1);
          continue;
        }
        scratch.Simplices.clear();
        this->Self->TessellateLeaf(leaf, scratch);
        for (const Point& point : scratch.Simplices)
        {
          this->Self->PointSet.Set(point);
        }
        this->Self->SimplexOffsets[leaf] =
          static_cast<std::int64_t>(scratch.Simplices.size()) / (Dim + 1);
      }
      this->Exec->ReportProgress(
        0.1 + 0.4 * static_cast<double>(end) / this->Self->Tree->GetNumberOfLeaves());
    }
  };

  template <class IdType, class Executor>
  struct WriteKernel
  {
    using Scratch = typename SpacetreeTessellator::Scratch;
    const SpacetreeTessellator* Self;
    IdType* Connectivity;
    MaterialIndex* Materials;
    Executor* Exec;
    void operator()(Scratch& scratch, std::int64_t begin, std::int64_t end) const
    {
      if (this->Exec->ShouldAbort())
      {
        return;
      }
      for (std::int64_t leaf = begin; leaf < end; ++leaf)
      {
        if (!this->Self->IsSelected(leaf))
        {
          continue;
        }
        const std::int64_t simplex = this->Self->SimplexOffsets[leaf];
        const std::int64_t count = this->Self->SimplexOffsets[leaf + 1] - simplex;
        IdType* ids = this->Connectivity + simplex * (Dim + 1);
        if (this->Self->IsRegularLeaf(leaf))
        {
          const auto corners = this->Self->LeafCorners(leaf);
          std::array<IdType, CubeInfo<Dim>::VerticesPerCell> cornerIds;
          for (int c = 0; c < CubeInfo<Dim>::VerticesPerCell; ++c)
          {
            cornerIds[c] = static_cast<IdType>(this->Self->PointSet.Rank(corners[c]));
          }
          for (std::uint8_t code : this->Self->RegularCellSimplices(leaf))
          {
            *ids++ = cornerIds[code];
          }
        }
        else
        {
          scratch.Simplices.clear();
          this->Self->TessellateLeaf(leaf, scratch);
          Orient(scratch.Simplices);
          for (const Point& point : scratch.Simplices)
          {
            *ids++ = static_cast<IdType>(this->Self->PointSet.Rank(point));
          }
        }
        std::fill(this->Materials + simplex, this->Materials + simplex + count,
          this->Self->Tree->LeafMaterials[leaf]);
      }
      this->Exec->ReportProgress(
        0.5 + 0.4 * static_cast<double>(end) / this->Self->Tree->GetNumberOfLeaves());
    }
  };

  template <class Visitor>
  struct PointKernel
  {
    using Scratch = NoScratch;
    const SpacetreeTessellator* Self;
    Visitor* Visit;
    void operator()(NoScratch&, std::int64_t begin, std::int64_t end) const
    {
      this->Self->PointSet.VisitSetBits(begin, end, *this->Visit);
    }
  };

  const Spacetree<Dim>* Tree = nullptr;
  /// The tree's level table and finest level, at hand for the recursion.
  const LatticeIndex<Dim>* Sizes = nullptr;
  int MaxLevel = 0;
  SpacetreeTessellationOptions Options;
  LatticeIndex<Dim> LatticeDimensions{};
  std::vector<std::int8_t> CanonicalLevels;
  std::vector<std::uint8_t> TemplateAllowed;
  bool NeedsLevelMap = false;
  /// Levels of the leaves per lattice cell, from Prepare to the end of WriteSimplices, for
  /// patterns that leave axes unsplit.
  std::unique_ptr<LevelMap<Dim>> Map;
  LatticeBitset<Dim> VertexSet;
  LatticeBitset<Dim> PointSet;
  std::vector<std::int64_t> SimplexOffsets;
  std::int64_t NumberOfPoints = 0;
  std::array<std::vector<std::uint8_t>, 2> RegularCellTables;
};

} // namespace stm

#endif
