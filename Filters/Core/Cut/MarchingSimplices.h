// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreMarchingSimplices_h
#define stmCoreMarchingSimplices_h

// Marching simplices (the paper's section 3.2) for simplicial meshes of any dimension 1 to 4.
//
// Every vertex is classed negative (f < iso - tolerance: inside), zero or positive (outside).
// Only edges from a negative to a positive vertex are cut, at the zero of the linear interpolant
// (one cut vertex per edge, numbered after the input points in sorted edge order, so the number
// does not depend on the cell order). A simplex with n+ positive, n0 zero and n- negative
// vertices P, Z, M is split into the two convex pieces of its linear interpolant: the positive
// piece is the join of the zero vertices with the product of simplices P x (M + *), whose vertex
// (p, *) is p itself and (p, m) the cut vertex of edge pm; the negative piece is the same with
// the roles swapped. (In 3D these are the paper's tet + prism, two prisms, tet + pyramid and two
// tets.) Each piece is cut into simplices by the *pulling* triangulation in the order of the
// global vertex numbers: cone from the piece's smallest vertex over the pulling triangulations
// of the facets that avoid it. Every face is thus triangulated by a rule that depends only on
// the face and the global order, so neighbouring cells agree without Steiner points; for a
// quadrilateral this is the diagonal through its smallest vertex (the paper's rule, [20]), for a
// prism the Dompierre split. The number of simplices of a piece depends only on (n+, n0, n-):
// a product of simplices of dimensions a and b always has C(a + b, a) of them (the case tables).
// Pieces are oriented like the parent, from their barycentric coordinates (exact).
//
// A simplex without both signs is not split. When all its vertices are zero (the paper's n0 = 4
// case) the caller decides its side (the paper: the material of the underlying cell).

#include "../Common/Determinant.h"
#include "../Common/Execution.h"
#include "../Common/Status.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

namespace stm
{

/// Which side of the separating surface a piece lies on.
enum class CutSide : std::uint8_t
{
  Inside = 0, // f < iso
  Outside = 1 // f > iso
};

/// Which pieces the volume output keeps.
enum class KeptSides
{
  Both,
  Inside,
  Outside
};

/// Vertex classes, in the digit order of the case index.
enum class VertexClass : std::int8_t
{
  Negative = 0,
  Zero = 1,
  Positive = 2
};

namespace detail
{
constexpr int Power3(int exponent)
{
  return exponent == 0 ? 1 : 3 * Power3(exponent - 1);
}

constexpr int Binomial(int n, int k)
{
  if (k < 0 || k > n)
  {
    return 0;
  }
  int result = 1;
  for (int i = 1; i <= k; ++i)
  {
    result = result * (n - k + i) / i;
  }
  return result;
}

constexpr int PopCount(unsigned bits)
{
  int count = 0;
  for (; bits != 0; bits &= bits - 1)
  {
    ++count;
  }
  return count;
}
} // namespace detail

/// Case tables of a d-simplex: a case is the vertex classes as base-3 digits, vertex 0 lowest.
template <int Dim>
struct SimplexCutInfo
{
  static_assert(Dim >= 1 && Dim <= 4, "marching simplices support dimensions 1 to 4");
  static constexpr int Vertices = Dim + 1;
  static constexpr int Edges = Dim * (Dim + 1) / 2;
  static constexpr int Cases = detail::Power3(Dim + 1);
  /// Largest number of simplices one piece can have: C(d, floor(d/2)).
  static constexpr int MaxPieceSimplices = detail::Binomial(Dim, Dim / 2);

  static constexpr VertexClass ClassOf(int caseIndex, int vertex)
  {
    for (int v = 0; v < vertex; ++v)
    {
      caseIndex /= 3;
    }
    return static_cast<VertexClass>(caseIndex % 3);
  }

  static constexpr int Count(int caseIndex, VertexClass vertexClass)
  {
    int count = 0;
    for (int v = 0; v < Vertices; ++v)
    {
      count += ClassOf(caseIndex, v) == vertexClass ? 1 : 0;
    }
    return count;
  }

  /// Simplices on the given side of a case: C(|P| - 1 + |M|, |M|) on the positive side (P the
  /// vertices of that side, M those of the other), one for an unsplit simplex; an all-zero
  /// simplex counts on neither side (its side is the caller's).
  static constexpr int SideSimplices(int caseIndex, CutSide side)
  {
    const int own =
      Count(caseIndex, side == CutSide::Inside ? VertexClass::Negative : VertexClass::Positive);
    const int other =
      Count(caseIndex, side == CutSide::Inside ? VertexClass::Positive : VertexClass::Negative);
    return own == 0 ? 0 : detail::Binomial(own - 1 + other, other);
  }

  /// Edges cut by the case (one negative and one positive end).
  static constexpr int CutEdges(int caseIndex)
  {
    return Count(caseIndex, VertexClass::Negative) * Count(caseIndex, VertexClass::Positive);
  }

  static constexpr int AllZeroCase() { return (Cases - 1) / 2; } // every digit 1

  template <class Function>
  static constexpr std::array<std::uint8_t, Cases> Table(Function function)
  {
    std::array<std::uint8_t, Cases> table{};
    for (int c = 0; c < Cases; ++c)
    {
      table[c] = static_cast<std::uint8_t>(function(c));
    }
    return table;
  }

  static constexpr std::array<std::uint8_t, Cases> InsideSimplices =
    Table([](int c) { return SideSimplices(c, CutSide::Inside); });
  static constexpr std::array<std::uint8_t, Cases> OutsideSimplices =
    Table([](int c) { return SideSimplices(c, CutSide::Outside); });
  static constexpr std::array<std::uint8_t, Cases> CutEdgeCounts =
    Table([](int c) { return CutEdges(c); });
};

/// A vertex of a piece: vertex A of the parent when A == B, else the cut vertex of edge AB.
struct PieceVertex
{
  std::int8_t A = 0;
  std::int8_t B = 0;
  bool IsCut() const { return this->A != this->B; }
};

/// The sign of the determinant of a piece simplex's barycentric coordinates (cut vertices at the
/// edge midpoints; the sign holds for any cut parameters in (0, 1) because the pieces stay
/// non-degenerate). Exact: the entries are 0, 1/2, 1.
template <int Dim>
double BarycentricDeterminant(const PieceVertex* simplex)
{
  constexpr int n = Dim + 1;
  double m[n][n];
  for (int r = 0; r < n; ++r)
  {
    for (int c = 0; c < n; ++c)
    {
      m[r][c] = 0.0;
    }
    m[r][simplex[r].A] += simplex[r].IsCut() ? 0.5 : 1.0;
    if (simplex[r].IsCut())
    {
      m[r][simplex[r].B] += 0.5;
    }
  }
  return Determinant<n>(m);
}

/// The orientation of every piece simplex of a Dim-simplex, Dim <= 3, as a table: a piece vertex
/// has a code (vertex v: v; the cut vertex of edge {a, b}: Dim + 1 + the edge's index), a piece
/// the base-Codes number of its vertices' codes, vertex 0 most significant, and Signs the sign
/// of its barycentric determinant (0: degenerate, never a piece). OrientLikeParent runs once
/// for every piece of every cut and every option the snapping weighs, so a lookup replaces the
/// (Dim + 1) x (Dim + 1) determinant (AAL, 116 labels: 13 % of the cut stage's samples).
template <int Dim>
struct PieceOrientation
{
  static_assert(Dim >= 1 && Dim <= 3, "the orientation table covers dimensions 1 to 3");
  static constexpr int Vertices = Dim + 1;
  static constexpr int Codes = Vertices + Dim * (Dim + 1) / 2;
  static constexpr int Pieces = []
  {
    int count = 1;
    for (int v = 0; v < Vertices; ++v)
    {
      count *= Codes;
    }
    return count;
  }();

  static constexpr int CodeOf(int a, int b)
  {
    if (a == b)
    {
      return a;
    }
    const int low = a < b ? a : b, high = a < b ? b : a;
    int edge = 0;
    for (int i = 0; i < low; ++i)
    {
      edge += Dim - i;
    }
    return Vertices + edge + (high - low - 1);
  }

  /// Codes by the vertex pair (A, B) of a piece vertex.
  static constexpr std::array<std::array<std::int8_t, Vertices>, Vertices> CodeTable = []
  {
    std::array<std::array<std::int8_t, Vertices>, Vertices> table{};
    for (int a = 0; a < Vertices; ++a)
    {
      for (int b = 0; b < Vertices; ++b)
      {
        table[a][b] = static_cast<std::int8_t>(CodeOf(a, b));
      }
    }
    return table;
  }();

  // Each piece vertex at twice its barycentric coordinates in the parent, vertex 0 dropped
  // (vertex v: 2 e_v, the cut vertex of edge {a, b}: e_a + e_b, e_0 = 0): the edge vectors'
  // determinant then has the sign of the barycentric one (its rows sum to 2).
  static constexpr std::array<std::int8_t, Pieces> Signs = []
  {
    std::int64_t places[Codes][Dim] = {};
    for (int a = 0; a < Vertices; ++a)
    {
      for (int b = a; b < Vertices; ++b)
      {
        std::int64_t* place = places[CodeOf(a, b)];
        place[a == 0 ? 0 : a - 1] += a == 0 ? 0 : 1;
        place[b == 0 ? 0 : b - 1] += b == 0 ? 0 : 1;
      }
    }
    std::array<std::int8_t, Pieces> signs{};
    for (int piece = 0; piece < Pieces; ++piece)
    {
      std::int64_t simplex[Vertices][Dim] = {};
      for (int r = Vertices - 1, rest = piece; r >= 0; --r, rest /= Codes)
      {
        for (int c = 0; c < Dim; ++c)
        {
          simplex[r][c] = places[rest % Codes][c];
        }
      }
      const std::int64_t determinant = SimplexDeterminant<Dim>(simplex);
      signs[piece] = static_cast<std::int8_t>(determinant > 0 ? 1 : determinant < 0 ? -1 : 0);
    }
    return signs;
  }();

  /// The piece's index into Signs.
  static int IndexOf(const PieceVertex* simplex)
  {
    int index = 0;
    for (int r = 0; r < Vertices; ++r)
    {
      index = index * Codes + CodeTable[simplex[r].A][simplex[r].B];
    }
    return index;
  }
};

/// Puts a piece simplex into the parent's orientation (BarycentricDeterminant's sign), by the
/// table of PieceOrientation up to 3D.
template <int Dim>
void OrientLikeParent(PieceVertex* simplex)
{
  bool reversed = false;
  if constexpr (Dim <= 3)
  {
    reversed = PieceOrientation<Dim>::Signs[PieceOrientation<Dim>::IndexOf(simplex)] < 0;
  }
  else
  {
    reversed = BarycentricDeterminant<Dim>(simplex) < 0;
  }
  if (reversed)
  {
    std::swap(simplex[0], simplex[1]);
  }
}

/// The pieces of one simplex. globalId(PieceVertex) numbers the piece vertices (the pulling
/// order); visit(const PieceVertex* simplex, CutSide side) receives each simplex, oriented like
/// the parent. allZeroSide is the side of a simplex whose vertices are all zero.
template <int Dim, class GlobalId, class Visitor>
void ForEachPiece(int caseIndex, CutSide allZeroSide, GlobalId&& globalId, Visitor&& visit)
{
  using Info = SimplexCutInfo<Dim>;
  unsigned negative = 0, zero = 0, positive = 0;
  for (int v = 0; v < Info::Vertices; ++v)
  {
    const VertexClass vertexClass = Info::ClassOf(caseIndex, v);
    (vertexClass == VertexClass::Negative  ? negative
        : vertexClass == VertexClass::Zero ? zero
                                           : positive) |= 1u << v;
  }
  if (negative == 0 || positive == 0)
  {
    std::array<PieceVertex, Dim + 1> whole;
    for (int v = 0; v < Info::Vertices; ++v)
    {
      whole[v] = PieceVertex{ static_cast<std::int8_t>(v), static_cast<std::int8_t>(v) };
    }
    visit(whole.data(),
      negative != 0     ? CutSide::Inside
        : positive != 0 ? CutSide::Outside
                        : allZeroSide);
    return;
  }
  // Bit Dim + 1 of a B set is the star: the product vertex (a, *) is a itself.
  constexpr unsigned star = 1u << (Dim + 1);
  std::array<PieceVertex, Dim + 1> simplex;
  auto product = [](int a, int b)
  {
    return b == Dim + 1 ? PieceVertex{ static_cast<std::int8_t>(a), static_cast<std::int8_t>(a) }
                        : PieceVertex{ static_cast<std::int8_t>(a), static_cast<std::int8_t>(b) };
  };
  // Pulling triangulation of the face join(zeros, A x B); the first `depth` entries of simplex
  // are the apexes pulled so far.
  auto pull = [&](auto& self, unsigned zeros, unsigned as, unsigned bs, int depth,
                CutSide side) -> void
  {
    if (detail::PopCount(as) == 1 || detail::PopCount(bs) == 1)
    {
      int count = depth;
      for (int z = 0; z <= Dim; ++z)
      {
        if (zeros & (1u << z))
        {
          simplex[count++] =
            PieceVertex{ static_cast<std::int8_t>(z), static_cast<std::int8_t>(z) };
        }
      }
      for (int a = 0; a <= Dim; ++a)
      {
        for (int b = 0; b <= Dim + 1 && (as & (1u << a)); ++b)
        {
          if (bs & (1u << b))
          {
            simplex[count++] = product(a, b);
          }
        }
      }
      std::array<PieceVertex, Dim + 1> oriented = simplex; // the prefix stays for siblings
      OrientLikeParent<Dim>(oriented.data());
      visit(oriented.data(), side);
      return;
    }
    // The smallest vertex of the face.
    std::int64_t smallest = std::numeric_limits<std::int64_t>::max();
    int smallestZero = -1, smallestA = -1, smallestB = -1;
    for (int z = 0; z <= Dim; ++z)
    {
      if (zeros & (1u << z))
      {
        const std::int64_t id =
          globalId(PieceVertex{ static_cast<std::int8_t>(z), static_cast<std::int8_t>(z) });
        if (id < smallest)
        {
          smallest = id;
          smallestZero = z;
        }
      }
    }
    for (int a = 0; a <= Dim; ++a)
    {
      for (int b = 0; b <= Dim + 1 && (as & (1u << a)); ++b)
      {
        if (bs & (1u << b))
        {
          const std::int64_t id = globalId(product(a, b));
          if (id < smallest)
          {
            smallest = id;
            smallestZero = -1;
            smallestA = a;
            smallestB = b;
          }
        }
      }
    }
    if (smallestZero >= 0)
    {
      simplex[depth] = PieceVertex{ static_cast<std::int8_t>(smallestZero),
        static_cast<std::int8_t>(smallestZero) };
      self(self, zeros & ~(1u << smallestZero), as, bs, depth + 1, side);
      return;
    }
    simplex[depth] = product(smallestA, smallestB);
    self(self, zeros, as & ~(1u << smallestA), bs, depth + 1, side);
    simplex[depth] = product(smallestA, smallestB);
    self(self, zeros, as, bs & ~(1u << smallestB), depth + 1, side);
  };
  pull(pull, zero, negative, positive | star, 0, CutSide::Inside);
  pull(pull, zero, positive, negative | star, 0, CutSide::Outside);
}

/// The rank of edge (a, b) among a simplex's edges in the (min, max) order of its corners'
/// distinct numbers: the order of the cut vertices MarchingSimplices numbers by their edges.
template <int Dim, class Number>
int EdgeRank(const Number* numbers, int a, int b)
{
  const auto key = std::minmax(numbers[a], numbers[b]);
  int count = 0;
  for (int c = 0; c <= Dim; ++c)
  {
    for (int d = c + 1; d <= Dim; ++d)
    {
      count += std::minmax(numbers[c], numbers[d]) < key ? 1 : 0;
    }
  }
  return count;
}

/// ForEachPiece's pieces of every case for every order of the corners' global numbers, with
/// the cut vertices numbered after all corners in the (min, max) order of their edges' numbers
/// (MarchingSimplices' numbering, and VertexSnap's per cell). The pulling triangulation depends
/// on nothing else, so callers that cut single simplices over and over (VertexSnap's quality
/// figures) look the pieces up instead of recursing. All-zero cases give the whole simplex on
/// the inside. Built once, on first use; up to 3D (4D: 29,160 entries).
template <int Dim>
class PieceTable
{
public:
  static_assert(Dim >= 1 && Dim <= 3, "piece tables are built for dimensions 1 to 3");
  using Info = SimplexCutInfo<Dim>;
  static constexpr int Vertices = Dim + 1;
  /// Orders of Dim + 1 distinct numbers: (Dim + 1)!.
  static constexpr int Orders = Dim == 1 ? 2 : Dim == 2 ? 6 : 24;
  /// Both sides' pieces.
  static constexpr int MaxPieces = 2 * Info::MaxPieceSimplices;

  struct Entry
  {
    std::int8_t Count = 0;
    std::array<std::array<PieceVertex, Vertices>, MaxPieces> Pieces{};
    std::array<CutSide, MaxPieces> Sides{};
  };

  static const PieceTable& Get()
  {
    static const PieceTable table;
    return table;
  }

  /// The order index (0 to Orders - 1, a Lehmer code) of Dim + 1 distinct numbers.
  template <class Number>
  static int OrderOf(const Number* numbers)
  {
    int order = 0;
    for (int k = 0; k < Vertices; ++k)
    {
      int smallerAfter = 0;
      for (int j = k + 1; j < Vertices; ++j)
      {
        smallerAfter += numbers[j] < numbers[k] ? 1 : 0;
      }
      order = order * (Vertices - k) + smallerAfter;
    }
    return order;
  }

  const Entry& Of(int caseIndex, int order) const
  {
    return this->Entries[static_cast<std::size_t>(caseIndex * Orders + order)];
  }

private:
  PieceTable()
  {
    this->Entries.resize(static_cast<std::size_t>(Info::Cases * Orders));
    std::array<int, Vertices> numbers{};
    for (int v = 0; v < Vertices; ++v)
    {
      numbers[v] = v;
    }
    do
    {
      auto number = [&](const PieceVertex& vertex) -> std::int64_t
      {
        return vertex.IsCut() ? Vertices + EdgeRank<Dim>(numbers.data(), vertex.A, vertex.B)
                              : numbers[vertex.A];
      };
      const int order = OrderOf(numbers.data());
      for (int caseIndex = 0; caseIndex < Info::Cases; ++caseIndex)
      {
        Entry& entry = this->Entries[static_cast<std::size_t>(caseIndex * Orders + order)];
        ForEachPiece<Dim>(caseIndex, CutSide::Inside, number,
          [&](const PieceVertex* simplex, CutSide side)
          {
            std::copy(simplex, simplex + Vertices, entry.Pieces[entry.Count].begin());
            entry.Sides[entry.Count++] = side;
          });
      }
    } while (std::next_permutation(numbers.begin(), numbers.end()));
  }

  std::vector<Entry> Entries;
};

struct MarchingSimplicesOptions
{
  /// The separating surface is f = IsoValue; f < IsoValue is inside.
  double IsoValue = 0.0;
  /// A vertex with |f - IsoValue| <= ZeroTolerance is on the surface (class zero).
  double ZeroTolerance = 0.0;
  KeptSides Keep = KeptSides::Both;
};

/// A cut edge: input points A < B, the cut vertex at (1 - T) x_A + T x_B.
struct CutEdge
{
  std::int64_t A = 0;
  std::int64_t B = 0;
  double T = 0.0;
};

/// Cuts a simplicial mesh (Dim + 1 point ids per cell) at a level of a point function.
/// Usage: Classify, then WriteCells into arrays of GetNumberOfCells() cells, the cut vertices
/// being GetCutEdges() numbered from GetNumberOfInputPoints(); ExtractSurface for the interface.
template <int Dim>
class MarchingSimplices
{
public:
  using Info = SimplexCutInfo<Dim>;
  /// Cells per block of the count and write passes: blocks, not threads, define the layout.
  static constexpr std::int64_t BlockSize = 4096;

  /// Classes the points and cells, counts the output and numbers the cut vertices. values:
  /// one per point; allZeroSide(cell) gives the side of a cell whose vertices are all zero.
  template <class IdType, class AllZeroSide, class Executor>
  Status Classify(const double* values, std::int64_t numberOfPoints, const IdType* connectivity,
    std::int64_t numberOfCells, const MarchingSimplicesOptions& options, AllZeroSide&& allZeroSide,
    Executor& executor);

  std::int64_t GetNumberOfInputPoints() const { return this->NumberOfInputPoints; }
  std::int64_t GetNumberOfCells() const { return this->NumberOfOutputCells; }
  const std::vector<CutEdge>& GetCutEdges() const { return this->Edges; }
  VertexClass GetPointClass(std::int64_t point) const
  {
    return static_cast<VertexClass>(this->PointClasses[point]);
  }
  /// Input cells that are split, and input cells whose vertices are all zero.
  std::int64_t GetNumberOfSplitCells() const { return this->SplitCells; }
  std::int64_t GetNumberOfAllZeroCells() const { return this->AllZeroCells; }
  /// The case of an input cell (see SimplexCutInfo).
  int GetCase(std::int64_t cell) const { return this->Cases[cell]; }

  /// Writes the kept pieces: Dim + 1 ids per cell, the parent cell, the side. Cells come in
  /// input order, each parent's pieces inside first.
  template <class IdType, class OutIdType, class Executor>
  Status WriteCells(const IdType* connectivity, OutIdType* outConnectivity, std::int64_t* parents,
    std::uint8_t* sides, Executor& executor) const;

  /// The interface between inside and outside pieces: facets (Dim ids each, output numbering)
  /// oriented outward from the inside piece (relative to the parent's orientation), and for each
  /// the inside piece's parent cell. Sorted by vertex set.
  template <class IdType, class Executor>
  Status ExtractSurface(const IdType* connectivity, std::vector<std::int64_t>& facets,
    std::vector<std::int64_t>& insideParents, Executor& executor) const;

  /// Output id of the cut vertex of input edge (a, b); -1 when the edge is not cut.
  std::int64_t CutVertexId(std::int64_t a, std::int64_t b) const
  {
    const std::pair<std::int64_t, std::int64_t> key = std::minmax(a, b);
    auto found = std::lower_bound(this->Edges.begin(), this->Edges.end(), key,
      [](const CutEdge& edge, const std::pair<std::int64_t, std::int64_t>& k)
      { return edge.A < k.first || (edge.A == k.first && edge.B < k.second); });
    if (found == this->Edges.end() || found->A != key.first || found->B != key.second)
    {
      return -1;
    }
    return this->NumberOfInputPoints + (found - this->Edges.begin());
  }

private:
  static bool IsCutEdge(int caseIndex, int a, int b)
  {
    const VertexClass ca = Info::ClassOf(caseIndex, a);
    const VertexClass cb = Info::ClassOf(caseIndex, b);
    return (ca == VertexClass::Negative && cb == VertexClass::Positive) ||
      (ca == VertexClass::Positive && cb == VertexClass::Negative);
  }

  /// Output ids of a cell's piece vertices, its cut vertices looked up once.
  template <class IdType>
  struct CellIds
  {
    std::int64_t Ids[Dim + 1][Dim + 1];
    CellIds(const MarchingSimplices* self, const IdType* ids, int caseIndex)
    {
      for (int a = 0; a <= Dim; ++a)
      {
        this->Ids[a][a] = static_cast<std::int64_t>(ids[a]);
        for (int b = a + 1; b <= Dim; ++b)
        {
          this->Ids[a][b] = this->Ids[b][a] =
            IsCutEdge(caseIndex, a, b) ? self->CutVertexId(ids[a], ids[b]) : -1;
        }
      }
    }
    std::int64_t operator()(const PieceVertex& vertex) const
    {
      return this->Ids[vertex.A][vertex.B];
    }
  };

  int CellsOfCase(int caseIndex, CutSide allZeroSide) const
  {
    const bool inside = this->Keep != KeptSides::Outside;
    const bool outside = this->Keep != KeptSides::Inside;
    if (caseIndex == Info::AllZeroCase())
    {
      return (allZeroSide == CutSide::Inside ? inside : outside) ? 1 : 0;
    }
    return (inside ? Info::InsideSimplices[caseIndex] : 0) +
      (outside ? Info::OutsideSimplices[caseIndex] : 0);
  }

  bool Kept(CutSide side) const
  {
    return this->Keep == KeptSides::Both ||
      (side == CutSide::Inside) == (this->Keep == KeptSides::Inside);
  }

  std::int64_t NumberOfInputPoints = 0;
  std::int64_t NumberOfInputCells = 0;
  std::int64_t NumberOfOutputCells = 0;
  std::int64_t SplitCells = 0;
  std::int64_t AllZeroCells = 0;
  KeptSides Keep = KeptSides::Both;
  std::vector<std::int8_t> PointClasses;
  std::vector<std::uint8_t> Cases;        // per input cell
  std::vector<std::uint8_t> AllZeroSides; // per input cell: CutSide of all-zero cells
  std::vector<std::int64_t> BlockOffsets; // first output cell of each block
  std::vector<CutEdge> Edges;             // sorted by (A, B)
};

template <int Dim>
template <class IdType, class AllZeroSide, class Executor>
Status MarchingSimplices<Dim>::Classify(const double* values, std::int64_t numberOfPoints,
  const IdType* connectivity, std::int64_t numberOfCells, const MarchingSimplicesOptions& options,
  AllZeroSide&& allZeroSide, Executor& executor)
{
  if (!(options.ZeroTolerance >= 0.0) || !std::isfinite(options.ZeroTolerance) ||
    !std::isfinite(options.IsoValue))
  {
    return Status::Invalid(
      "the iso-value and the zero tolerance must be finite, the tolerance >= 0");
  }
  this->NumberOfInputPoints = numberOfPoints;
  this->NumberOfInputCells = numberOfCells;
  this->Keep = options.Keep;
  const double iso = options.IsoValue;
  const double tolerance = options.ZeroTolerance;

  // Point classes; a NaN has no side.
  this->PointClasses.assign(static_cast<std::size_t>(numberOfPoints), 0);
  struct PointKernel
  {
    using Scratch = NoScratch;
    std::int8_t* Classes;
    const double* Values;
    double Iso, Tolerance;
    std::atomic<bool>* Invalid;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t p = begin; p < end; ++p)
      {
        const double difference = this->Values[p] - this->Iso;
        if (!std::isfinite(difference))
        {
          this->Invalid->store(true, std::memory_order_relaxed);
          continue;
        }
        this->Classes[p] =
          static_cast<std::int8_t>(difference < -this->Tolerance ? VertexClass::Negative
              : difference > this->Tolerance                     ? VertexClass::Positive
                                                                 : VertexClass::Zero);
      }
    }
  };
  std::atomic<bool> invalid{ false };
  PointKernel pointKernel{ this->PointClasses.data(), values, iso, tolerance, &invalid };
  executor.For(0, numberOfPoints, 1 << 16, pointKernel);
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }
  if (invalid)
  {
    return Status::Invalid("the separating function has NaN or infinite values (or f - iso "
                           "overflows); a separating function must be finite at every point");
  }

  // Cell cases, counts per block, cut edges per block.
  const std::int64_t blocks = (numberOfCells + BlockSize - 1) / BlockSize;
  this->Cases.assign(static_cast<std::size_t>(numberOfCells), 0);
  this->AllZeroSides.assign(static_cast<std::size_t>(numberOfCells), 0);
  this->BlockOffsets.assign(static_cast<std::size_t>(blocks) + 1, 0);
  std::vector<std::vector<std::pair<std::int64_t, std::int64_t>>> blockEdges(
    static_cast<std::size_t>(blocks));
  std::vector<std::int64_t> blockSplit(static_cast<std::size_t>(blocks), 0);
  std::vector<std::int64_t> blockAllZero(static_cast<std::size_t>(blocks), 0);
  std::atomic<bool> badIds{ false };
  struct CellKernel
  {
    using Scratch = NoScratch;
    MarchingSimplices* Self;
    const IdType* Connectivity;
    std::int64_t NumberOfCells;
    std::int64_t NumberOfPoints;
    std::remove_reference_t<AllZeroSide>* ZeroSide;
    std::vector<std::vector<std::pair<std::int64_t, std::int64_t>>>* Edges;
    std::int64_t* Split;
    std::int64_t* AllZero;
    std::atomic<bool>* BadIds;
    Executor* Exec;
    void operator()(Scratch&, std::int64_t beginBlock, std::int64_t endBlock) const
    {
      for (std::int64_t block = beginBlock; block < endBlock; ++block)
      {
        if (this->Exec->ShouldAbort())
        {
          return;
        }
        std::int64_t count = 0;
        auto& edges = (*this->Edges)[block];
        const std::int64_t last = std::min(this->NumberOfCells, (block + 1) * BlockSize);
        for (std::int64_t cell = block * BlockSize; cell < last; ++cell)
        {
          const IdType* ids = this->Connectivity + cell * (Dim + 1);
          int caseIndex = 0;
          for (int v = Dim; v >= 0; --v)
          {
            if (ids[v] < 0 || ids[v] >= this->NumberOfPoints)
            {
              this->BadIds->store(true, std::memory_order_relaxed);
              return;
            }
            caseIndex = 3 * caseIndex + this->Self->PointClasses[ids[v]];
          }
          this->Self->Cases[cell] = static_cast<std::uint8_t>(caseIndex);
          CutSide zeroSide = CutSide::Inside;
          if (caseIndex == Info::AllZeroCase())
          {
            zeroSide = (*this->ZeroSide)(cell);
            this->Self->AllZeroSides[cell] = static_cast<std::uint8_t>(zeroSide);
            ++this->AllZero[block];
          }
          count += this->Self->CellsOfCase(caseIndex, zeroSide);
          if (Info::CutEdgeCounts[caseIndex] == 0)
          {
            continue;
          }
          ++this->Split[block];
          for (int a = 0; a <= Dim; ++a)
          {
            for (int b = a + 1; b <= Dim; ++b)
            {
              if (IsCutEdge(caseIndex, a, b))
              {
                edges.emplace_back(std::minmax<std::int64_t>(ids[a], ids[b]));
              }
            }
          }
        }
        this->Self->BlockOffsets[block + 1] = count;
        if (block % 64 == 0)
        {
          this->Exec->ReportProgress(0.5 * static_cast<double>(block) / this->Blocks());
        }
      }
    }
    double Blocks() const
    {
      return static_cast<double>((this->NumberOfCells + BlockSize - 1) / BlockSize);
    }
  };
  CellKernel cellKernel{ this, connectivity, numberOfCells, numberOfPoints, &allZeroSide,
    &blockEdges, blockSplit.data(), blockAllZero.data(), &badIds, &executor };
  executor.For(0, blocks, 1, cellKernel);
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }
  if (badIds)
  {
    return Status::Invalid("a cell refers to a point id outside the mesh");
  }
  executor.ReportProgress(0.5);
  // The gathering and sorting of the cut edges below is serial (about a third of the run on the
  // AAL brain mask on two threads): an abort requested at the progress event above is honoured
  // here, not after it.
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }
  for (std::int64_t block = 0; block < blocks; ++block)
  {
    this->BlockOffsets[block + 1] += this->BlockOffsets[block];
  }
  this->NumberOfOutputCells = this->BlockOffsets[blocks];
  this->SplitCells = 0;
  this->AllZeroCells = 0;
  std::size_t edgeCount = 0;
  for (std::int64_t block = 0; block < blocks; ++block)
  {
    this->SplitCells += blockSplit[block];
    this->AllZeroCells += blockAllZero[block];
    edgeCount += blockEdges[block].size();
  }
  std::vector<std::pair<std::int64_t, std::int64_t>> keys;
  keys.reserve(edgeCount);
  for (auto& edges : blockEdges)
  {
    keys.insert(keys.end(), edges.begin(), edges.end());
    std::vector<std::pair<std::int64_t, std::int64_t>>().swap(edges);
  }
  std::sort(keys.begin(), keys.end());
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  this->Edges.resize(keys.size());
  for (std::size_t e = 0; e < keys.size(); ++e)
  {
    const double fa = values[keys[e].first] - iso;
    const double fb = values[keys[e].second] - iso;
    this->Edges[e] = CutEdge{ keys[e].first, keys[e].second, fa / (fa - fb) };
  }
  return Status::Ok();
}

template <int Dim>
template <class IdType, class OutIdType, class Executor>
Status MarchingSimplices<Dim>::WriteCells(const IdType* connectivity, OutIdType* outConnectivity,
  std::int64_t* parents, std::uint8_t* sides, Executor& executor) const
{
  const std::int64_t blocks = static_cast<std::int64_t>(this->BlockOffsets.size()) - 1;
  struct WriteKernel
  {
    using Scratch = NoScratch;
    const MarchingSimplices* Self;
    const IdType* Connectivity;
    OutIdType* Out;
    std::int64_t* Parents;
    std::uint8_t* Sides;
    Executor* Exec;
    void operator()(Scratch&, std::int64_t beginBlock, std::int64_t endBlock) const
    {
      for (std::int64_t block = beginBlock; block < endBlock; ++block)
      {
        if (this->Exec->ShouldAbort())
        {
          return;
        }
        std::int64_t next = this->Self->BlockOffsets[block];
        const std::int64_t last = std::min(this->Self->NumberOfInputCells, (block + 1) * BlockSize);
        for (std::int64_t cell = block * BlockSize; cell < last; ++cell)
        {
          const IdType* ids = this->Connectivity + cell * (Dim + 1);
          const int caseIndex = this->Self->Cases[cell];
          const auto zeroSide = static_cast<CutSide>(this->Self->AllZeroSides[cell]);
          if (Info::CutEdgeCounts[caseIndex] == 0)
          {
            const CutSide side = caseIndex == Info::AllZeroCase() ? zeroSide
              : Info::InsideSimplices[caseIndex] != 0             ? CutSide::Inside
                                                                  : CutSide::Outside;
            if (this->Self->Kept(side))
            {
              std::copy(ids, ids + Dim + 1, this->Out + next * (Dim + 1));
              this->Parents[next] = cell;
              this->Sides[next] = static_cast<std::uint8_t>(side);
              ++next;
            }
            continue;
          }
          const CellIds<IdType> global(this->Self, ids, caseIndex);
          ForEachPiece<Dim>(caseIndex, zeroSide, global,
            [&](const PieceVertex* simplex, CutSide side)
            {
              if (!this->Self->Kept(side))
              {
                return;
              }
              for (int v = 0; v <= Dim; ++v)
              {
                this->Out[next * (Dim + 1) + v] = static_cast<OutIdType>(global(simplex[v]));
              }
              this->Parents[next] = cell;
              this->Sides[next] = static_cast<std::uint8_t>(side);
              ++next;
            });
        }
        if (block % 64 == 0)
        {
          const double blocks = static_cast<double>(this->Self->BlockOffsets.size() - 1);
          this->Exec->ReportProgress(0.5 + 0.5 * static_cast<double>(block) / blocks);
        }
      }
    }
  };
  WriteKernel kernel{ this, connectivity, outConnectivity, parents, sides, &executor };
  executor.For(0, blocks, 1, kernel);
  return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
}

template <int Dim>
template <class IdType, class Executor>
Status MarchingSimplices<Dim>::ExtractSurface(const IdType* connectivity,
  std::vector<std::int64_t>& facets, std::vector<std::int64_t>& insideParents,
  Executor& executor) const
{
  // Candidate facets: those of pieces whose vertices are all on the surface (zero or cut),
  // from split cells and from cells with at least Dim zero vertices.
  struct Candidate
  {
    std::array<std::int64_t, Dim> Key;   // sorted
    std::array<std::int64_t, Dim> Facet; // outward from its piece
    std::int64_t Parent;
    CutSide Side;
    bool operator<(const Candidate& other) const
    {
      return this->Key < other.Key || (this->Key == other.Key && this->Side < other.Side);
    }
  };
  const std::int64_t blocks = static_cast<std::int64_t>(this->BlockOffsets.size()) - 1;
  std::vector<std::vector<Candidate>> blockCandidates(static_cast<std::size_t>(blocks));
  struct SurfaceKernel
  {
    using Scratch = NoScratch;
    const MarchingSimplices* Self;
    const IdType* Connectivity;
    std::vector<std::vector<Candidate>>* Candidates;
    Executor* Exec;
    void operator()(Scratch&, std::int64_t beginBlock, std::int64_t endBlock) const
    {
      for (std::int64_t block = beginBlock; block < endBlock; ++block)
      {
        if (this->Exec->ShouldAbort())
        {
          return;
        }
        auto& out = (*this->Candidates)[block];
        const std::int64_t last = std::min(this->Self->NumberOfInputCells, (block + 1) * BlockSize);
        for (std::int64_t cell = block * BlockSize; cell < last; ++cell)
        {
          const int caseIndex = this->Self->Cases[cell];
          if (Info::CutEdgeCounts[caseIndex] == 0 &&
            Info::Count(caseIndex, VertexClass::Zero) < Dim)
          {
            continue;
          }
          const IdType* ids = this->Connectivity + cell * (Dim + 1);
          const CellIds<IdType> global(this->Self, ids, caseIndex);
          const auto zeroSide = static_cast<CutSide>(this->Self->AllZeroSides[cell]);
          ForEachPiece<Dim>(caseIndex, zeroSide, global,
            [&](const PieceVertex* simplex, CutSide side)
            {
              for (int opposite = 0; opposite <= Dim; ++opposite)
              {
                Candidate candidate;
                int count = 0;
                bool onSurface = true;
                for (int v = 0; v <= Dim && onSurface; ++v)
                {
                  if (v == opposite)
                  {
                    continue;
                  }
                  onSurface = simplex[v].IsCut() ||
                    Info::ClassOf(caseIndex, simplex[v].A) == VertexClass::Zero;
                  candidate.Facet[count++] = global(simplex[v]);
                }
                if (!onSurface)
                {
                  continue;
                }
                // The facet opposite vertex i, in order, is outward for even i.
                if (opposite % 2 == 1 && Dim >= 2)
                {
                  std::swap(candidate.Facet[0], candidate.Facet[1]);
                }
                candidate.Key = candidate.Facet;
                std::sort(candidate.Key.begin(), candidate.Key.end());
                candidate.Parent = cell;
                candidate.Side = side;
                out.push_back(candidate);
              }
            });
        }
      }
    }
  };
  SurfaceKernel kernel{ this, connectivity, &blockCandidates, &executor };
  executor.For(0, blocks, 1, kernel);
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }
  std::vector<Candidate> candidates;
  for (auto& block : blockCandidates)
  {
    candidates.insert(candidates.end(), block.begin(), block.end());
    std::vector<Candidate>().swap(block);
  }
  std::sort(candidates.begin(), candidates.end());
  facets.clear();
  insideParents.clear();
  for (std::size_t first = 0; first < candidates.size();)
  {
    std::size_t last = first + 1;
    while (last < candidates.size() && candidates[last].Key == candidates[first].Key)
    {
      ++last;
    }
    // An interface facet: exactly one inside and one outside piece.
    if (last - first == 2 && candidates[first].Side == CutSide::Inside &&
      candidates[first + 1].Side == CutSide::Outside)
    {
      facets.insert(facets.end(), candidates[first].Facet.begin(), candidates[first].Facet.end());
      insideParents.push_back(candidates[first].Parent);
    }
    first = last;
  }
  return Status::Ok();
}

} // namespace stm

#endif
