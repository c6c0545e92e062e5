// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreVertexSnap_h
#define stmCoreVertexSnap_h

// Vertex snapping (the paper's section 3.3) for simplicial meshes of any dimension 1 to 4: where
// the separating surface crosses an edge close to one of its vertices, that vertex is moved onto
// the surface (its f becomes exactly the iso-value) instead of cutting the edge, which avoids
// the slivers marching simplices would make next to it.
//
// A cut edge joins a negative and a positive vertex (beyond the zero tolerance, the classes of
// MarchingSimplices). Its intersection parameter t is measured from the negative end; an end's
// distance is t or 1 - t, relative to the edge length. A vertex claims a snap through its
// incident cut edge of smallest distance (ties: the smaller other endpoint), towards that edge's
// intersection point (computed exactly as MarchingSimplices computes the cut vertex, so a
// snapped vertex lands where the cut would have been):
// - Threshold (the paper's rule): when the distance is below Alpha; at Alpha = 0.5 every cut
//   edge's nearer end claims (both at t = 1/2), so no edge stays cut unless a snap is refused.
//   With QualityBound > 0, a snap is also refused where the cut elements around the snapped
//   vertex would be worse than the bound and worse than the plain cut there (measured on the
//   AAL brain mask, labels function: at Alpha 0.34 to 0.5 this takes the worst condition number
//   from 33 to 1.7e14 down to about 4.4 to 5.2; at 1/3 it does not lower the worst element
//   (4.8, cuts at exactly 1/3 of the edge) and adds a few bad ones, so it is off by default).
// - QualityDriven (the paper's proposed improvement; Alpha is ignored): the nearer end of every
//   cut edge is a candidate, with the options: keep the cut, snap along any of its cut edges of
//   distance <= 1/2 (not just the nearest), or nudge (below, with 0.4 for Alpha). It takes the
//   option with the smallest worst condition number of the simplices the cut would make in its
//   incident cells (ties: snap, nearest edge first, then keep the cut; a nudge must be strictly
//   better). The simplices are those MarchingSimplices would write (the same pulling
//   triangulation in global vertex order), so every decision keeps the worst element of the
//   cut mesh from growing. Later decisions next to a point can still make its cells worse, so
//   the rounds are followed by revisits (at the end of Snap).
//
// Nudging: a vertex whose snap is refused would leave cuts closer than Alpha to it (the very
// slivers snapping avoids). Instead its f is pushed away from the iso-value (its sign and place
// kept) just enough that the cut of each of its edges lies at least Alpha (of the edge) from it
// - the zero set moves by less than Alpha of an edge, as a snap would move it - but never so far
// that the cut on an edge to a point already refused comes closer than Alpha to that point. A
// nudge moves cuts towards the other ends, which may then claim a snap and join the candidates.
// GetNudgedFlags and VertexSnapCounts::Nudged report the nudged points (counted as refused too).
//
// Conflicts (candidates sharing a cell) are resolved in rounds: a candidate whose (distance,
// point id) is the smallest of the candidates in its 1-ring is processed; such local minima
// share no cell, so a round runs in parallel without locks, and the result does not depend on
// the number of threads. A processed vertex is moved; the snap is undone (and the vertex
// dropped for good, and nudged) if an incident cell would have all its vertices on the surface
// (the paper: later smoothing could collapse it) or would lose its orientation or become flat
// (MinimumRelativeVolume). After each round the neighbours of snapped and nudged vertices recompute
// their claims, and the neighbours of nudged ones may become candidates, until no candidate is
// left.
//
// A piece of a distributed mesh (VertexSnapOptions::Exchange) decides as the whole mesh does:
// after every round (and every round of revisits) it takes the states of the points it holds
// from the pieces whose own cells have them (SnapExchange), so its ghost cells need only reach
// as far as one round's decisions around its own points read (three rings of cells: the
// neighbours' decisions, which read two rings further), not as far as their chains go.

#include "../Check/SimplexQuality.h"
#include "../Common/Determinant.h"
#include "../Common/Execution.h"
#include "../Common/Status.h"
#include "MarchingSimplices.h"
#include "SnapExchange.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

namespace stm
{

enum class SnapRule
{
  /// Snap where the distance to the intersection is below Alpha (the paper's rule).
  Threshold,
  /// Snap where that does not worsen the cut elements' worst condition number.
  QualityDriven
};

struct VertexSnapOptions
{
  /// Threshold rule: a vertex snaps when an incident edge is cut closer than Alpha times the edge
  /// length to it; 0 to 0.5 (0: never; 0.5: every cut edge). The paper's best is about 1/3.
  double Alpha = 1.0 / 3.0;
  SnapRule Rule = SnapRule::Threshold;
  /// The separating surface is f = IsoValue.
  double IsoValue = 0.0;
  /// A vertex with |f - IsoValue| <= ZeroTolerance is on the surface (as in MarchingSimplices).
  double ZeroTolerance = 1e-9;
  /// Threshold rule: when > 0, a snap is also refused (and the point nudged) where the cut
  /// elements around the snapped point would have a worst condition number above this bound
  /// and above that of the plain cut there. 0 (the default): the paper's rule alone.
  double QualityBound = 0.0;
  /// Per point, 0 for a point that must stay where it is (a snap candidate never; its value
  /// may still be nudged); null: every point may move. The multi-material cut fixes the points
  /// of cells whose material is already assigned.
  const std::uint8_t* Movable = nullptr;
  /// The exchanges with the other pieces of a distributed mesh (SnapExchange), or null for a
  /// whole mesh. With it, the points of the piece's own cells get the whole mesh's decisions.
  SnapExchange* Exchange = nullptr;
};

struct VertexSnapCounts
{
  std::int64_t Snapped = 0;
  /// Refused because an incident cell would have had only vertices on the surface.
  std::int64_t RefusedAllZero = 0;
  /// Refused because an incident cell would have been inverted or flattened.
  std::int64_t RefusedNonPositive = 0;
  /// QualityDriven: refused because the cut elements would have been worse.
  std::int64_t RefusedQuality = 0;
  /// Refused points whose f was pushed away from the iso-value instead ("nudged"; they stay
  /// where they are, and are counted among the refused as well): see VertexSnap.
  std::int64_t Nudged = 0;
  std::int64_t Rounds = 0;
  /// QualityDriven: decisions changed when revisited, and the rounds of revisiting.
  std::int64_t Revised = 0;
  std::int64_t RevisionRounds = 0;

  std::int64_t Refused() const
  {
    return this->RefusedAllZero + this->RefusedNonPositive + this->RefusedQuality;
  }
};

/// The projector that never projects: every snapped vertex goes to its edge's intersection.
struct NoSnapProjection
{
  bool operator()(std::int64_t, const double*, const double*, const double*, double*) const
  {
    return false;
  }
};

namespace detail
{
/// A range kernel for the executor from a callable (begin, end).
template <class Function>
struct SnapKernel
{
  using Scratch = NoScratch;
  Function Work;
  void operator()(Scratch&, std::int64_t begin, std::int64_t end) const { this->Work(begin, end); }
};

template <class Executor, class Function>
void SnapFor(Executor& executor, std::int64_t count, std::int64_t grain, Function&& work)
{
  SnapKernel<std::decay_t<Function>> kernel{ std::forward<Function>(work) };
  executor.For(0, count, grain, kernel);
}
} // namespace detail

/// Snaps the vertices of a simplicial mesh (Dim + 1 point ids per cell) to a level set of a
/// point function, in place. Usage: Snap, then GetMovedFlags and GetCounts.
template <int Dim>
class VertexSnap
{
public:
  static_assert(Dim >= 1 && Dim <= 4, "vertex snapping supports dimensions 1 to 4");

  /// points: Dim coordinates per point; values: one per point; both are updated for the
  /// snapped vertices (values exactly IsoValue). projector(point, const double* current, const
  /// double* target, const double* starBox, double* result) may place a snapped vertex
  /// elsewhere than the edge's intersection `target` (e.g. onto the true surface of an implicit
  /// function): it writes result and returns true, or returns false for the target. starBox
  /// holds the lower then the upper corner (Dim values each) of the box around the cells of the
  /// vertex. A projector that evaluates its function only within that box makes the result a
  /// function of those cells alone, so that the pieces of a distributed mesh, each holding the
  /// cells around its vertices, place a shared vertex alike. A result that is not finite or
  /// lies farther from the vertex than the length of its edge is replaced by the target. The
  /// projector is called from several threads at once. On Aborted the arrays are partly updated.
  template <class IdType, class Projector, class Executor>
  Status Snap(double* points, double* values, std::int64_t numberOfPoints,
    const IdType* connectivity, std::int64_t numberOfCells, const VertexSnapOptions& options,
    Projector&& projector, Executor& executor);

  template <class IdType, class Executor>
  Status Snap(double* points, double* values, std::int64_t numberOfPoints,
    const IdType* connectivity, std::int64_t numberOfCells, const VertexSnapOptions& options,
    Executor& executor)
  {
    return this->Snap(points, values, numberOfPoints, connectivity, numberOfCells, options,
      NoSnapProjection{}, executor);
  }

  /// Per point: 1 where the last Snap moved it.
  const std::vector<std::uint8_t>& GetMovedFlags() const { return this->Moved; }
  /// Per point: 1 where a snap was refused (the point keeps its place; its value too unless
  /// it was nudged).
  const std::vector<std::uint8_t>& GetRefusedFlags() const { return this->Refused; }
  /// Per point: 1 where the last Snap nudged it (changed its value, not its place).
  const std::vector<std::uint8_t>& GetNudgedFlags() const { return this->Nudged; }
  /// Per moved point: the other end of the edge it snapped along (from its first place); -1
  /// where it did not move, and where a piece took the point's state from another piece.
  const std::vector<std::int64_t>& GetSnapEdges() const { return this->SnapEdges; }
  /// Whether every piece of a distributed mesh stopped with this one when the last Snap
  /// failed or was aborted: true when it exchanged to its end; false without an exchange, or
  /// when it dropped an idle one (SnapExchange::IsIdle), whose pieces stop alone.
  bool GetStopsAgreed() const { return this->StopsAgreed; }
  const VertexSnapCounts& GetCounts() const { return this->Counts; }

private:
  enum Outcome : std::uint8_t
  {
    Waiting = 0,
    Snapped = 1,
    AllZero = 2,
    NonPositive = 3,
    WorseQuality = 4,
    OutcomeMask = 7,
    /// Or'ed to a refusal: the point was nudged.
    NudgedFlag = 8
  };
  /// QualityDriven ignores Alpha; its nudge keeps cuts at least this far from the point (0.4
  /// measured best on the AAL brain mask among 1/3, 0.4 and 0.45).
  static constexpr double QualityDrivenNudgeAlpha = 0.4;
  /// QualityDriven revisits the points whose cells have a piece of condition number above
  /// this, each at most MaxRevisions times.
  static constexpr double RevisitAbove = 2.5;
  static constexpr std::uint8_t MaxRevisions = 3;
  /// A snap is refused where a cell's volume would fall below this fraction of the product of
  /// its edge lengths from corner 0: far above a determinant's rounding error (about 1e-15 of
  /// it), far below any cell a cut should keep.
  static constexpr double MinimumRelativeVolume = 1e-10;

  struct Claim
  {
    double Distance = std::numeric_limits<double>::infinity();
    std::int64_t Other = -1;
    bool Before(const Claim& other) const
    {
      return this->Distance < other.Distance ||
        (this->Distance == other.Distance && this->Other < other.Other);
    }
  };

  template <class IdType>
  struct Mesh
  {
    double* Points;
    double* Values;
    std::int8_t* Classes;
    std::int64_t NumberOfPoints;
    const IdType* Connectivity;
    const std::int64_t* Offsets; // point -> incident cells (candidates' only)
    const std::int64_t* Cells;
    double Iso;
    double Tolerance;

    const IdType* CellIds(std::int64_t cell) const { return this->Connectivity + cell * (Dim + 1); }
    VertexClass ClassOf(std::int64_t point) const
    {
      return static_cast<VertexClass>(this->Classes[point]);
    }
  };

  template <class IdType>
  static Claim ComputeClaim(const Mesh<IdType>& mesh, std::int64_t v);
  template <class IdType>
  static double WorstPieceCondition(const Mesh<IdType>& mesh, std::int64_t cell, std::int64_t v,
    const double* position, double value, double limit);

  std::vector<std::uint8_t> Moved;
  std::vector<std::uint8_t> Refused;
  std::vector<std::uint8_t> Nudged;
  std::vector<std::int64_t> SnapEdges;
  bool StopsAgreed = false;
  VertexSnapCounts Counts;
};

template <int Dim>
template <class IdType>
typename VertexSnap<Dim>::Claim VertexSnap<Dim>::ComputeClaim(
  const Mesh<IdType>& mesh, std::int64_t v)
{
  Claim best;
  const VertexClass own = mesh.ClassOf(v);
  if (own == VertexClass::Zero)
  {
    return best;
  }
  const VertexClass opposite =
    own == VertexClass::Negative ? VertexClass::Positive : VertexClass::Negative;
  for (std::int64_t i = mesh.Offsets[v]; i < mesh.Offsets[v + 1]; ++i)
  {
    const IdType* ids = mesh.CellIds(mesh.Cells[i]);
    for (int k = 0; k <= Dim; ++k)
    {
      const auto w = static_cast<std::int64_t>(ids[k]);
      if (mesh.ClassOf(w) != opposite)
      {
        continue;
      }
      // t from the negative end: the same number whichever end computes it.
      const std::int64_t negative = own == VertexClass::Negative ? v : w;
      const std::int64_t positive = own == VertexClass::Negative ? w : v;
      const double t =
        (mesh.Iso - mesh.Values[negative]) / (mesh.Values[positive] - mesh.Values[negative]);
      const Claim claim{ own == VertexClass::Negative ? t : 1.0 - t, w };
      if (claim.Before(best))
      {
        best = claim;
      }
    }
  }
  return best;
}

/// The worst condition number of the simplices MarchingSimplices makes of one cell, with vertex
/// v at `position` with f = `value` (its class from the value). Cut vertices are numbered after
/// every input point in the order of their edges, so within one cell their ranks among the cell's
/// edges reproduce the global pulling order. Once a piece is worse than `limit`, the rest are
/// not measured: the result is then some figure above `limit`, which is all a caller comparing
/// with `limit` needs.
template <int Dim>
template <class IdType>
double VertexSnap<Dim>::WorstPieceCondition(const Mesh<IdType>& mesh, std::int64_t cell,
  std::int64_t v, const double* position, double value, double limit)
{
  using Info = SimplexCutInfo<Dim>;
  const IdType* ids = mesh.CellIds(cell);
  std::int64_t global[Dim + 1];
  const double* x[Dim + 1];
  double f[Dim + 1];
  VertexClass classes[Dim + 1];
  int caseIndex = 0;
  for (int k = Dim; k >= 0; --k)
  {
    global[k] = static_cast<std::int64_t>(ids[k]);
    const bool isV = global[k] == v;
    x[k] = isV ? position : mesh.Points + global[k] * Dim;
    f[k] = isV ? value : mesh.Values[global[k]];
    const double difference = value - mesh.Iso;
    const VertexClass vertexClass = !isV ? mesh.ClassOf(global[k])
      : difference < -mesh.Tolerance     ? VertexClass::Negative
      : difference > mesh.Tolerance      ? VertexClass::Positive
                                         : VertexClass::Zero;
    caseIndex = 3 * caseIndex + static_cast<int>(vertexClass);
    classes[k] = vertexClass;
  }
  double edges[Dim][Dim];
  for (int r = 0; r < Dim; ++r)
  {
    for (int c = 0; c < Dim; ++c)
    {
      edges[r][c] = x[c + 1][r] - x[0][r];
    }
  }
  const bool flip = Determinant<Dim>(edges) < 0; // pieces are oriented like their parent
  auto measure = [flip](const double*(&corners)[Dim + 1])
  {
    if (flip)
    {
      std::swap(corners[0], corners[1]);
    }
    return SimplexCondition<Dim>(corners);
  };
  if (Info::CutEdgeCounts[caseIndex] == 0)
  {
    return measure(x);
  }
  // The cut points of the cut edges only (one negative and one positive end), as
  // MarchingSimplices::Classify places them.
  double cutPoints[Dim + 1][Dim + 1][Dim];
  for (int a = 0; a <= Dim; ++a)
  {
    for (int b = a + 1; b <= Dim; ++b)
    {
      const bool cut =
        (classes[a] == VertexClass::Negative && classes[b] == VertexClass::Positive) ||
        (classes[a] == VertexClass::Positive && classes[b] == VertexClass::Negative);
      if (!cut)
      {
        continue;
      }
      const int lower = global[a] < global[b] ? a : b;
      const int upper = lower == a ? b : a;
      const double fa = f[lower] - mesh.Iso;
      const double fb = f[upper] - mesh.Iso;
      const double t = fa / (fa - fb); // as MarchingSimplices::Classify
      for (int c = 0; c < Dim; ++c)
      {
        cutPoints[a][b][c] = cutPoints[b][a][c] = (1.0 - t) * x[lower][c] + t * x[upper][c];
      }
    }
  }
  double worst = 0.0;
  auto measurePiece = [&](const PieceVertex* simplex)
  {
    const double* corners[Dim + 1];
    for (int k = 0; k <= Dim; ++k)
    {
      corners[k] = simplex[k].IsCut() ? cutPoints[simplex[k].A][simplex[k].B] : x[simplex[k].A];
    }
    worst = std::max(worst, measure(corners));
  };
  if constexpr (Dim <= 3)
  {
    // The pieces by lookup: the cut vertices are numbered after every point in the order of
    // their edges, as PieceTable numbers them (AAL, 116 labels: the pulling recursion and the
    // edge ranks were a third of the snaps' time).
    const auto& entry = PieceTable<Dim>::Get().Of(caseIndex, PieceTable<Dim>::OrderOf(global));
    for (int i = 0; i < entry.Count && !(worst > limit); ++i)
    {
      measurePiece(entry.Pieces[i].data());
    }
  }
  else
  {
    const std::int64_t cutBase = mesh.NumberOfPoints;
    auto globalId = [&](const PieceVertex& vertex) -> std::int64_t {
      return vertex.IsCut() ? cutBase + EdgeRank<Dim>(global, vertex.A, vertex.B)
                            : global[vertex.A];
    };
    ForEachPiece<Dim>(caseIndex, CutSide::Inside, globalId,
      [&](const PieceVertex* simplex, CutSide)
      {
        if (!(worst > limit))
        {
          measurePiece(simplex);
        }
      });
  }
  return worst;
}

template <int Dim>
template <class IdType, class Projector, class Executor>
Status VertexSnap<Dim>::Snap(double* points, double* values, std::int64_t numberOfPoints,
  const IdType* connectivity, std::int64_t numberOfCells, const VertexSnapOptions& options,
  Projector&& projector, Executor& executor)
{
  // A piece that stops before the rounds tells the others, which would wait for it otherwise
  // (1: aborted, 2: failed; the agreement before the rounds).
  // Dropped after the lists when no piece sends anything (SnapExchange::IsIdle).
  SnapExchange* exchange = options.Exchange;
  this->StopsAgreed = exchange != nullptr;
  auto stopBeforeRounds = [exchange](Status status)
  {
    if (exchange)
    {
      exchange->Maximum(status.GetCode() == Status::Code::Aborted ? 1.0 : 2.0);
    }
    return status;
  };
  this->Counts = VertexSnapCounts();
  this->Moved.assign(static_cast<std::size_t>(std::max<std::int64_t>(numberOfPoints, 0)), 0);
  this->Refused.assign(this->Moved.size(), 0);
  this->Nudged.assign(this->Moved.size(), 0);
  this->SnapEdges.assign(this->Moved.size(), -1);
  if (!(options.Alpha >= 0.0 && options.Alpha <= 0.5) || !(options.ZeroTolerance >= 0.0) ||
    !(options.QualityBound >= 0.0) || !std::isfinite(options.ZeroTolerance) ||
    !std::isfinite(options.IsoValue))
  {
    return stopBeforeRounds(
      Status::Invalid("vertex snapping needs 0 <= Alpha <= 0.5, a finite iso-value, a "
                      "finite zero tolerance >= 0 and a quality bound >= 0"));
  }
  if (numberOfPoints < 0 || numberOfCells < 0)
  {
    return stopBeforeRounds(Status::Invalid("negative numbers of points or cells"));
  }
  const double iso = options.IsoValue;
  const double tolerance = options.ZeroTolerance;
  const bool qualityDriven = options.Rule == SnapRule::QualityDriven;
  // A claim at distance d makes a candidate when the rule accepts d: below Alpha, or for the
  // nearer end at all when every cut edge is to be snapped.
  const bool everyEdge = qualityDriven || options.Alpha >= 0.5;
  const double alpha = options.Alpha;
  const double qualityBound = qualityDriven ? 0.0 : options.QualityBound;
  auto accepts = [everyEdge, alpha](double distance)
  { return everyEdge ? distance <= 0.5 : distance < alpha; };

  // Point classes, as MarchingSimplices classes them (f - iso finite).
  auto classOf = [iso, tolerance](double value)
  {
    const double difference = value - iso;
    return static_cast<std::int8_t>(difference < -tolerance ? VertexClass::Negative
        : difference > tolerance                            ? VertexClass::Positive
                                                            : VertexClass::Zero);
  };
  std::vector<std::int8_t> classes(static_cast<std::size_t>(numberOfPoints), 0);
  std::atomic<bool> invalid{ false };
  detail::SnapFor(executor, numberOfPoints, 1 << 16,
    [&](std::int64_t begin, std::int64_t end)
    {
      for (std::int64_t p = begin; p < end; ++p)
      {
        const double difference = values[p] - iso;
        if (!std::isfinite(difference))
        {
          invalid.store(true, std::memory_order_relaxed);
          continue;
        }
        classes[p] = classOf(values[p]);
      }
    });
  if (executor.ShouldAbort())
  {
    return stopBeforeRounds(Status::Aborted());
  }
  if (invalid)
  {
    return stopBeforeRounds(
      Status::Invalid("the separating function has NaN or infinite values (or f - iso "
                      "overflows); a separating function must be finite at every point"));
  }

  // Ends of cut edges: the only points that can claim a snap, and the only ones whose incident
  // cells are needed (far fewer than all points near a surface).
  const std::unique_ptr<std::atomic<std::int64_t>[]> degrees(
    new std::atomic<std::int64_t>[static_cast<std::size_t>(numberOfPoints) + 1]);
  detail::SnapFor(executor, numberOfPoints + 1, 1 << 16,
    [&](std::int64_t begin, std::int64_t end)
    {
      for (std::int64_t p = begin; p < end; ++p)
      {
        degrees[p].store(0, std::memory_order_relaxed);
      }
    });
  std::atomic<bool> badIds{ false };
  auto cellHasBothSigns = [&](const IdType* ids)
  {
    bool negative = false, positive = false;
    for (int k = 0; k <= Dim; ++k)
    {
      negative = negative || classes[ids[k]] == static_cast<std::int8_t>(VertexClass::Negative);
      positive = positive || classes[ids[k]] == static_cast<std::int8_t>(VertexClass::Positive);
    }
    return negative && positive;
  };
  // Progress from the cell passes, which take most of the time before the rounds.
  auto progress = [&](std::int64_t cell, double from, double to)
  {
    if ((cell >> 14) % 8 == 0)
    {
      executor.ReportProgress(from +
        (to - from) * static_cast<double>(cell) /
          static_cast<double>(std::max<std::int64_t>(numberOfCells, 1)));
    }
  };
  std::vector<std::uint8_t> active(static_cast<std::size_t>(numberOfPoints), 0);
  {
    const std::unique_ptr<std::atomic<std::uint8_t>[]> flags(
      new std::atomic<std::uint8_t>[static_cast<std::size_t>(numberOfPoints)]);
    detail::SnapFor(executor, numberOfPoints, 1 << 16,
      [&](std::int64_t begin, std::int64_t end)
      {
        for (std::int64_t p = begin; p < end; ++p)
        {
          flags[p].store(0, std::memory_order_relaxed);
        }
      });
    detail::SnapFor(executor, numberOfCells, 1 << 14,
      [&](std::int64_t begin, std::int64_t end)
      {
        progress(begin, 0.05, 0.2);
        // Abort is polled per range, not per cell: each poll asks VTK which thread this is
        // (AAL brain mask: this pass 0.19 -> 0.02 s).
        if (executor.ShouldAbort())
        {
          return;
        }
        for (std::int64_t cell = begin; cell < end; ++cell)
        {
          const IdType* ids = connectivity + cell * (Dim + 1);
          bool valid = true;
          for (int k = 0; k <= Dim; ++k)
          {
            valid = valid && ids[k] >= 0 && static_cast<std::int64_t>(ids[k]) < numberOfPoints;
          }
          if (!valid)
          {
            badIds.store(true, std::memory_order_relaxed);
            return;
          }
          if (!cellHasBothSigns(ids))
          {
            continue;
          }
          for (int k = 0; k <= Dim; ++k)
          {
            if (classes[ids[k]] != static_cast<std::int8_t>(VertexClass::Zero) &&
              (options.Movable == nullptr || options.Movable[ids[k]] != 0))
            {
              flags[ids[k]].store(1, std::memory_order_relaxed);
            }
          }
        }
      });
    if (executor.ShouldAbort())
    {
      return stopBeforeRounds(Status::Aborted());
    }
    if (badIds)
    {
      return stopBeforeRounds(Status::Invalid("a cell refers to a point id outside the mesh"));
    }
    detail::SnapFor(executor, numberOfPoints, 1 << 16,
      [&](std::int64_t begin, std::int64_t end)
      {
        for (std::int64_t p = begin; p < end; ++p)
        {
          active[p] = flags[p].load(std::memory_order_relaxed);
        }
      });
  }
  executor.ReportProgress(0.2);

  // Point -> cell adjacency (CSR) of the active points, each list sorted.
  detail::SnapFor(executor, numberOfCells, 1 << 14,
    [&](std::int64_t begin, std::int64_t end)
    {
      if (executor.ShouldAbort())
      {
        return;
      }
      progress(begin, 0.2, 0.3);
      for (std::int64_t cell = begin; cell < end; ++cell)
      {
        const IdType* ids = connectivity + cell * (Dim + 1);
        for (int k = 0; k <= Dim; ++k)
        {
          if (active[ids[k]])
          {
            degrees[ids[k]].fetch_add(1, std::memory_order_relaxed);
          }
        }
      }
    });
  if (executor.ShouldAbort())
  {
    return stopBeforeRounds(Status::Aborted());
  }
  std::vector<std::int64_t> offsets(static_cast<std::size_t>(numberOfPoints) + 1, 0);
  for (std::int64_t p = 0; p < numberOfPoints; ++p)
  {
    offsets[p + 1] = offsets[p] + degrees[p].load(std::memory_order_relaxed);
    degrees[p].store(offsets[p], std::memory_order_relaxed); // now the fill cursor
  }
  std::vector<std::int64_t> incident(static_cast<std::size_t>(offsets[numberOfPoints]));
  detail::SnapFor(executor, numberOfCells, 1 << 14,
    [&](std::int64_t begin, std::int64_t end)
    {
      if (executor.ShouldAbort())
      {
        return;
      }
      progress(begin, 0.3, 0.4);
      for (std::int64_t cell = begin; cell < end; ++cell)
      {
        const IdType* ids = connectivity + cell * (Dim + 1);
        for (int k = 0; k <= Dim; ++k)
        {
          if (active[ids[k]])
          {
            incident[degrees[ids[k]].fetch_add(1, std::memory_order_relaxed)] = cell;
          }
        }
      }
    });
  detail::SnapFor(executor, numberOfPoints, 1 << 12,
    [&](std::int64_t begin, std::int64_t end)
    {
      for (std::int64_t p = begin; p < end; ++p)
      {
        std::sort(incident.begin() + offsets[p], incident.begin() + offsets[p + 1]);
      }
    });
  if (executor.ShouldAbort())
  {
    return stopBeforeRounds(Status::Aborted());
  }
  executor.ReportProgress(0.45);

  const Mesh<IdType> mesh{ points, values, classes.data(), numberOfPoints, connectivity,
    offsets.data(), incident.data(), iso, tolerance };
  std::vector<Claim> claims(static_cast<std::size_t>(numberOfPoints));
  std::vector<std::int64_t> candidates;
  for (std::int64_t p = 0; p < numberOfPoints; ++p)
  {
    if (active[p])
    {
      candidates.push_back(p);
    }
  }
  std::vector<std::uint8_t>().swap(active);
  // QualityDriven revisits decisions (below): the active points' first places and values. The
  // active points are also the only ones whose states the pieces of a distributed mesh share:
  // a nudge keeps a point's sign and a snap makes it zero, so no cell gains both signs.
  std::vector<std::int64_t> activePoints;
  std::vector<double> originals; // Dim coordinates and the value per active point
  if (qualityDriven || exchange)
  {
    activePoints = candidates;
  }
  if (qualityDriven)
  {
    originals.resize(activePoints.size() * (Dim + 1));
    for (std::size_t i = 0; i < activePoints.size(); ++i)
    {
      const std::int64_t p = activePoints[i];
      std::copy(points + p * Dim, points + (p + 1) * Dim, originals.data() + i * (Dim + 1));
      originals[i * (Dim + 1) + Dim] = values[p];
    }
  }
  // claims[p] is valid for candidates only; a point that leaves the list never returns.
  std::vector<std::uint8_t> isCandidate(static_cast<std::size_t>(numberOfPoints), 0);
  auto refreshClaims = [&](const std::vector<std::int64_t>& list, const std::uint8_t* onlyNear)
  {
    std::vector<std::uint8_t> keep(list.size(), 0);
    detail::SnapFor(executor, static_cast<std::int64_t>(list.size()), 1024,
      [&](std::int64_t begin, std::int64_t end)
      {
        for (std::int64_t i = begin; i < end; ++i)
        {
          const std::int64_t v = list[i];
          bool stale = onlyNear == nullptr;
          for (std::int64_t j = offsets[v]; j < offsets[v + 1] && !stale; ++j)
          {
            const IdType* ids = connectivity + incident[j] * (Dim + 1);
            for (int k = 0; k <= Dim && !stale; ++k)
            {
              stale = onlyNear[ids[k]] != 0;
            }
          }
          if (stale)
          {
            claims[v] = ComputeClaim(mesh, v);
          }
          keep[i] = accepts(claims[v].Distance) ? 1 : 0;
        }
      });
    std::vector<std::int64_t> kept;
    for (std::size_t i = 0; i < list.size(); ++i)
    {
      isCandidate[list[i]] = keep[i];
      if (keep[i])
      {
        kept.push_back(list[i]);
      }
    }
    return kept;
  };
  candidates = refreshClaims(candidates, nullptr);
  executor.ReportProgress(0.5);
  const double initialCandidates = static_cast<double>(std::max<std::size_t>(candidates.size(), 1));

  // The decision for one selected candidate v, applied in place (header comment).
  const double nudgeAlpha = qualityDriven ? QualityDrivenNudgeAlpha : alpha;
  const double nudgeRatio = nudgeAlpha / (1.0 - nudgeAlpha); // |f(v)| : |f(w)| at distance alpha
  // The distance of the cut on edge (v, w) from v when f(v) = fv, exactly as ComputeClaim.
  auto distanceOf = [&](double fv, std::int64_t w)
  {
    const bool negative = fv < iso;
    const double fNegative = negative ? fv : values[w];
    const double fPositive = negative ? values[w] : fv;
    const double t = (iso - fNegative) / (fPositive - fNegative);
    return negative ? t : 1.0 - t;
  };
  // v's cut edges (distance, other end), nearest first, each once.
  auto collectEdges = [&](std::int64_t v, std::vector<Claim>& edges)
  {
    edges.clear();
    const std::int8_t own = classes[v];
    for (std::int64_t j = offsets[v]; j < offsets[v + 1]; ++j)
    {
      const IdType* ids = connectivity + incident[j] * (Dim + 1);
      for (int k = 0; k <= Dim; ++k)
      {
        const auto w = static_cast<std::int64_t>(ids[k]);
        if (classes[w] != own && classes[w] != static_cast<std::int8_t>(VertexClass::Zero))
        {
          edges.push_back(Claim{ distanceOf(values[v], w), w });
        }
      }
    }
    std::sort(
      edges.begin(), edges.end(), [](const Claim& a, const Claim& b) { return a.Before(b); });
    edges.erase(std::unique(edges.begin(), edges.end(),
                  [](const Claim& a, const Claim& b) { return a.Other == b.Other; }),
      edges.end());
  };
  // Where v goes when it snaps along its edge to w: the cut vertex of MarchingSimplices, or
  // the projector's result within the edge's length of v.
  auto snapTarget = [&](std::int64_t v, std::int64_t w, double* position)
  {
    const double* x = points + v * Dim;
    const double* y = points + w * Dim;
    const std::int64_t lower = std::min(v, w);
    const std::int64_t upper = std::max(v, w);
    const double fa = values[lower] - iso;
    const double fb = values[upper] - iso;
    const double t = fa / (fa - fb); // the cut vertex of MarchingSimplices
    double target[Dim];
    double edgeLength = 0.0;
    double starBox[2 * Dim];
    for (int c = 0; c < Dim; ++c)
    {
      target[c] = (1.0 - t) * points[lower * Dim + c] + t * points[upper * Dim + c];
      edgeLength += (x[c] - y[c]) * (x[c] - y[c]);
      starBox[c] = starBox[Dim + c] = x[c];
    }
    for (std::int64_t j = offsets[v]; j < offsets[v + 1]; ++j)
    {
      const IdType* ids = connectivity + incident[j] * (Dim + 1);
      for (int k = 0; k <= Dim; ++k)
      {
        const double* corner = points + static_cast<std::int64_t>(ids[k]) * Dim;
        for (int c = 0; c < Dim; ++c)
        {
          starBox[c] = std::min(starBox[c], corner[c]);
          starBox[Dim + c] = std::max(starBox[Dim + c], corner[c]);
        }
      }
    }
    bool projected = projector(v, static_cast<const double*>(x), static_cast<const double*>(target),
      static_cast<const double*>(starBox), position);
    double moveLength = 0.0;
    for (int c = 0; c < Dim && projected; ++c)
    {
      projected = std::isfinite(position[c]);
      moveLength += (position[c] - x[c]) * (position[c] - x[c]);
    }
    if (!projected || !(moveLength <= edgeLength))
    {
      std::copy(target, target + Dim, position);
    }
  };
  // Whether an incident cell of v has all its other vertices on the surface.
  auto closesACell = [&](std::int64_t v)
  {
    for (std::int64_t j = offsets[v]; j < offsets[v + 1]; ++j)
    {
      const IdType* ids = connectivity + incident[j] * (Dim + 1);
      bool allZero = true;
      for (int k = 0; k <= Dim; ++k)
      {
        allZero = allZero &&
          (ids[k] == v || classes[ids[k]] == static_cast<std::int8_t>(VertexClass::Zero));
      }
      if (allZero)
      {
        return true;
      }
    }
    return false;
  };
  // Whether every incident cell of v keeps its orientation with v at position, and keeps a
  // volume above MinimumRelativeVolume of the product of its edge vectors from corner 0 (the
  // largest volume those edges could span): a snap onto the plane of the cell's other corners
  // leaves a determinant of rounding noise, of either sign, and the cut's pieces of such a
  // cell are flat (found by FuzzCorePipeline).
  auto keepsOrientation = [&](std::int64_t v, const double* position)
  {
    for (std::int64_t j = offsets[v]; j < offsets[v + 1]; ++j)
    {
      const IdType* ids = connectivity + incident[j] * (Dim + 1);
      double before[Dim][Dim], after[Dim][Dim];
      for (int c = 0; c < Dim; ++c)
      {
        const double* origin = points + ids[0] * Dim;
        const double* movedOrigin = ids[0] == v ? position : origin;
        for (int r = 0; r < Dim; ++r)
        {
          const double* corner = points + ids[c + 1] * Dim;
          const double* movedCorner = ids[c + 1] == v ? position : corner;
          before[r][c] = corner[r] - origin[r];
          after[r][c] = movedCorner[r] - movedOrigin[r];
        }
      }
      double spanned = 1.0;
      for (int c = 0; c < Dim; ++c)
      {
        double squared = 0.0;
        for (int r = 0; r < Dim; ++r)
        {
          squared += after[r][c] * after[r][c];
        }
        spanned *= std::sqrt(squared);
      }
      const double oldVolume = Determinant<Dim>(before);
      const double newVolume = Determinant<Dim>(after);
      const double floor = MinimumRelativeVolume * spanned;
      if (!(oldVolume > 0 ? newVolume > floor : oldVolume < 0 && newVolume < -floor))
      {
        return false;
      }
    }
    return true;
  };
  // The worst condition number of the pieces the cut makes of v's cells with v at position
  // and f(v) = value; past `limit` (an option that has lost already) some figure above it.
  constexpr double NoLimit = std::numeric_limits<double>::infinity();
  auto localWorst = [&](std::int64_t v, const double* position, double value, double limit)
  {
    double worst = 0.0;
    for (std::int64_t j = offsets[v]; j < offsets[v + 1] && !(worst > limit); ++j)
    {
      worst = std::max(worst, WorstPieceCondition(mesh, incident[j], v, position, value, limit));
    }
    return worst;
  };
  // The nudged f(v): |f(v) - iso| raised (never lowered) until the cut of every edge of v lies
  // at least nudgeAlpha (of the edge) from v, but never so far that the cut on an edge to a
  // point whose decision is final comes closer than nudgeAlpha to that point.
  auto nudgedValue = [&](std::int64_t v, const std::vector<Claim>& edges)
  {
    const double own = std::abs(values[v] - iso);
    double largest = 0.0, cap = std::numeric_limits<double>::infinity();
    for (const Claim& edge : edges)
    {
      const double other = std::abs(values[edge.Other] - iso);
      largest = std::max(largest, other);
      if (this->Refused[edge.Other])
      {
        cap = std::min(cap, other / nudgeRatio);
      }
    }
    double magnitude = std::min(nudgeRatio * largest, cap);
    if (!(nudgeAlpha > 0.0) || !(magnitude > own) || !std::isfinite(magnitude))
    {
      return values[v];
    }
    const double sign = values[v] < iso ? -1.0 : 1.0;
    double value = iso + sign * magnitude;
    // Rounding may leave the nearest cut a hair closer than nudgeAlpha: a few ulps more.
    for (int guard = 0; guard < 16; ++guard)
    {
      double nearest = 1.0;
      for (const Claim& edge : edges)
      {
        nearest = std::min(nearest, distanceOf(value, edge.Other));
      }
      const double next = std::nextafter(magnitude, std::numeric_limits<double>::infinity());
      if (nearest >= nudgeAlpha || !(next <= cap))
      {
        break;
      }
      magnitude = next;
      value = iso + sign * magnitude;
    }
    return value;
  };
  auto apply = [&](std::int64_t v, const double* position, std::int64_t other)
  {
    this->SnapEdges[v] = other;
    std::copy(position, position + Dim, points + v * Dim);
    values[v] = iso;
    classes[v] = static_cast<std::int8_t>(VertexClass::Zero);
  };
  // QualityDriven's options for v from its present place and value (its cut edges in `edges`)
  // against staying, whose worst is `best`: the best snap along a cut edge of distance <= 1/2
  // (one as good as staying wins when snapOnTie), else a nudge strictly better than staying.
  // Returns Snapped with `position`, or the reason no snap was taken, with `value` nudged or
  // left; `best` becomes the chosen option's worst.
  auto improve = [&](std::int64_t v, const std::vector<Claim>& edges, bool allZero, bool snapOnTie,
                   double& best, double* position, double& value, std::int64_t& other) -> Outcome
  {
    Outcome outcome = allZero ? AllZero : NonPositive;
    bool snap = false;
    double candidate[Dim];
    for (std::size_t e = 0; e < edges.size() && !allZero; ++e)
    {
      if (!(edges[e].Distance <= 0.5))
      {
        break;
      }
      snapTarget(v, edges[e].Other, candidate);
      if (!keepsOrientation(v, candidate))
      {
        continue;
      }
      outcome = WorseQuality;
      const double snapped = localWorst(v, candidate, iso, best);
      if (snap || !snapOnTie ? snapped < best : snapped <= best)
      {
        best = snapped;
        snap = true;
        other = edges[e].Other;
        std::copy(candidate, candidate + Dim, position);
      }
    }
    if (snap)
    {
      return Snapped;
    }
    const double nudged = nudgedValue(v, edges);
    if (nudged != values[v])
    {
      const double worst = localWorst(v, points + v * Dim, nudged, best);
      if (worst < best)
      {
        best = worst;
        value = nudged;
      }
    }
    return outcome;
  };
  auto Decide = [&](std::int64_t v, std::vector<Claim>& edges) -> std::uint8_t
  {
    collectEdges(v, edges);
    const double* x = points + v * Dim;
    const bool allZero = closesACell(v);
    double position[Dim];
    if (!qualityDriven)
    {
      Outcome outcome = allZero ? AllZero : Snapped;
      if (outcome == Snapped)
      {
        snapTarget(v, claims[v].Other, position);
        outcome = keepsOrientation(v, position) ? Snapped : NonPositive;
      }
      if (outcome == Snapped && qualityBound > 0.0)
      {
        // Compared with the plain cut: against the nudged cut it refuses more snaps and ends
        // worse (measured on the AAL brain mask).
        const double snapped = localWorst(v, position, iso, NoLimit);
        if (snapped > qualityBound && !(snapped <= localWorst(v, x, values[v], NoLimit)))
        {
          outcome = WorseQuality;
        }
      }
      if (outcome == Snapped)
      {
        apply(v, position, claims[v].Other);
        return Snapped;
      }
      const double nudged = nudgedValue(v, edges);
      if (nudged != values[v])
      {
        values[v] = nudged;
        return static_cast<std::uint8_t>(outcome | NudgedFlag);
      }
      return outcome;
    }
    // QualityDriven: the best of keeping the cut, snapping along one of the cut edges of
    // distance <= 1/2 and nudging; on a tie, snapping (the nearest edge first), then cutting.
    double best = localWorst(v, x, values[v], NoLimit);
    double value = values[v];
    std::int64_t other = -1;
    const Outcome outcome = improve(v, edges, allZero, true, best, position, value, other);
    if (outcome == Snapped)
    {
      apply(v, position, other);
      return Snapped;
    }
    if (value != values[v])
    {
      values[v] = value;
      return static_cast<std::uint8_t>(outcome | NudgedFlag);
    }
    return outcome;
  };
  // Every decided point's outcome (with NudgedFlag), for the flags and counts.
  std::vector<std::uint8_t> decisions(static_cast<std::size_t>(numberOfPoints), Waiting);
  auto record = [&](std::int64_t v, std::uint8_t decision)
  {
    decisions[v] = decision;
    const Outcome outcome = static_cast<Outcome>(decision & OutcomeMask);
    this->Moved[v] = outcome == Snapped ? 1 : 0;
    this->Refused[v] = outcome == Snapped || outcome == Waiting ? 0 : 1;
    this->Nudged[v] = (decision & NudgedFlag) ? 1 : 0;
  };

  // A distributed mesh's pieces agree to start (or that one stopped), make the lists, and take
  // the states of the points they hold from the pieces whose own cells have them: a candidate
  // near the ghost cells' far end may have claimed without all its cells.
  std::vector<std::uint8_t> changedNow(static_cast<std::size_t>(numberOfPoints), 0);
  // Per shared point: its place, value and decision, and two flags (in the rounds whether it is
  // a candidate; in the revisits whether it is listed, and its revisions).
  constexpr int StateWidth = Dim + 4;
  std::vector<double> sentStates, receivedStates;
  // Sends this piece's states, takes the received ones and returns the points they changed.
  auto shareStates = [&](auto&& flagsOf, auto&& takeFlags)
  {
    auto pack = [&](std::int64_t slot, double* state)
    {
      const std::int64_t p = activePoints[slot];
      std::copy(points + p * Dim, points + (p + 1) * Dim, state);
      state[Dim] = values[p];
      state[Dim + 1] = decisions[p];
      flagsOf(slot, state + Dim + 2);
    };
    const std::vector<std::int64_t>& sent = exchange->GetSent();
    sentStates.resize(sent.size() * StateWidth);
    for (std::size_t i = 0; i < sent.size(); ++i)
    {
      pack(sent[i], sentStates.data() + i * StateWidth);
    }
    exchange->Share(sentStates, StateWidth, receivedStates);
    const std::vector<std::int64_t>& received = exchange->GetReceived();
    std::vector<std::int64_t> changed;
    for (std::size_t i = 0; i < received.size(); ++i)
    {
      const double* state = receivedStates.data() + i * StateWidth;
      double present[StateWidth] = {};
      pack(received[i], present);
      if (std::equal(state, state + StateWidth, present))
      {
        continue;
      }
      const std::int64_t p = activePoints[received[i]];
      std::copy(state, state + Dim, points + p * Dim);
      values[p] = state[Dim];
      classes[p] = classOf(values[p]);
      const auto decision = static_cast<std::uint8_t>(state[Dim + 1]);
      record(p, decision);
      // Which edge another piece snapped along is not sent.
      this->SnapEdges[p] = -1;
      takeFlags(received[i], state + Dim + 2);
      changed.push_back(p);
    }
    return changed;
  };
  // The candidates after an exchange: the listed points that are candidates, with the claims
  // near the changed points (and of the changed points) computed again.
  auto candidatesAfterExchange = [&](const std::vector<std::int64_t>& changed)
  {
    for (std::int64_t p : changed)
    {
      changedNow[p] = 1;
    }
    std::vector<std::int64_t> listed;
    for (std::int64_t p : activePoints)
    {
      if (isCandidate[p])
      {
        listed.push_back(p);
      }
    }
    std::vector<std::int64_t> refreshed = refreshClaims(listed, changedNow.data());
    for (std::int64_t p : changed)
    {
      changedNow[p] = 0;
    }
    return refreshed;
  };
  auto shareCandidates = [&]()
  {
    const std::vector<std::int64_t> changed = shareStates(
      [&](std::int64_t slot, double* flags)
      {
        flags[0] = isCandidate[activePoints[slot]];
        flags[1] = 0.0;
      },
      [&](std::int64_t slot, const double* flags)
      { isCandidate[activePoints[slot]] = static_cast<std::uint8_t>(flags[0]); });
    candidates = candidatesAfterExchange(changed);
  };
  if (exchange)
  {
    const double stopped = exchange->Maximum(executor.ShouldAbort() ? 1.0 : 0.0);
    if (stopped > 0.0)
    {
      return stopped > 1.0 ? Status::Invalid("another piece of the mesh could not be snapped")
                           : Status::Aborted();
    }
    exchange->List(activePoints.data(), static_cast<std::int64_t>(activePoints.size()));
    if (exchange->IsIdle())
    {
      // No agreements either: each piece goes its own way, and one that stops tells the others
      // at their next agreement after this snap (the caller's).
      exchange = nullptr;
      this->StopsAgreed = false;
    }
    else
    {
      shareCandidates();
    }
  }
  // Whether to go on with another round (every piece alike, while any piece has work), or
  // Aborted.
  auto goOn = [&](bool work, Status& status)
  {
    double state = executor.ShouldAbort() ? 2.0 : work ? 1.0 : 0.0;
    if (exchange)
    {
      state = exchange->Maximum(state);
    }
    status = state > 1.0 ? Status::Aborted() : Status::Ok();
    return state == 1.0;
  };

  // Rounds of independent local minima.
  std::vector<std::uint8_t> freshMark(static_cast<std::size_t>(numberOfPoints), 0);
  std::vector<std::uint8_t> outcomes;
  Status roundStatus;
  while (goOn(!candidates.empty(), roundStatus))
  {
    ++this->Counts.Rounds;
    const auto count = static_cast<std::int64_t>(candidates.size());
    outcomes.assign(candidates.size(), Waiting);
    std::vector<std::uint8_t> selected(candidates.size(), 0);
    detail::SnapFor(executor, count, 1024,
      [&](std::int64_t begin, std::int64_t end)
      {
        for (std::int64_t i = begin; i < end; ++i)
        {
          const std::int64_t v = candidates[i];
          const Claim own{ claims[v].Distance, v };
          bool minimum = true;
          for (std::int64_t j = offsets[v]; j < offsets[v + 1] && minimum; ++j)
          {
            const IdType* ids = connectivity + incident[j] * (Dim + 1);
            for (int k = 0; k <= Dim && minimum; ++k)
            {
              const auto w = static_cast<std::int64_t>(ids[k]);
              minimum = w == v || !isCandidate[w] || own.Before(Claim{ claims[w].Distance, w });
            }
          }
          selected[i] = minimum ? 1 : 0;
        }
      });
    // Local minima share no cell: each reads only points no other one writes (a nudge writes
    // only its own value).
    detail::SnapFor(executor, count, 256,
      [&](std::int64_t begin, std::int64_t end)
      {
        std::vector<Claim> edges; // a candidate's cut edges, nearest first
        for (std::int64_t i = begin; i < end && !executor.ShouldAbort(); ++i)
        {
          if (selected[i])
          {
            outcomes[i] = Decide(candidates[i], edges);
          }
        }
      });
    // The pieces of a distributed mesh stop together, at the next round's agreement.
    if (executor.ShouldAbort() && !exchange)
    {
      return Status::Aborted();
    }
    std::vector<std::int64_t> remaining, roundChanged;
    for (std::int64_t i = 0; i < count; ++i)
    {
      const std::int64_t v = candidates[i];
      if (!selected[i])
      {
        remaining.push_back(v);
        continue;
      }
      isCandidate[v] = 0;
      record(v, outcomes[i]);
      const Outcome outcome = static_cast<Outcome>(outcomes[i] & OutcomeMask);
      if (outcome == Snapped || (outcomes[i] & NudgedFlag))
      {
        changedNow[v] = 1;
        roundChanged.push_back(v);
      }
    }
    // A nudge moves the cuts on v's edges towards their other ends, which may now claim a snap
    // they did not claim before: they join the candidates (each at most once per nudge).
    std::vector<std::int64_t> fresh;
    for (std::int64_t v : roundChanged)
    {
      if (!this->Nudged[v])
      {
        continue;
      }
      for (std::int64_t j = offsets[v]; j < offsets[v + 1]; ++j)
      {
        const IdType* ids = connectivity + incident[j] * (Dim + 1);
        for (int k = 0; k <= Dim; ++k)
        {
          const auto w = static_cast<std::int64_t>(ids[k]);
          if (w != v && !isCandidate[w] && !this->Moved[w] && !this->Refused[w] &&
            classes[w] != static_cast<std::int8_t>(VertexClass::Zero) && !freshMark[w])
          {
            freshMark[w] = 1;
            fresh.push_back(w);
          }
        }
      }
    }
    candidates = refreshClaims(remaining, changedNow.data());
    if (!fresh.empty())
    {
      for (std::int64_t w : fresh)
      {
        freshMark[w] = 0;
      }
      std::sort(fresh.begin(), fresh.end());
      const std::vector<std::int64_t> added = refreshClaims(fresh, nullptr);
      candidates.insert(candidates.end(), added.begin(), added.end());
      std::sort(candidates.begin(), candidates.end());
    }
    for (std::int64_t v : roundChanged)
    {
      changedNow[v] = 0;
    }
    if (exchange)
    {
      shareCandidates();
    }
    executor.ReportProgress(
      0.5 + 0.4 * (1.0 - static_cast<double>(candidates.size()) / initialCandidates));
  }
  if (!roundStatus.IsOk())
  {
    return roundStatus;
  }

  // QualityDriven revisits: a decision was the best for the neighbours of its time, but later
  // decisions next to it may have made its cells worse. Points whose cells have a piece worse
  // than RevisitAbove choose again among staying, going back to their first place and value
  // (and cut), and snapping or nudging from there, given their neighbours' present states; a
  // change must lower their worst. Rounds of local maxima of that worst (ties: smaller id)
  // share no cell; a point changes at most MaxRevisions times, so the pass ends.
  // Every piece of a distributed mesh takes part, with active points or without.
  if (qualityDriven && (exchange || !activePoints.empty()))
  {
    const auto activeCount = static_cast<std::int64_t>(activePoints.size());
    // A point's slot by lookup, not by binary search in activePoints: the 1-ring walks below
    // test every corner of every incident cell, round after round (AAL, 116 labels: the
    // searches took 0.6 s of the steps' snaps).
    std::vector<std::int64_t> slotOfPoint(static_cast<std::size_t>(numberOfPoints), -1);
    for (std::int64_t i = 0; i < activeCount; ++i)
    {
      slotOfPoint[activePoints[i]] = i;
    }
    std::vector<double> worst(activePoints.size(), 0.0);
    std::vector<std::uint8_t> revisions(activePoints.size(), 0);
    std::vector<std::uint8_t> listed(activePoints.size(), 0);
    auto measureWorst = [&](const std::vector<std::int64_t>& slots)
    {
      detail::SnapFor(executor, static_cast<std::int64_t>(slots.size()), 256,
        [&](std::int64_t begin, std::int64_t end)
        {
          for (std::int64_t i = begin; i < end; ++i)
          {
            // Only the points above RevisitAbove need their exact worst; most are below.
            const std::int64_t p = activePoints[slots[i]];
            const double below = localWorst(p, points + p * Dim, values[p], RevisitAbove);
            worst[slots[i]] =
              below > RevisitAbove ? localWorst(p, points + p * Dim, values[p], NoLimit) : below;
          }
        });
    };
    std::vector<std::int64_t> slots(activePoints.size());
    for (std::int64_t i = 0; i < activeCount; ++i)
    {
      slots[i] = i;
    }
    measureWorst(slots);
    std::vector<std::int64_t> list;
    for (std::int64_t i = 0; i < activeCount; ++i)
    {
      if (worst[i] > RevisitAbove)
      {
        list.push_back(i);
        listed[i] = 1;
      }
    }
    // The 1-ring of a point, as active slots, the point's own included.
    auto forEachActiveNeighbour = [&](std::int64_t p, auto&& visit)
    {
      for (std::int64_t j = offsets[p]; j < offsets[p + 1]; ++j)
      {
        const IdType* ids = connectivity + incident[j] * (Dim + 1);
        for (int k = 0; k <= Dim; ++k)
        {
          const std::int64_t slot = slotOfPoint[static_cast<std::int64_t>(ids[k])];
          if (slot >= 0 && !visit(slot))
          {
            return;
          }
        }
      }
    };
    // v's new state, or Waiting when staying is best (v is left as it was).
    auto revise = [&](std::int64_t slot, std::vector<Claim>& edges) -> std::uint8_t
    {
      const std::int64_t v = activePoints[slot];
      const double* first = originals.data() + slot * (Dim + 1);
      // Neighbours may have moved since v left its first place: going back must keep every
      // cell's orientation (and the snaps below keep the first place's).
      if (!keepsOrientation(v, first))
      {
        return Waiting;
      }
      double present[Dim] = {};
      std::copy(points + v * Dim, points + (v + 1) * Dim, present);
      const double presentValue = values[v];
      const std::int8_t presentClass = classes[v];
      const double firstValue = first[Dim];
      // From the first state (no other selected point reads v: they share no cell).
      std::copy(first, first + Dim, points + v * Dim);
      values[v] = firstValue;
      classes[v] = classOf(firstValue);
      double best = worst[slot];
      const double cut = localWorst(v, first, firstValue, best);
      const bool backToCut = cut < best;
      best = std::min(best, cut);
      collectEdges(v, edges);
      double position[Dim];
      double value = firstValue;
      std::int64_t other = -1;
      const Outcome outcome =
        improve(v, edges, closesACell(v), false, best, position, value, other);
      if (outcome == Snapped)
      {
        apply(v, position, other);
        return Snapped;
      }
      if (value != firstValue)
      {
        values[v] = value;
        return static_cast<std::uint8_t>(WorseQuality | NudgedFlag);
      }
      if (backToCut)
      {
        return WorseQuality;
      }
      std::copy(present, present + Dim, points + v * Dim);
      values[v] = presentValue;
      classes[v] = presentClass;
      return Waiting;
    };
    // The active slots around `changed` points (theirs included), sorted, measured again.
    auto measureAround = [&](const std::vector<std::int64_t>& changed)
    {
      std::vector<std::int64_t> touched;
      for (std::int64_t p : changed)
      {
        forEachActiveNeighbour(p,
          [&](std::int64_t other)
          {
            touched.push_back(other);
            return true;
          });
      }
      std::sort(touched.begin(), touched.end());
      touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
      measureWorst(touched);
      return touched;
    };
    // A distributed mesh's pieces take the held points' states, listings and revisions from
    // the pieces whose own cells have them, and measure again around the changed points.
    auto shareListed = [&]()
    {
      const std::vector<std::int64_t> changed = shareStates(
        [&](std::int64_t slot, double* flags)
        {
          flags[0] = listed[slot];
          flags[1] = revisions[slot];
        },
        [&](std::int64_t slot, const double* flags)
        {
          listed[slot] = static_cast<std::uint8_t>(flags[0]);
          revisions[slot] = static_cast<std::uint8_t>(flags[1]);
        });
      measureAround(changed);
      list.clear();
      for (std::int64_t slot = 0; slot < activeCount; ++slot)
      {
        if (listed[slot])
        {
          list.push_back(slot);
        }
      }
    };
    if (exchange)
    {
      shareListed();
    }
    std::vector<std::uint8_t> outcomes;
    // Rounds shrink the list but may list a point again, so this is an estimate that never
    // goes back: on the AAL brain mask the revisits take about a third of the snap.
    const double initialListed = std::max<double>(1.0, static_cast<double>(list.size()));
    double revisitProgress = 0.0;
    Status revisitStatus;
    while (goOn(!list.empty(), revisitStatus))
    {
      revisitProgress =
        std::max(revisitProgress, 1.0 - static_cast<double>(list.size()) / initialListed);
      executor.ReportProgress(0.9 + 0.1 * revisitProgress);
      ++this->Counts.RevisionRounds;
      const auto count = static_cast<std::int64_t>(list.size());
      std::vector<std::uint8_t> selected(list.size(), 0);
      detail::SnapFor(executor, count, 1024,
        [&](std::int64_t begin, std::int64_t end)
        {
          for (std::int64_t i = begin; i < end; ++i)
          {
            const std::int64_t own = list[i];
            bool maximum = true;
            forEachActiveNeighbour(activePoints[own],
              [&](std::int64_t other)
              {
                maximum = other == own || !listed[other] || worst[other] < worst[own] ||
                  (worst[other] == worst[own] && other > own);
                return maximum;
              });
            selected[i] = maximum ? 1 : 0;
          }
        });
      outcomes.assign(list.size(), Waiting);
      detail::SnapFor(executor, count, 64,
        [&](std::int64_t begin, std::int64_t end)
        {
          std::vector<Claim> edges;
          for (std::int64_t i = begin; i < end && !executor.ShouldAbort(); ++i)
          {
            if (selected[i])
            {
              outcomes[i] = revise(list[i], edges);
            }
          }
        });
      if (executor.ShouldAbort() && !exchange)
      {
        return Status::Aborted();
      }
      // Unselected points stay listed; selected ones leave, and come back (with their
      // neighbours) when they or a neighbour changed and are still bad.
      std::vector<std::int64_t> next, changed;
      for (std::int64_t i = 0; i < count; ++i)
      {
        const std::int64_t slot = list[i];
        if (!selected[i])
        {
          next.push_back(slot);
          continue;
        }
        listed[slot] = 0;
        if (outcomes[i] == Waiting)
        {
          continue;
        }
        ++revisions[slot];
        ++this->Counts.Revised;
        record(activePoints[slot], outcomes[i]);
        changed.push_back(activePoints[slot]);
      }
      for (std::int64_t slot : measureAround(changed))
      {
        if (!listed[slot] && worst[slot] > RevisitAbove && revisions[slot] < MaxRevisions)
        {
          listed[slot] = 1;
          next.push_back(slot);
        }
      }
      std::sort(next.begin(), next.end());
      list.swap(next);
      if (exchange)
      {
        shareListed();
      }
    }
    if (!revisitStatus.IsOk())
    {
      return revisitStatus;
    }
  }
  for (std::int64_t v = 0; v < numberOfPoints; ++v)
  {
    if (decisions[v] == Waiting)
    {
      continue;
    }
    switch (static_cast<Outcome>(decisions[v] & OutcomeMask))
    {
      case Snapped:
        ++this->Counts.Snapped;
        break;
      case AllZero:
        ++this->Counts.RefusedAllZero;
        break;
      case NonPositive:
        ++this->Counts.RefusedNonPositive;
        break;
      default:
        ++this->Counts.RefusedQuality;
        break;
    }
    this->Counts.Nudged += (decisions[v] & NudgedFlag) ? 1 : 0;
  }
  executor.ReportProgress(1.0);
  return Status::Ok();
}

} // namespace stm

#endif
