// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSpacetreeTessellation_h
#define stmCoreSpacetreeTessellation_h

// Direct conforming simplicial tessellation of the spacetree leaves (paper sections 2.3, 2.4).
//
// Every k-face F of the spacetree (a k-cube of some level) gets a triangulation that depends on
// F and the vertex set V (all leaf corners) only, which makes the mesh consistent across faces
// by construction, for any level difference:
//  - F is split if its centre is in V (a finer leaf touches it): its triangulation is the union
//    of those of its 2^k children;
//  - otherwise, if V has no point on F's boundary besides its corners, F is regular and takes
//    the template of its level;
//  - otherwise the centre of F is inserted and joined to the triangulations of its 2k facets
//    (the recursive midpoint rule).
// A leaf is treated as an unsplit Dim-face. With 2^Dim refinement, F's boundary holds a point
// of V other than its corners exactly when the midpoint of one of its edges is in V, so the
// regularity test reads k 2^(k-1) bits.
//
// Templates: Checkerboard (Dim <= 3, the paper's choice) cuts a square along the diagonal
// between its corners of even level-coordinate sum and a cube into the tetrahedron of its even
// corners plus one tetrahedron per odd corner (5 in all). Kuhn cuts a k-cube into the k!
// simplices along monotone corner paths, in any dimension.
//
// Points live on the lattice of half lattice units (face centres of the finest cells); the
// used ones are numbered in lattice order through a bitset rank, so the numbering does not
// depend on the number of threads. Simplices are emitted leaf by leaf in leaf order.

#include "../Common/CubeInfo.h"
#include "../Common/Execution.h"
#include "../Common/LatticeBitset.h"
#include "../Common/Status.h"
#include "../Spacetree/Spacetree.h"

#include <algorithm>
#include <array>
#include <cstdint>
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

  /// A k-face of the spacetree: a cube of edge Size (lattice units) at Anchor, spanning the
  /// axes set in FreeAxes.
  struct Face
  {
    LatticeIndex<Dim> Anchor;
    std::int64_t Size;
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
    this->Options = options;
    this->BuildRegularCellTables();

    const LatticeIndex<Dim> latticeDims = tree.GetLatticeDimensions();
    LatticeIndex<Dim> vertexDims, pointDims;
    for (int axis = 0; axis < Dim; ++axis)
    {
      vertexDims[axis] = latticeDims[axis] + 1;
      pointDims[axis] = 2 * latticeDims[axis] + 1;
    }
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
  Status WriteSimplices(IdType* connectivity, MaterialIndex* materials, Executor& executor) const
  {
    WriteKernel<IdType, Executor> write{ this, connectivity, materials, &executor };
    executor.For(0, this->Tree->GetNumberOfLeaves(), 2048, write);
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
    return Face{ this->Tree->LeafAnchors[leaf],
      this->Tree->GetCellSize(this->Tree->LeafLevels[leaf]), (1u << Dim) - 1u };
  }

  /// Whether a leaf has no spacetree vertex on its boundary besides its corners; its simplices
  /// are then RegularCellSimplices(leaf) over its corners.
  bool IsRegularLeaf(std::int64_t leaf) const
  {
    return this->IsBoundaryRegular(this->LeafFace(leaf));
  }

  /// Corner codes (bit i: far side along axis i), Dim+1 per simplex, positively oriented, of the
  /// template of a regular leaf.
  const std::vector<std::uint8_t>& RegularCellSimplices(std::int64_t leaf) const
  {
    const Face cell = this->LeafFace(leaf);
    std::int64_t anchorSum = 0;
    for (int axis = 0; axis < Dim; ++axis)
    {
      anchorSum += cell.Anchor[axis] / cell.Size;
    }
    return this->RegularCellTables[anchorSum & 1];
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
  /// Tabulates the template of a regular cell for both anchor parities, oriented once, so
  /// that regular leaves (most of them) skip the recursion and the determinants.
  void BuildRegularCellTables()
  {
    for (int parity = 0; parity < 2; ++parity)
    {
      Face unit{ LatticeIndex<Dim>{}, 1, (1u << Dim) - 1u };
      unit.Anchor[0] = parity;
      std::vector<Point> simplices;
      this->AppendTemplate(unit, simplices);
      Orient(simplices);
      auto& table = this->RegularCellTables[parity];
      table.clear();
      for (const Point& point : simplices)
      {
        unsigned code = 0;
        for (int axis = 0; axis < Dim; ++axis)
        {
          code |= static_cast<unsigned>((point[axis] - 2 * unit.Anchor[axis]) / 2) << axis;
        }
        table.push_back(static_cast<std::uint8_t>(code));
      }
    }
  }

  /// The corners of a leaf in half units, indexed by corner code.
  std::array<Point, CubeInfo<Dim>::VerticesPerCell> LeafCorners(std::int64_t leaf) const
  {
    const Face cell = this->LeafFace(leaf);
    std::array<Point, CubeInfo<Dim>::VerticesPerCell> corners;
    for (int c = 0; c < CubeInfo<Dim>::VerticesPerCell; ++c)
    {
      for (int axis = 0; axis < Dim; ++axis)
      {
        corners[c][axis] = 2 * (cell.Anchor[axis] + ((c >> axis) & 1) * cell.Size);
      }
    }
    return corners;
  }

  // A face centre, in lattice units; only meaningful for Size >= 2.
  static LatticeIndex<Dim> Centre(const Face& face)
  {
    LatticeIndex<Dim> centre = face.Anchor;
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (face.FreeAxes & (1u << axis))
      {
        centre[axis] += face.Size / 2;
      }
    }
    return centre;
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

  /// Corner c (bit i of c selects the far side along the i-th free axis) in half units.
  static Point Corner(const Face& face, unsigned c)
  {
    Point point = HalfUnits(face.Anchor);
    int freeIndex = 0;
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (face.FreeAxes & (1u << axis))
      {
        point[axis] += ((c >> freeIndex) & 1u) * 2 * face.Size;
        ++freeIndex;
      }
    }
    return point;
  }

  bool IsSplit(const Face& face) const
  {
    return face.Size >= 2 && this->VertexSet.Test(Centre(face));
  }

  /// No point of V on the boundary besides the corners: no edge midpoint is in V.
  bool IsBoundaryRegular(const Face& face) const
  {
    if (face.Size < 2)
    {
      return true;
    }
    const std::int64_t half = face.Size / 2;
    for (int edgeAxis = 0; edgeAxis < Dim; ++edgeAxis)
    {
      if (!(face.FreeAxes & (1u << edgeAxis)))
      {
        continue;
      }
      const unsigned others = face.FreeAxes & ~(1u << edgeAxis);
      // Enumerate the subsets of the other free axes: each is one edge parallel to edgeAxis.
      unsigned subset = 0;
      do
      {
        LatticeIndex<Dim> midpoint = face.Anchor;
        midpoint[edgeAxis] += half;
        for (int axis = 0; axis < Dim; ++axis)
        {
          if (subset & (1u << axis))
          {
            midpoint[axis] += face.Size;
          }
        }
        if (this->VertexSet.Test(midpoint))
        {
          return false;
        }
        subset = (subset - others) & others;
      } while (subset != 0);
    }
    return true;
  }

  /// Appends the k-simplices (k+1 points each) of a face of the spacetree.
  void Triangulate(const Face& face, std::vector<Point>& out, Scratch& scratch) const
  {
    if (face.FreeAxes == 0)
    {
      out.push_back(HalfUnits(face.Anchor));
      return;
    }
    if (this->IsSplit(face))
    {
      const std::int64_t half = face.Size / 2;
      const int k = PopCount(face.FreeAxes);
      for (unsigned child = 0; child < (1u << k); ++child)
      {
        Face sub{ face.Anchor, half, face.FreeAxes };
        int freeIndex = 0;
        for (int axis = 0; axis < Dim; ++axis)
        {
          if (face.FreeAxes & (1u << axis))
          {
            sub.Anchor[axis] += ((child >> freeIndex) & 1u) * half;
            ++freeIndex;
          }
        }
        this->Triangulate(sub, out, scratch);
      }
      return;
    }
    this->TriangulateUnsplit(face, out, scratch);
  }

  void TriangulateUnsplit(const Face& face, std::vector<Point>& out, Scratch& scratch) const
  {
    if (this->IsBoundaryRegular(face))
    {
      this->AppendTemplate(face, out);
      return;
    }
    // Recursive midpoint rule: cone from the centre over the triangulated facets.
    const int k = PopCount(face.FreeAxes);
    std::vector<Point>& facets = scratch.FacetBuffers[k - 1];
    facets.clear();
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (!(face.FreeAxes & (1u << axis)))
      {
        continue;
      }
      for (int side = 0; side < 2; ++side)
      {
        Face facet{ face.Anchor, face.Size, face.FreeAxes & ~(1u << axis) };
        facet.Anchor[axis] += side * face.Size;
        this->Triangulate(facet, facets, scratch);
      }
    }
    Point centre = HalfUnits(face.Anchor);
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (face.FreeAxes & (1u << axis))
      {
        centre[axis] += face.Size;
      }
    }
    for (std::size_t first = 0; first < facets.size(); first += k)
    {
      out.push_back(centre);
      out.insert(out.end(), facets.begin() + first, facets.begin() + first + k);
    }
  }

  void AppendTemplate(const Face& face, std::vector<Point>& out) const
  {
    const int k = PopCount(face.FreeAxes);
    if (k == 1)
    {
      out.push_back(Corner(face, 0));
      out.push_back(Corner(face, 1));
      return;
    }
    if (this->Options.Template == CellTemplate::Kuhn)
    {
      this->AppendKuhn(face, k, out);
      return;
    }
    // Checkerboard: parity of the corner's level coordinates (corner / Size), summed over all
    // axes, so that the choice depends on the face alone.
    std::int64_t anchorSum = 0;
    for (int axis = 0; axis < Dim; ++axis)
    {
      anchorSum += face.Anchor[axis] / face.Size;
    }
    const bool anchorEven = (anchorSum & 1) == 0;
    if (k == 2)
    {
      // Corners 0=(0,0) 1=(1,0) 2=(0,1) 3=(1,1).
      const Point c0 = Corner(face, 0), c1 = Corner(face, 1), c2 = Corner(face, 2),
                  c3 = Corner(face, 3);
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
    out.insert(out.end(),
      { Corner(face, even[0]), Corner(face, even[1]), Corner(face, even[2]),
        Corner(face, even[3]) });
    for (unsigned o : odd)
    {
      out.insert(out.end(),
        { Corner(face, o), Corner(face, o ^ 1u), Corner(face, o ^ 2u), Corner(face, o ^ 4u) });
    }
  }

  void AppendKuhn(const Face& face, int k, std::vector<Point>& out) const
  {
    std::array<int, Dim> order{};
    std::iota(order.begin(), order.begin() + k, 0);
    do
    {
      unsigned corner = 0;
      out.push_back(Corner(face, corner));
      for (int step = 0; step < k; ++step)
      {
        corner |= 1u << order[step];
        out.push_back(Corner(face, corner));
      }
    } while (std::next_permutation(order.begin(), order.begin() + k));
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
        const std::int64_t size = tree.GetCellSize(tree.LeafLevels[leaf]);
        for (int c = 0; c < CubeInfo<Dim>::VerticesPerCell; ++c)
        {
          LatticeIndex<Dim> corner = tree.LeafAnchors[leaf];
          for (int axis = 0; axis < Dim; ++axis)
          {
            corner[axis] += ((c >> axis) & 1) * size;
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
  SpacetreeTessellationOptions Options;
  LatticeBitset<Dim> VertexSet;
  LatticeBitset<Dim> PointSet;
  std::vector<std::int64_t> SimplexOffsets;
  std::int64_t NumberOfPoints = 0;
  std::array<std::vector<std::uint8_t>, 2> RegularCellTables;
};

} // namespace stm

#endif
