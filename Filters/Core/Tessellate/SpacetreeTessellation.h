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
#include "../Common/Determinant.h"
#include "../Common/Execution.h"
#include "../Common/LatticeBitset.h"
#include "../Common/Status.h"
#include "../Spacetree/LevelMap.h"
#include "../Spacetree/Spacetree.h"

#include <algorithm>
#include <array>
#include <atomic>
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

/// What the tessellation emits.
enum class TessellationOutput
{
  /// Conforming simplices only.
  Simplices = 0,
  /// The paper's hybrid rule: a k-face is tessellated (midpoint + cone) only if one of its
  /// facets is; every other face stays a k-cube. In 3D: hexahedra, pyramids, tetrahedra.
  Hybrid = 1,
  /// The leaves themselves as Dim-cubes, with hanging nodes.
  Leaves = 2
};

/// How unsplit faces are triangulated in Simplices output.
enum class TemplateRule
{
  /// The recursive midpoint rule for every face of dimension 2 or more (paper Fig. 3a).
  MidpointEverywhere = 0,
  /// Templates for regular faces, the midpoint rule for the others (paper section 2.4).
  RegularFaces = 1,
  /// In addition, irregular faces that are cones from one of their corners are triangulated as
  /// that cone, without a new point (the paper's extended templates, Figs. 3d, 4 right, 5).
  Extended = 2
};

struct SpacetreeTessellationOptions
{
  CellTemplate Template = CellTemplate::Checkerboard;
  TessellationOutput Output = TessellationOutput::Simplices;
  TemplateRule Templates = TemplateRule::RegularFaces;
  /// Tessellate the background leaves too, not only the body of interest.
  bool IncludeBackground = false;
  /// Layers of background leaves around the body of interest to tessellate too (each layer:
  /// the background leaves touching the previous ones); ignored with IncludeBackground.
  int BoundaryLayers = 0;
  /// Per leaf (empty: none), 1 for a leaf that gives no cells, though its corners still shape
  /// its neighbours' cells as any leaf's do: a piece's outer ghost layer, whose leaves are
  /// there for their neighbours' sake (RootPieces.h).
  std::vector<std::uint8_t> HiddenLeaves;
};

/// The cells of a k-face are polytopes P_j of the paper's equation (1), 1 <= j <= k: cones with
/// k - j apexes over a j-cube. Their points are the apexes, outermost first, followed by the
/// 2^j cube corners in code order (bit i: far side along the cube's i-th axis). j = 1 is a
/// simplex, j = k the cube itself; in 3D j = 2 is a pyramid.
constexpr int CellPointCount(int k, int shape)
{
  return (k - shape) + (1 << shape);
}

/// Cells (points and shapes) of a face, as appended by the tessellation.
template <int Dim>
struct TessellationCells
{
  std::vector<LatticeIndex<Dim>> Points;
  std::vector<std::uint8_t> Shapes;

  void Clear()
  {
    this->Points.clear();
    this->Shapes.clear();
  }
  std::size_t Size() const { return this->Shapes.size(); }
};

/// Orientation of a cell of shape j (see CellPointCount): the determinant of the simplex of
/// cube corners 0, 1, 2, 4, ..., 2^(j-1) followed by the apexes. For a simplex it has the sign
/// of SimplexDeterminant of the stored order; for a pyramid it is positive when the apex lies
/// on the side the base normal of corners 0, 1, 3, 2 points to.
template <int Dim>
std::int64_t CellDeterminant(const LatticeIndex<Dim>* points, int shape)
{
  const int apexes = Dim - shape;
  const LatticeIndex<Dim>* corners = points + apexes;
  std::array<LatticeIndex<Dim>, Dim + 1> simplex;
  simplex[0] = corners[0];
  for (int i = 0; i < shape; ++i)
  {
    simplex[1 + i] = corners[1 << i];
  }
  for (int a = 0; a < apexes; ++a)
  {
    simplex[1 + shape + a] = points[a];
  }
  return SimplexDeterminant<Dim>(simplex.data());
}

/// The level tables of the tessellation, from the tree's level table: for every level and axis
/// set, the canonical level of a face of that level spanning those axes (the finest level whose
/// cells have the same edges along those axes); whether a cell of each level may take the cell
/// template; whether some face needs the level map.
template <int Dim>
struct TessellationLevelTables
{
  std::vector<std::int8_t> CanonicalLevels;
  std::vector<std::uint8_t> TemplateAllowed;
  bool NeedsLevelMap = false;

  void Build(const LatticeIndex<Dim>* cellSizes, int levels, CellTemplate cellTemplate)
  {
    // ShrinkMasks[m]: the axes whose edge level m makes shorter than level m - 1.
    std::vector<unsigned> shrinkMasks(levels, 0u);
    for (int level = 1; level < levels; ++level)
    {
      for (int axis = 0; axis < Dim; ++axis)
      {
        if (cellSizes[level][axis] < cellSizes[level - 1][axis])
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
    if (cellTemplate == CellTemplate::Checkerboard && Dim == 3)
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
};

/// A k-face of the spacetree: a box of the edges of Level at Anchor, spanning the axes set in
/// FreeAxes.
template <int Dim>
struct SpacetreeFace
{
  LatticeIndex<Dim> Anchor;
  int Level;
  unsigned FreeAxes;
};

/// The facet of a face (edges size) across its free axis number freeIndex, on side 0 or 1.
template <int Dim>
SpacetreeFace<Dim> FacetOf(
  const SpacetreeFace<Dim>& face, const LatticeIndex<Dim>& size, int freeIndex, int side)
{
  int axis = 0;
  for (int seen = -1; axis < Dim; ++axis)
  {
    if ((face.FreeAxes & (1u << axis)) && ++seen == freeIndex)
    {
      break;
    }
  }
  SpacetreeFace<Dim> facet{ face.Anchor, face.Level, face.FreeAxes & ~(1u << axis) };
  facet.Anchor[axis] += side * size[axis];
  return facet;
}

/// Corner c (bit i of c selects the far side along the i-th free axis) of a box of edges size
/// (lattice units) spanning freeAxes, anchor and result in half units.
template <int Dim>
LatticeIndex<Dim> BoxCorner(
  const LatticeIndex<Dim>& anchor, const LatticeIndex<Dim>& size, unsigned freeAxes, unsigned c)
{
  LatticeIndex<Dim> point = anchor;
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

/// Appends the template of a box (anchor in half units) spanning freeAxes; parity is that of
/// the sum of the level coordinates of its anchor. With keepBox (hybrid output, and any edge)
/// the box itself is the one cell.
template <int Dim>
void AppendBoxTemplate(CellTemplate cellTemplate, bool keepBox, const LatticeIndex<Dim>& anchor,
  const LatticeIndex<Dim>& size, int parity, unsigned freeAxes, TessellationCells<Dim>& out)
{
  const int k = PopCount(freeAxes);
  std::array<LatticeIndex<Dim>, CubeInfo<Dim>::VerticesPerCell> corners;
  for (unsigned c = 0; c < (1u << k); ++c)
  {
    corners[c] = BoxCorner<Dim>(anchor, size, freeAxes, c);
  }
  auto corner = [&corners](unsigned c) -> const LatticeIndex<Dim>& { return corners[c]; };
  std::vector<LatticeIndex<Dim>>& points = out.Points;
  if (k == 1 || keepBox)
  {
    points.insert(points.end(), corners.begin(), corners.begin() + (1 << k));
    out.Shapes.push_back(static_cast<std::uint8_t>(k));
    return;
  }
  const std::size_t first = points.size();
  if (cellTemplate == CellTemplate::Kuhn)
  {
    std::array<int, Dim> order{};
    std::iota(order.begin(), order.begin() + k, 0);
    do
    {
      unsigned c = 0;
      points.push_back(corner(c));
      for (int step = 0; step < k; ++step)
      {
        c |= 1u << order[step];
        points.push_back(corner(c));
      }
    } while (std::next_permutation(order.begin(), order.begin() + k));
  }
  else if constexpr (Dim == 1)
  {
    return; // unreachable: a 1-face is an edge
  }
  else if (k == 2)
  {
    // Checkerboard: the parity of the level coordinates decides, so that the choice depends
    // on the face alone. Corners 0=(0,0) 1=(1,0) 2=(0,1) 3=(1,1).
    const LatticeIndex<Dim> c0 = corner(0), c1 = corner(1), c2 = corner(2), c3 = corner(3);
    if (parity == 0)
    {
      points.insert(points.end(), { c0, c1, c3, c0, c3, c2 });
    }
    else
    {
      points.insert(points.end(), { c1, c3, c2, c1, c2, c0 });
    }
  }
  else
  {
    // k == 3: the even corners form the central tetrahedron; each odd corner with its three
    // (even) neighbours forms a corner tetrahedron.
    const bool anchorEven = parity == 0;
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
    points.insert(
      points.end(), { corner(even[0]), corner(even[1]), corner(even[2]), corner(even[3]) });
    for (unsigned o : odd)
    {
      points.insert(points.end(), { corner(o), corner(o ^ 1u), corner(o ^ 2u), corner(o ^ 4u) });
    }
  }
  out.Shapes.insert(out.Shapes.end(), (points.size() - first) / (k + 1), 1);
}

template <int Dim>
class SpacetreeTessellator
{
public:
  using Point = LatticeIndex<Dim>; // in half lattice units
  using Cells = TessellationCells<Dim>;

  using Face = SpacetreeFace<Dim>;

  struct Scratch
  {
    Cells LeafCells;
    std::array<Cells, Dim + 1> FacetBuffers;
  };

  /// Counts the cells of every selected leaf and numbers the points they use.
  template <class Executor>
  Status Prepare(
    const Spacetree<Dim>& tree, const SpacetreeTessellationOptions& options, Executor& executor)
  {
    if (options.Template == CellTemplate::Checkerboard && Dim > 3 &&
      options.Output == TessellationOutput::Simplices &&
      options.Templates != TemplateRule::MidpointEverywhere)
    {
      return Status::Invalid("the checkerboard template exists for dimensions 1 to 3 only");
    }
    if (options.BoundaryLayers < 0)
    {
      return Status::Invalid("the number of boundary layers must not be negative");
    }
    if (!options.HiddenLeaves.empty() &&
      static_cast<std::int64_t>(options.HiddenLeaves.size()) != tree.GetNumberOfLeaves())
    {
      return Status::Invalid("the hidden leaves do not have one entry per leaf");
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
    const Status selection = this->SelectLeaves(executor);
    if (!selection.IsOk())
    {
      return selection;
    }
    executor.ReportProgress(0.1);

    this->CellOffsets.assign(static_cast<std::size_t>(leaves + 1), 0);
    this->ConnectivityOffsets.assign(static_cast<std::size_t>(leaves + 1), 0);
    CountKernel<Executor> count{ this, &executor };
    executor.For(0, leaves, 2048, count);
    if (executor.ShouldAbort())
    {
      return Status::Aborted();
    }
    // Exclusive prefix sums: the offsets of a leaf become those of its first cell and point id.
    std::int64_t cells = 0, ids = 0;
    for (std::int64_t leaf = 0; leaf <= leaves; ++leaf)
    {
      const std::int64_t leafCells = this->CellOffsets[leaf];
      const std::int64_t leafIds = this->ConnectivityOffsets[leaf];
      this->CellOffsets[leaf] = cells;
      this->ConnectivityOffsets[leaf] = ids;
      cells += leafCells;
      ids += leafIds;
    }
    this->NumberOfPoints = this->PointSet.BuildRank();
    if (options.Output == TessellationOutput::Leaves)
    {
      this->HangingSet = LatticeBitset<Dim>(vertexDims);
      HangingNodeKernel hanging{ this };
      executor.For(0, leaves, 2048, hanging);
      if (executor.ShouldAbort())
      {
        return Status::Aborted();
      }
    }
    executor.ReportProgress(0.5);
    return Status::Ok();
  }

  std::int64_t GetNumberOfCells() const { return this->CellOffsets.back(); }
  /// The cells of leaf l are [offsets[l], offsets[l + 1]) in WriteCells' order.
  const std::vector<std::int64_t>& GetLeafCellOffsets() const { return this->CellOffsets; }
  /// Total number of point ids over all cells.
  std::int64_t GetConnectivitySize() const { return this->ConnectivityOffsets.back(); }
  std::int64_t GetNumberOfPoints() const { return this->NumberOfPoints; }
  /// Whether every cell is a simplex (Dim + 1 point ids each).
  bool IsSimplicial() const { return this->Options.Output == TessellationOutput::Simplices; }

  /// Writes the point ids of every cell (see CellPointCount for their order), positively
  /// oriented, its shape (may be null for simplicial output) and the material index of each
  /// cell. IdType is the integer type of the output connectivity.
  template <class IdType, class Executor>
  Status WriteCells(
    IdType* connectivity, std::uint8_t* shapes, MaterialIndex* materials, Executor& executor)
  {
    if (this->NeedsLevelMap && !this->Map)
    {
      // Prepare's map was released by an earlier WriteCells.
      this->Map.reset(new LevelMap<Dim>());
      const Status status = this->Map->Build(*this->Tree, executor);
      if (!status.IsOk())
      {
        return status;
      }
    }
    WriteKernel<IdType, Executor> write{ this, connectivity, shapes, materials, &executor };
    executor.For(0, this->Tree->GetNumberOfLeaves(), 2048, write);
    this->Map.reset();
    return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
  }

  /// WriteCells for simplicial output.
  template <class IdType, class Executor>
  Status WriteSimplices(IdType* connectivity, MaterialIndex* materials, Executor& executor)
  {
    if (!this->IsSimplicial())
    {
      return Status::Invalid("the tessellation is not simplicial");
    }
    return this->WriteCells(connectivity, nullptr, materials, executor);
  }

  /// Calls visit(pointId, halfUnitPoint) for every point, from any thread, each point once.
  template <class Visitor, class Executor>
  Status VisitPoints(Visitor& visit, Executor& executor) const
  {
    PointKernel<Visitor> kernel{ this, &visit };
    executor.For(0, this->PointSet.GetNumberOfWords(), 4096, kernel);
    return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
  }

  /// Whether a point (half units) is a corner of a leaf of the tree.
  bool IsLeafVertex(const Point& point) const
  {
    LatticeIndex<Dim> vertex;
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (point[axis] % 2 != 0)
      {
        return false;
      }
      vertex[axis] = point[axis] / 2;
    }
    return this->VertexSet.Test(vertex);
  }

  /// Leaves output: whether a point (half units) lies on the boundary of an output leaf without
  /// being one of its corners.
  bool IsHangingNode(const Point& point) const
  {
    if (this->Options.Output != TessellationOutput::Leaves || !this->IsLeafVertex(point))
    {
      return false;
    }
    LatticeIndex<Dim> vertex;
    for (int axis = 0; axis < Dim; ++axis)
    {
      vertex[axis] = point[axis] / 2;
    }
    return this->HangingSet.Test(vertex);
  }

  /// Points that are not corners of leaves: the face and cell centres the tessellation added.
  template <class Executor>
  std::int64_t CountInsertedPoints(Executor& executor) const
  {
    std::atomic<std::int64_t> inserted{ 0 };
    InsertedPointKernel kernel{ this, &inserted };
    executor.For(0, this->PointSet.GetNumberOfWords(), 4096, kernel);
    return inserted.load();
  }
  std::int64_t CountInsertedPoints() const
  {
    SequentialExecutor executor;
    return this->CountInsertedPoints(executor);
  }

  /// Whether a leaf belongs to the output.
  bool IsSelected(std::int64_t leaf) const
  {
    if (!this->Options.HiddenLeaves.empty() && this->Options.HiddenLeaves[leaf] != 0)
    {
      return false;
    }
    if (this->Options.IncludeBackground || this->Tree->LeafMaterials[leaf] != BackgroundMaterial)
    {
      return true;
    }
    return !this->LayerLeaves.empty() && this->LayerLeaves[leaf] != 0;
  }

  /// The leaf as a Dim-face.
  Face LeafFace(std::int64_t leaf) const
  {
    return Face{ this->Tree->LeafAnchors[leaf], this->Tree->LeafLevels[leaf], (1u << Dim) - 1u };
  }

  /// Whether a leaf is emitted as one tabulated piece: its level's simplicial template (no leaf
  /// corner on its boundary besides its corners, and a template that fits its faces), the cube
  /// itself in hybrid output, or any leaf in leaves output. Its cells are then
  /// RegularCellCodes(leaf) over its corners.
  bool IsRegularLeaf(std::int64_t leaf) const
  {
    return this->Options.Output == TessellationOutput::Leaves ||
      this->TakesTemplate(this->LeafFace(leaf));
  }

  /// Corner codes (bit i: far side along axis i) of the cells of a regular leaf, positively
  /// oriented: Dim + 1 per simplex, or 2^Dim for the one cube of hybrid and leaves output.
  const std::vector<std::uint8_t>& RegularCellCodes(std::int64_t leaf) const
  {
    return this->RegularCellTables[this->IsSimplicial() ? this->Parity(this->LeafFace(leaf)) : 0];
  }
  /// Shape of the cells of RegularCellCodes.
  int RegularCellShape() const { return this->IsSimplicial() ? 1 : Dim; }

  /// Appends the Dim-cells of a leaf, unoriented.
  void TessellateLeaf(std::int64_t leaf, Scratch& scratch) const
  {
    this->TriangulateUnsplit(this->LeafFace(leaf), scratch.LeafCells, scratch);
  }

  /// Reorders the points of each cell so that its orientation (CellDeterminant) is positive.
  static void Orient(Cells& cells)
  {
    Point* points = cells.Points.data();
    for (std::uint8_t shape : cells.Shapes)
    {
      if (shape == 1)
      {
        // A simplex: CellDeterminant has the sign of the stored order's determinant.
        if (SimplexDeterminant<Dim>(points) < 0)
        {
          std::swap(points[Dim - 1], points[Dim]);
        }
      }
      else if (CellDeterminant<Dim>(points, shape) < 0)
      {
        // Mirror the cube along its first axis.
        Point* corners = points + (Dim - shape);
        for (int c = 0; c < (1 << shape); c += 2)
        {
          std::swap(corners[c], corners[c + 1]);
        }
      }
      points += CellPointCount(Dim, shape);
    }
  }

  /// Orient for a buffer of simplices (Dim + 1 points each).
  static void OrientSimplices(std::vector<Point>& simplices)
  {
    for (std::size_t first = 0; first < simplices.size(); first += Dim + 1)
    {
      if (SimplexDeterminant<Dim>(&simplices[first]) < 0)
      {
        std::swap(simplices[first + Dim - 1], simplices[first + Dim]);
      }
    }
  }

private:
  void BuildLevelTables()
  {
    this->Tables.Build(this->Sizes, this->MaxLevel + 1, this->Options.Template);
    this->NeedsLevelMap = this->Tables.NeedsLevelMap;
  }

  int CanonicalLevel(int level, unsigned axes) const
  {
    return this->Tables.CanonicalLevel(level, axes);
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

  /// Tabulates the cells of a regular leaf (for both anchor parities in simplicial output),
  /// oriented once, so that regular leaves (most of them) skip the recursion and the
  /// determinants.
  void BuildRegularCellTables()
  {
    for (int parity = 0; parity < 2; ++parity)
    {
      auto& table = this->RegularCellTables[parity];
      table.clear();
      if (!this->IsSimplicial())
      {
        for (unsigned c = 0; c < (1u << Dim); ++c)
        {
          table.push_back(static_cast<std::uint8_t>(c));
        }
        continue;
      }
      Cells cells;
      this->AppendTemplate(Point{}, Spacetree<Dim>::UnitSize(), parity, (1u << Dim) - 1u, cells);
      Orient(cells);
      for (const Point& point : cells.Points)
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

  /// Corner c of a face, in half units.
  Point FaceCorner(const Face& face, unsigned c) const
  {
    return BoxCorner<Dim>(HalfUnits(face.Anchor), this->Size(face), face.FreeAxes, c);
  }

  Face Facet(const Face& face, int freeIndex, int side) const
  {
    return FacetOf<Dim>(face, this->Size(face), freeIndex, side);
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

  /// Calls visit(child) for the next-level children of a split face.
  template <class Visitor>
  void ForEachChildFace(const Face& face, Visitor&& visit) const
  {
    const LatticeIndex<Dim> size = this->Size(face);
    const LatticeIndex<Dim> childSize = this->Sizes[face.Level + 1];
    ForEachChildAnchor<Dim>(face.Anchor, size, childSize, face.FreeAxes,
      [&](const LatticeIndex<Dim>& anchor) {
        visit(Face{ anchor, face.Level + 1, face.FreeAxes });
      });
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

  /// Whether an unsplit face of dimension >= 2 at its canonical level takes its template.
  bool TakesTemplate(const Face& face) const
  {
    if (this->Options.Output == TessellationOutput::Hybrid)
    {
      return this->IsBoundaryRegular(face);
    }
    return this->Options.Templates != TemplateRule::MidpointEverywhere &&
      (PopCount(face.FreeAxes) < 3 || this->Tables.TemplateAllowed[face.Level]) &&
      this->IsBoundaryRegular(face);
  }

  /// Appends the k-cells of a face of the spacetree.
  void Triangulate(Face face, Cells& out, Scratch& scratch) const
  {
    if (face.FreeAxes == 0)
    {
      out.Points.push_back(HalfUnits(face.Anchor));
      out.Shapes.push_back(0);
      return;
    }
    face.Level = this->CanonicalLevel(face.Level, face.FreeAxes);
    if (this->IsSplit(face))
    {
      this->ForEachChildFace(
        face, [&](const Face& child) { this->Triangulate(child, out, scratch); });
      return;
    }
    if ((face.FreeAxes & (face.FreeAxes - 1u)) == 0)
    {
      // An unsplit edge, the most frequent face: its two end points.
      const Point first = HalfUnits(face.Anchor);
      Point second = first;
      for (int axis = 0; axis < Dim; ++axis)
      {
        second[axis] += (face.FreeAxes & (1u << axis)) ? 2 * this->Size(face)[axis] : 0;
      }
      out.Points.push_back(first);
      out.Points.push_back(second);
      out.Shapes.push_back(1);
      return;
    }
    this->TriangulateUnsplit(face, out, scratch);
  }

  void TriangulateUnsplit(const Face& face, Cells& out, Scratch& scratch) const
  {
    const int k = PopCount(face.FreeAxes);
    if (k == 1 || this->TakesTemplate(face))
    {
      const int parity =
        k >= 2 && this->Options.Template == CellTemplate::Checkerboard ? this->Parity(face) : 0;
      this->AppendTemplate(HalfUnits(face.Anchor), this->Size(face), parity, face.FreeAxes, out);
      return;
    }
    if (this->Options.Output == TessellationOutput::Simplices &&
      this->Options.Templates == TemplateRule::Extended)
    {
      const int apex = this->ExtendedApex(face);
      if (apex >= 0)
      {
        this->AppendCone(face, this->FaceCorner(face, apex), apex, out, scratch);
        return;
      }
    }
    // Recursive midpoint rule: cone from the centre over the triangulated facets.
    Point centre = HalfUnits(face.Anchor);
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (face.FreeAxes & (1u << axis))
      {
        centre[axis] += this->Size(face)[axis];
      }
    }
    this->AppendCone(face, centre, -1, out, scratch);
  }

  /// Appends the cone from apex over the cells of the facets of a face, skipping the facets
  /// that contain corner skipCorner (none if negative).
  void AppendCone(
    const Face& face, const Point& apex, int skipCorner, Cells& out, Scratch& scratch) const
  {
    const int k = PopCount(face.FreeAxes);
    Cells& facets = scratch.FacetBuffers[k - 1];
    facets.Clear();
    for (int freeIndex = 0; freeIndex < k; ++freeIndex)
    {
      for (int side = 0; side < 2; ++side)
      {
        if (skipCorner >= 0 && ((skipCorner >> freeIndex) & 1) == side)
        {
          continue;
        }
        this->Triangulate(this->Facet(face, freeIndex, side), facets, scratch);
      }
    }
    auto point = facets.Points.begin();
    for (std::uint8_t shape : facets.Shapes)
    {
      const int count = CellPointCount(k - 1, shape);
      out.Points.push_back(apex);
      out.Points.insert(out.Points.end(), point, point + count);
      out.Shapes.push_back(shape);
      point += count;
    }
  }

  /// Whether the cells of a face stay within one level of refinement: an unsplit face whose
  /// facets do, or a split face whose children are unsplit and regular. Extended templates
  /// cone only over such faces, which bounds their element shapes for any balance level.
  bool IsShallow(Face face) const
  {
    face.Level = this->CanonicalLevel(face.Level, face.FreeAxes);
    const int k = PopCount(face.FreeAxes);
    if (this->IsSplit(face))
    {
      bool shallow = true;
      this->ForEachChildFace(face,
        [&](const Face& child)
        {
          if (shallow)
          {
            const Face canonical{ child.Anchor, this->CanonicalLevel(child.Level, child.FreeAxes),
              child.FreeAxes };
            shallow = !this->IsSplit(canonical) && (k == 1 || this->TakesTemplate(canonical));
          }
        });
      return shallow;
    }
    for (int freeIndex = 0; k > 1 && freeIndex < k; ++freeIndex)
    {
      for (int side = 0; side < 2; ++side)
      {
        if (!this->IsShallow(this->Facet(face, freeIndex, side)))
        {
          return false;
        }
      }
    }
    return true;
  }

  /// The corners (bit c for corner c) on the diagonals of a face's template: the
  /// checkerboard's corners of even level-coordinate sum, Kuhn's first and last corner.
  unsigned DiagonalCorners(const Face& face) const
  {
    const int corners = 1 << PopCount(face.FreeAxes);
    if (this->Options.Template == CellTemplate::Kuhn)
    {
      return 1u | (1u << (corners - 1));
    }
    const int parity = this->Parity(face);
    unsigned mask = 0;
    for (int c = 0; c < corners; ++c)
    {
      if (((parity + PopCount(static_cast<unsigned>(c))) & 1) == 0)
      {
        mask |= 1u << c;
      }
    }
    return mask;
  }

  /// The corners (bit c for corner c) from which the triangulation of a face is a cone.
  unsigned ConeCorners(Face face) const
  {
    face.Level = this->CanonicalLevel(face.Level, face.FreeAxes);
    if (this->IsSplit(face))
    {
      return 0u;
    }
    const int k = PopCount(face.FreeAxes);
    if (k == 1)
    {
      return 3u;
    }
    if (this->TakesTemplate(face))
    {
      // Every Kuhn simplex contains the first and last corner; the checkerboard square's
      // diagonal joins its even corners; the checkerboard cube is no cone.
      return this->Options.Template == CellTemplate::Kuhn || k == 2 ? this->DiagonalCorners(face)
                                                                    : 0u;
    }
    const int apex = this->ExtendedApex(face);
    return apex >= 0 ? 1u << apex : 0u;
  }

  /// The corner of an irregular unsplit face (canonical level, k >= 2) from which its
  /// triangulation can be a cone without new points: the facets containing the corner are cones
  /// from it, and the others are shallow. Corners on the template's diagonals come first, so
  /// that neighbouring cubes find cones more often. -1 if there is none.
  int ExtendedApex(const Face& face) const
  {
    const int k = PopCount(face.FreeAxes);
    const int corners = 1 << k;
    // Facets by (freeIndex, side): shallow, and the face's corners they are cones from.
    std::array<bool, 2 * Dim> shallow{};
    std::array<unsigned, 2 * Dim> coneCorners{};
    for (int freeIndex = 0; freeIndex < k; ++freeIndex)
    {
      for (int side = 0; side < 2; ++side)
      {
        const Face facet = this->Facet(face, freeIndex, side);
        shallow[2 * freeIndex + side] = this->IsShallow(facet);
        const unsigned facetCones = this->ConeCorners(facet);
        const unsigned below = (1u << freeIndex) - 1u;
        for (int c = 0; c < corners; ++c)
        {
          // The facet's corner code: the face's without the bit of the facet's normal axis.
          const unsigned facetCorner = (c & below) | ((c >> (freeIndex + 1)) << freeIndex);
          if (((c >> freeIndex) & 1) == side && (facetCones >> facetCorner) & 1u)
          {
            coneCorners[2 * freeIndex + side] |= 1u << c;
          }
        }
      }
    }
    const unsigned preferred = this->DiagonalCorners(face);
    for (int pass = 0; pass < 2; ++pass)
    {
      for (int c = 0; c < corners; ++c)
      {
        if (((preferred >> c) & 1u) != (pass == 0 ? 1u : 0u))
        {
          continue;
        }
        bool fits = true;
        for (int freeIndex = 0; fits && freeIndex < k; ++freeIndex)
        {
          const int near = (c >> freeIndex) & 1;
          fits = (coneCorners[2 * freeIndex + near] & (1u << c)) != 0 &&
            shallow[2 * freeIndex + 1 - near];
        }
        if (fits)
        {
          return c;
        }
      }
    }
    return -1;
  }

  void AppendTemplate(const Point& anchor, const LatticeIndex<Dim>& size, int parity,
    unsigned freeAxes, Cells& out) const
  {
    AppendBoxTemplate<Dim>(this->Options.Template,
      this->Options.Output != TessellationOutput::Simplices, anchor, size, parity, freeAxes, out);
  }

  /// Selects the background leaves of the boundary layers: LayerLeaves[leaf] = 1.
  template <class Executor>
  Status SelectLeaves(Executor& executor)
  {
    this->LayerLeaves.clear();
    if (this->Options.IncludeBackground || this->Options.BoundaryLayers == 0)
    {
      return Status::Ok();
    }
    const Spacetree<Dim>& tree = *this->Tree;
    const std::int64_t leaves = tree.GetNumberOfLeaves();
    this->LayerLeaves.assign(static_cast<std::size_t>(leaves), 0);
    std::vector<std::int64_t> added;
    for (std::int64_t leaf = 0; leaf < leaves; ++leaf)
    {
      if (tree.LeafMaterials[leaf] != BackgroundMaterial)
      {
        added.push_back(leaf);
      }
    }
    LatticeBitset<Dim> covered(this->LatticeDimensions);
    const std::vector<LatticeIndex<Dim>> directions = NeighborDirections<Dim>(false);
    for (int layer = 0; layer < this->Options.BoundaryLayers && !added.empty(); ++layer)
    {
      CoverKernel cover{ &tree, &added, &covered };
      executor.For(0, static_cast<std::int64_t>(added.size()), 256, cover);
      LayerKernel touch{ this, &covered, &directions };
      executor.For(0, leaves, 1024, touch);
      if (executor.ShouldAbort())
      {
        return Status::Aborted();
      }
      added.clear();
      for (std::int64_t leaf = 0; leaf < leaves; ++leaf)
      {
        if (this->LayerLeaves[leaf] == 2)
        {
          this->LayerLeaves[leaf] = 1;
          added.push_back(leaf);
        }
      }
    }
    return Status::Ok();
  }

  /// Marks the lattice cells of the leaves added last as covered.
  struct CoverKernel
  {
    using Scratch = NoScratch;
    const Spacetree<Dim>* Tree;
    const std::vector<std::int64_t>* Leaves;
    LatticeBitset<Dim>* Covered;
    void operator()(NoScratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t i = begin; i < end; ++i)
      {
        const std::int64_t leaf = (*this->Leaves)[i];
        const LatticeIndex<Dim>& anchor = this->Tree->LeafAnchors[leaf];
        const LatticeIndex<Dim> size = this->Tree->GetCellSize(this->Tree->LeafLevels[leaf]);
        LatticeIndex<Dim> upper;
        for (int axis = 0; axis < Dim; ++axis)
        {
          upper[axis] = anchor[axis] + size[axis];
        }
        ForEachLatticePoint<Dim>(
          anchor, upper, [&](const LatticeIndex<Dim>& cell) { this->Covered->Set(cell); });
      }
    }
  };

  /// Marks (2) the background leaves not selected yet that share a point with a covered cell.
  struct LayerKernel
  {
    using Scratch = NoScratch;
    SpacetreeTessellator* Self;
    const LatticeBitset<Dim>* Covered;
    const std::vector<LatticeIndex<Dim>>* Directions;
    void operator()(NoScratch&, std::int64_t begin, std::int64_t end) const
    {
      const Spacetree<Dim>& tree = *this->Self->Tree;
      for (std::int64_t leaf = begin; leaf < end; ++leaf)
      {
        if (tree.LeafMaterials[leaf] == BackgroundMaterial && this->Self->LayerLeaves[leaf] == 0 &&
          !ForEachAdjacentCell<Dim>(tree, leaf, *this->Directions,
            [&](const LatticeIndex<Dim>& cell) { return !this->Covered->Test(cell); }))
        {
          this->Self->LayerLeaves[leaf] = 2; // added by this layer
        }
      }
    }
  };

  /// Marks the output points that lie on the boundary of an output leaf besides its corners,
  /// found by descending its boundary faces through their splits.
  void MarkHangingNodes(const Face& face, std::int64_t leaf) const
  {
    if (face.FreeAxes == 0)
    {
      const Point point = HalfUnits(face.Anchor);
      if (this->PointSet.Test(point) && !this->IsLeafCorner(leaf, face.Anchor))
      {
        this->HangingSet.Set(face.Anchor);
      }
      return;
    }
    const Face canonical{ face.Anchor, this->CanonicalLevel(face.Level, face.FreeAxes),
      face.FreeAxes };
    if (this->IsSplit(canonical))
    {
      this->ForEachChildFace(
        canonical, [&](const Face& child) { this->MarkHangingNodes(child, leaf); });
      return;
    }
    const int k = PopCount(face.FreeAxes);
    for (int freeIndex = 0; freeIndex < k; ++freeIndex)
    {
      for (int side = 0; side < 2; ++side)
      {
        this->MarkHangingNodes(this->Facet(canonical, freeIndex, side), leaf);
      }
    }
  }

  bool IsLeafCorner(std::int64_t leaf, const LatticeIndex<Dim>& vertex) const
  {
    const LatticeIndex<Dim>& anchor = this->Tree->LeafAnchors[leaf];
    const LatticeIndex<Dim> size = this->Tree->GetCellSize(this->Tree->LeafLevels[leaf]);
    for (int axis = 0; axis < Dim; ++axis)
    {
      if (vertex[axis] != anchor[axis] && vertex[axis] != anchor[axis] + size[axis])
      {
        return false;
      }
    }
    return true;
  }

  struct HangingNodeKernel
  {
    using Scratch = NoScratch;
    const SpacetreeTessellator* Self;
    void operator()(NoScratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t leaf = begin; leaf < end; ++leaf)
      {
        if (!this->Self->IsSelected(leaf))
        {
          continue;
        }
        const Face cell = this->Self->LeafFace(leaf);
        for (int freeIndex = 0; freeIndex < Dim; ++freeIndex)
        {
          for (int side = 0; side < 2; ++side)
          {
            this->Self->MarkHangingNodes(this->Self->Facet(cell, freeIndex, side), leaf);
          }
        }
      }
    }
  };

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
          const std::int64_t ids =
            static_cast<std::int64_t>(this->Self->RegularCellCodes(leaf).size());
          this->Self->ConnectivityOffsets[leaf] = ids;
          this->Self->CellOffsets[leaf] = ids / CellPointCount(Dim, this->Self->RegularCellShape());
          continue;
        }
        scratch.LeafCells.Clear();
        this->Self->TessellateLeaf(leaf, scratch);
        for (const Point& point : scratch.LeafCells.Points)
        {
          this->Self->PointSet.Set(point);
        }
        this->Self->CellOffsets[leaf] = static_cast<std::int64_t>(scratch.LeafCells.Size());
        this->Self->ConnectivityOffsets[leaf] =
          static_cast<std::int64_t>(scratch.LeafCells.Points.size());
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
    std::uint8_t* Shapes;
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
        const std::int64_t cell = this->Self->CellOffsets[leaf];
        const std::int64_t count = this->Self->CellOffsets[leaf + 1] - cell;
        IdType* ids = this->Connectivity + this->Self->ConnectivityOffsets[leaf];
        if (this->Self->IsRegularLeaf(leaf))
        {
          const auto corners = this->Self->LeafCorners(leaf);
          std::array<IdType, CubeInfo<Dim>::VerticesPerCell> cornerIds;
          for (int c = 0; c < CubeInfo<Dim>::VerticesPerCell; ++c)
          {
            cornerIds[c] = static_cast<IdType>(this->Self->PointSet.Rank(corners[c]));
          }
          for (std::uint8_t code : this->Self->RegularCellCodes(leaf))
          {
            *ids++ = cornerIds[code];
          }
          if (this->Shapes)
          {
            std::fill(this->Shapes + cell, this->Shapes + cell + count,
              static_cast<std::uint8_t>(this->Self->RegularCellShape()));
          }
        }
        else
        {
          scratch.LeafCells.Clear();
          this->Self->TessellateLeaf(leaf, scratch);
          Orient(scratch.LeafCells);
          for (const Point& point : scratch.LeafCells.Points)
          {
            *ids++ = static_cast<IdType>(this->Self->PointSet.Rank(point));
          }
          if (this->Shapes)
          {
            std::copy(scratch.LeafCells.Shapes.begin(), scratch.LeafCells.Shapes.end(),
              this->Shapes + cell);
          }
        }
        std::fill(this->Materials + cell, this->Materials + cell + count,
          this->Self->Tree->LeafMaterials[leaf]);
      }
      this->Exec->ReportProgress(
        0.5 + 0.4 * static_cast<double>(end) / this->Self->Tree->GetNumberOfLeaves());
    }
  };

  struct InsertedPointKernel
  {
    using Scratch = NoScratch;
    const SpacetreeTessellator* Self;
    std::atomic<std::int64_t>* Inserted;
    void operator()(NoScratch&, std::int64_t begin, std::int64_t end) const
    {
      std::int64_t inserted = 0;
      this->Self->PointSet.VisitSetBits(begin, end,
        [&](std::int64_t, const Point& point) { inserted += !this->Self->IsLeafVertex(point); });
      *this->Inserted += inserted;
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
  TessellationLevelTables<Dim> Tables;
  bool NeedsLevelMap = false;
  /// Levels of the leaves per lattice cell, from Prepare to the end of WriteCells, for
  /// patterns that leave axes unsplit.
  std::unique_ptr<LevelMap<Dim>> Map;
  LatticeBitset<Dim> VertexSet;
  LatticeBitset<Dim> PointSet;
  /// Leaves output: the output points that hang on an output leaf (vertex lattice).
  mutable LatticeBitset<Dim> HangingSet;
  /// Boundary layers: the background leaves selected (1).
  std::vector<std::uint8_t> LayerLeaves;
  std::vector<std::int64_t> CellOffsets;
  std::vector<std::int64_t> ConnectivityOffsets;
  std::int64_t NumberOfPoints = 0;
  std::array<std::vector<std::uint8_t>, 2> RegularCellTables;
};

} // namespace stm

#endif
