// SPDX-License-Identifier: BSD-3-Clause
// Splitting edges inside one material where cells stay beyond the quality bounds (issue 7).
//
// After the smoothing a few cells can stay beyond the bounds because every corner is held:
// junction-line points move only along their lines and quadruple points not at all (AAL, 116
// labels: the two cells above condition number 4 have only junction points as corners). Such a
// cell may still have an edge inside one material: every cell around the edge has that
// material and every facet through the edge is shared by two of them, so the edge lies on no
// interface and not on the outer boundary. Splitting it at a new point m, which no interface
// holds, and moving m widens the cells: each cell around the edge becomes two, with m in place
// of one end or of the other. Wherever m lies inside the star of the edge, the union of the
// new cells is the union of the old ones, so no material's volume and no interface changes.
//
// The cells beyond the bounds (condition number above MaxConditionNumber or smallest dihedral
// angle, for triangles the smallest angle, below MinDihedralAngle) are visited worst first
// (ties: by their corners' coordinates, so that the order does not depend on the numbering).
// For each edge of the cell that lies inside one material, m starts at the edge's midpoint, and
// a compass search (along the axes, from a quarter of the edge's length, halved down to a
// thousandth of it, accepting only strict improvements) lowers the largest badness of the new
// cells: max(condition / MaxConditionNumber, MinDihedralAngle / smallest dihedral angle),
// infinite for a cell that would lose its orientation. The edge whose new cells end least bad is
// split when that is less than the badness of the cells it replaces; otherwise the cell stays. A
// cell already changed by an earlier split is measured again first.
//
// The result is a list of edits (new points, changed and appended cells) that the caller applies;
// it does not depend on the number of threads.
//
// The pieces of a distributed mesh (Exchange) split the edges the whole mesh's run splits. A split
// only reads and changes the cells around the corners of the cell it mends, and a piece holds
// every cell around its own cells' points (one ring of ghost cells). So each piece sends the
// cells around the corners of its own cells beyond the bounds, every piece puts all pieces' cells
// together (points matched by position, which the exchanged smoothing makes equal bit for bit)
// and runs the whole mesh's split on that union: it holds every cell beyond the bounds and each
// cell a split reads, so it makes the whole mesh's splits. Each piece then keeps the edits of the
// cells it holds. Only the cells around bad cells travel, and every piece gets all of them.
#ifndef stmCoreInteriorEdgeSplit_h
#define stmCoreInteriorEdgeSplit_h

#include "Check/SimplexQuality.h"
#include "Common/Execution.h"
#include "Common/Status.h"
#include "Smooth/SmoothingExchange.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <map>
#include <set>
#include <utility>
#include <vector>

namespace stm
{

struct InteriorEdgeSplitOptions
{
  /// The bounds that make a cell a candidate, >= 1 and in [0, 180).
  double MaxConditionNumber = 3.5;
  double MinDihedralAngle = 15.0;
  /// Per input point, non-zero for a point that no split may touch (nullptr: none): an edge with
  /// a held end is not split. A piece of a larger mesh holds the points of its ghost cells; an
  /// edge between two other points has only the piece's own cells around it, and splitting it
  /// changes no facet that the piece shares with another.
  const std::uint8_t* HeldPoints = nullptr;
  /// For the pieces of a distributed mesh (header comment): the exchange, and per cell non-zero
  /// for a ghost cell (nullptr: none). The piece must hold every cell at a point of its own
  /// cells. HeldPoints is then ignored: the pieces split the edges the whole mesh's run splits.
  SmoothingExchange* Exchange = nullptr;
  const std::uint8_t* GhostCells = nullptr;
};

template <int Dim>
class InteriorEdgeSplit
{
public:
  static_assert(Dim >= 2 && Dim <= 4, "edge splitting supports dimensions 2 to 4");
  using CellIds = std::array<std::int64_t, Dim + 1>;

  /// A split edge: its ends, and the new point's place (Dim coordinates). An end may be a point
  /// an earlier split added (an id from the number of input points on, earlier in the list).
  struct NewPoint
  {
    std::int64_t A;
    std::int64_t B;
    std::array<double, Dim> Position;
  };

  /// points: Dim coordinates per point; connectivity: Dim + 1 ids per cell; materials: one per
  /// cell, or nullptr (one material). The edits are in GetNewPoints (numbered after the input's
  /// points, in order), GetChangedCells (input cell -> its new ids) and GetAppendedCells (with
  /// the input cell each was split from, GetAppendedParents).
  template <class IdType, class Executor>
  Status Split(const double* points, std::int64_t numberOfPoints, const IdType* connectivity,
    std::int64_t numberOfCells, const std::int64_t* materials,
    const InteriorEdgeSplitOptions& options, Executor& executor);

  const std::vector<NewPoint>& GetNewPoints() const { return this->NewPoints; }
  const std::map<std::int64_t, CellIds>& GetChangedCells() const { return this->Changed; }
  const std::vector<CellIds>& GetAppendedCells() const { return this->Appended; }
  const std::vector<std::int64_t>& GetAppendedParents() const { return this->AppendedParents; }
  /// Cells beyond the bounds before, and the worst badness before and after (1: at the bounds);
  /// for a piece, those of the whole mesh.
  std::int64_t GetNumberOfCandidates() const { return this->Candidates; }
  double GetWorstBadnessBefore() const { return this->WorstBefore; }
  double GetWorstBadnessAfter() const { return this->WorstAfter; }

private:
  using CandidateList = std::vector<std::pair<double, std::int64_t>>; // (-badness, cell)
  template <class IdType, class Executor>
  CandidateList FindCandidates(
    const IdType* connectivity, std::int64_t numberOfCells, Executor& executor) const;
  /// Sorts worst first, ties by the corners' coordinates (sorted), then by id.
  void SortWorstFirst(CandidateList& candidates) const;
  template <class IdType, class Executor>
  Status SplitWhole(const IdType* connectivity, CandidateList candidates, Executor& executor);
  template <class IdType, class Executor>
  Status SplitPiece(const IdType* connectivity, Executor& executor);

  const double* Point(std::int64_t id) const
  {
    return id < this->NumberOfInputPoints
      ? this->InputPoints + id * Dim
      : this->NewPoints[static_cast<std::size_t>(id - this->NumberOfInputPoints)].Position.data();
  }
  bool IsHeld(std::int64_t point) const
  {
    return this->Options.HeldPoints && point < this->NumberOfInputPoints &&
      this->Options.HeldPoints[point] != 0;
  }
  CellIds Cell(std::int64_t cell) const
  {
    if (cell >= this->NumberOfInputCells)
    {
      return this->Appended[static_cast<std::size_t>(cell - this->NumberOfInputCells)];
    }
    const auto found = this->Changed.find(cell);
    return found != this->Changed.end() ? found->second : this->InputCell(cell);
  }
  std::int64_t Material(std::int64_t cell) const
  {
    const std::int64_t input = cell < this->NumberOfInputCells
      ? cell
      : this->AppendedParents[static_cast<std::size_t>(cell - this->NumberOfInputCells)];
    return this->Materials ? this->Materials[input] : 0;
  }
  /// The badness of the cell with these ids, one of them (`moved`) at `position` when >= 0;
  /// orientation: the sign the cell must keep.
  double Badness(
    const CellIds& ids, std::int64_t moved, const double* position, double orientation) const
  {
    const double* corners[Dim + 1];
    for (int v = 0; v <= Dim; ++v)
    {
      corners[v] = ids[v] == moved ? position : this->Point(ids[v]);
    }
    if (orientation < 0.0)
    {
      std::swap(corners[0], corners[1]);
    }
    const SimplexShape<Dim> shape = MeasureSimplex<Dim>(corners);
    if (!(shape.Determinant > 0.0) || !(shape.MinDihedralDegrees > 0.0))
    {
      return std::numeric_limits<double>::infinity();
    }
    return std::max(shape.Condition / this->Options.MaxConditionNumber,
      this->Options.MinDihedralAngle / shape.MinDihedralDegrees);
  }
  double Orientation(const CellIds& ids) const
  {
    const double* corners[Dim + 1];
    for (int v = 0; v <= Dim; ++v)
    {
      corners[v] = this->Point(ids[v]);
    }
    return MeasureSimplex<Dim>(corners).Determinant < 0.0 ? -1.0 : 1.0;
  }
  /// The cells around edge (a, b) when it lies inside one material, else empty.
  std::vector<std::int64_t> InteriorRing(std::int64_t a, std::int64_t b) const;
  /// The best split of edge (a, b) of the ring: the new cells' worst badness and m's place.
  double BestSplit(std::int64_t a, std::int64_t b, const std::vector<std::int64_t>& ring,
    std::array<double, Dim>& position) const;
  void Apply(std::int64_t a, std::int64_t b, const std::vector<std::int64_t>& ring,
    const std::array<double, Dim>& position);
  CellIds InputCell(std::int64_t cell) const { return this->InputCells.at(cell); }
  template <class IdType>
  static CellIds IdsOf(const IdType* connectivity, std::int64_t cell)
  {
    CellIds ids;
    for (int v = 0; v <= Dim; ++v)
    {
      ids[v] = static_cast<std::int64_t>(connectivity[cell * (Dim + 1) + v]);
    }
    return ids;
  }

  InteriorEdgeSplitOptions Options;
  const double* InputPoints = nullptr;
  std::int64_t NumberOfInputPoints = 0;
  std::int64_t NumberOfInputCells = 0;
  std::map<std::int64_t, CellIds> InputCells; // the input cells with a tracked corner
  const std::int64_t* Materials = nullptr;
  std::map<std::int64_t, std::vector<std::int64_t>> Incidence; // tracked point -> its cells
  std::vector<NewPoint> NewPoints;
  std::map<std::int64_t, CellIds> Changed;
  std::vector<CellIds> Appended;
  std::vector<std::int64_t> AppendedParents;
  std::int64_t Candidates = 0;
  double WorstBefore = 0.0;
  double WorstAfter = 0.0;
};

template <int Dim>
template <class IdType, class Executor>
Status InteriorEdgeSplit<Dim>::Split(const double* points, std::int64_t numberOfPoints,
  const IdType* connectivity, std::int64_t numberOfCells, const std::int64_t* materials,
  const InteriorEdgeSplitOptions& options, Executor& executor)
{
  *this = InteriorEdgeSplit();
  if (!(options.MaxConditionNumber >= 1.0) ||
    !(options.MinDihedralAngle >= 0.0 && options.MinDihedralAngle < 180.0))
  {
    return Status::Invalid(
      "the condition-number bound must be >= 1 and the angle bound in [0, 180) degrees");
  }
  if (numberOfPoints < 0 || numberOfCells < 0 || (numberOfCells > 0 && !connectivity) ||
    (numberOfPoints > 0 && !points))
  {
    return Status::Invalid("the mesh's arrays do not match its sizes");
  }
  for (std::int64_t i = 0; i < numberOfCells * (Dim + 1); ++i)
  {
    if (connectivity[i] < 0 || static_cast<std::int64_t>(connectivity[i]) >= numberOfPoints)
    {
      return Status::Invalid("a cell refers to a point id outside the mesh");
    }
  }
  this->Options = options;
  this->InputPoints = points;
  this->NumberOfInputPoints = numberOfPoints;
  this->NumberOfInputCells = numberOfCells;
  this->Materials = materials;

  if (options.Exchange)
  {
    return this->SplitPiece(connectivity, executor);
  }
  CandidateList candidates = this->FindCandidates(connectivity, numberOfCells, executor);
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }
  return this->SplitWhole(connectivity, std::move(candidates), executor);
}

template <int Dim>
template <class IdType, class Executor>
typename InteriorEdgeSplit<Dim>::CandidateList InteriorEdgeSplit<Dim>::FindCandidates(
  const IdType* connectivity, std::int64_t numberOfCells, Executor& executor) const
{
  // In parallel per chunk, without the ghost cells.
  constexpr std::int64_t Chunk = 1 << 14;
  const std::int64_t chunks = (numberOfCells + Chunk - 1) / Chunk;
  std::vector<CandidateList> found(static_cast<std::size_t>(chunks));
  struct MeasureKernel
  {
    using Scratch = NoScratch;
    const InteriorEdgeSplit* Self;
    const IdType* Connectivity;
    std::int64_t Cells;
    double Cosine; // a little below the cosine of MinDihedralAngle
    CandidateList* Found;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      const std::uint8_t* ghosts = this->Self->Options.GhostCells;
      for (std::int64_t chunk = begin; chunk < end; ++chunk)
      {
        for (std::int64_t c = chunk * Chunk; c < std::min(this->Cells, (chunk + 1) * Chunk); ++c)
        {
          if (ghosts && ghosts[c] != 0)
          {
            continue;
          }
          // Most cells are well within the bounds, which the cosines show without an acos.
          const CellIds ids = IdsOf(this->Connectivity, c);
          const double* corners[Dim + 1];
          for (int v = 0; v <= Dim; ++v)
          {
            corners[v] = this->Self->Point(ids[v]);
          }
          SimplexCosines shape = MeasureSimplexCosines<Dim>(corners);
          if (shape.Determinant < 0.0)
          {
            std::swap(corners[0], corners[1]);
            shape = MeasureSimplexCosines<Dim>(corners);
          }
          if (shape.Determinant > 0.0 &&
            shape.Condition <= this->Self->Options.MaxConditionNumber &&
            shape.LargestDihedralCosine < this->Cosine)
          {
            continue;
          }
          const double badness =
            this->Self->Badness(ids, -1, nullptr, this->Self->Orientation(ids));
          if (badness > 1.0)
          {
            this->Found[chunk].emplace_back(-badness, c);
          }
        }
      }
    }
  };
  const double cosine =
    std::cos(this->Options.MinDihedralAngle * (3.14159265358979323846 / 180.0)) - 1e-9;
  MeasureKernel measure{ this, connectivity, numberOfCells, cosine, found.data() };
  executor.For(0, chunks, 1, measure);
  CandidateList candidates;
  for (const auto& list : found)
  {
    candidates.insert(candidates.end(), list.begin(), list.end());
  }
  return candidates;
}

template <int Dim>
void InteriorEdgeSplit<Dim>::SortWorstFirst(CandidateList& candidates) const
{
  // Ties are rare (symmetric meshes), but their order must be the same in a piece's union as in
  // the whole mesh, whose ids differ.
  auto cornersOf = [this](std::int64_t cell)
  {
    std::array<std::array<double, Dim>, Dim + 1> corners;
    const CellIds ids = this->InputCell(cell);
    for (int v = 0; v <= Dim; ++v)
    {
      std::copy(this->Point(ids[v]), this->Point(ids[v]) + Dim, corners[v].begin());
    }
    std::sort(corners.begin(), corners.end());
    return corners;
  };
  std::sort(candidates.begin(), candidates.end(),
    [&](const std::pair<double, std::int64_t>& x, const std::pair<double, std::int64_t>& y)
    {
      if (x.first != y.first)
      {
        return x.first < y.first;
      }
      const auto cx = cornersOf(x.second), cy = cornersOf(y.second);
      return cx != cy ? cx < cy : x.second < y.second;
    });
}

template <int Dim>
template <class IdType, class Executor>
Status InteriorEdgeSplit<Dim>::SplitWhole(
  const IdType* connectivity, CandidateList candidates, Executor& executor)
{
  // The candidates' cells first: the ties' order reads their corners.
  for (const auto& candidate : candidates)
  {
    this->InputCells[candidate.second] = IdsOf(connectivity, candidate.second);
  }
  this->SortWorstFirst(candidates);
  this->Candidates = static_cast<std::int64_t>(candidates.size());
  this->WorstBefore = candidates.empty() ? 0.0 : -candidates.front().first;
  this->WorstAfter = this->WorstBefore;
  if (candidates.empty())
  {
    return Status::Ok();
  }
  const std::int64_t numberOfPoints = this->NumberOfInputPoints;
  const std::int64_t numberOfCells = this->NumberOfInputCells;

  // Incidence of the candidates' points (the only ends of edges that can be split; a new point
  // is tracked from its creation).
  std::vector<std::uint8_t> tracked(static_cast<std::size_t>(numberOfPoints), 0);
  for (const auto& candidate : candidates)
  {
    for (const std::int64_t id : IdsOf(connectivity, candidate.second))
    {
      tracked[id] = 1;
      this->Incidence[id];
    }
  }
  for (std::int64_t c = 0; c < numberOfCells; ++c)
  {
    for (int v = 0; v <= Dim; ++v)
    {
      const auto id = static_cast<std::int64_t>(connectivity[c * (Dim + 1) + v]);
      if (tracked[id])
      {
        this->Incidence[id].push_back(c);
        this->InputCells[c] = IdsOf(connectivity, c);
      }
    }
  }

  for (const auto& candidate : candidates)
  {
    if (executor.ShouldAbort())
    {
      return Status::Aborted();
    }
    const std::int64_t cell = candidate.second;
    const CellIds ids = this->Cell(cell);
    const double before = this->Badness(ids, -1, nullptr, this->Orientation(ids));
    if (!(before > 1.0))
    {
      continue;
    }
    double best = std::numeric_limits<double>::infinity();
    std::int64_t bestA = -1, bestB = -1;
    std::array<double, Dim> bestPosition{};
    std::vector<std::int64_t> bestRing;
    for (int i = 0; i <= Dim; ++i)
    {
      for (int j = i + 1; j <= Dim; ++j)
      {
        if (this->IsHeld(ids[i]) || this->IsHeld(ids[j]))
        {
          continue;
        }
        const std::vector<std::int64_t> ring = this->InteriorRing(ids[i], ids[j]);
        if (ring.empty())
        {
          continue;
        }
        double ringBefore = 0.0;
        for (const std::int64_t c : ring)
        {
          const CellIds around = this->Cell(c);
          ringBefore =
            std::max(ringBefore, this->Badness(around, -1, nullptr, this->Orientation(around)));
        }
        std::array<double, Dim> position;
        const double after = this->BestSplit(ids[i], ids[j], ring, position);
        if (after < ringBefore && after < best)
        {
          best = after;
          bestA = ids[i];
          bestB = ids[j];
          bestPosition = position;
          bestRing = ring;
        }
      }
    }
    if (bestA >= 0)
    {
      this->Apply(bestA, bestB, bestRing, bestPosition);
    }
  }

  // The worst badness of the changed and appended cells and of the candidates left.
  this->WorstAfter = 0.0;
  for (const auto& candidate : candidates)
  {
    const CellIds ids = this->Cell(candidate.second);
    this->WorstAfter =
      std::max(this->WorstAfter, this->Badness(ids, -1, nullptr, this->Orientation(ids)));
  }
  for (std::int64_t c = 0; c < static_cast<std::int64_t>(this->Appended.size()); ++c)
  {
    const CellIds ids = this->Appended[c];
    this->WorstAfter =
      std::max(this->WorstAfter, this->Badness(ids, -1, nullptr, this->Orientation(ids)));
  }
  return Status::Ok();
}

template <int Dim>
template <class IdType, class Executor>
Status InteriorEdgeSplit<Dim>::SplitPiece(const IdType* connectivity, Executor& executor)
{
  const std::int64_t numberOfPoints = this->NumberOfInputPoints;
  const std::int64_t numberOfCells = this->NumberOfInputCells;

  // What this piece sends: whether it was aborted, the number of cells, and per cell around a
  // corner of its own cells beyond the bounds its material and its corners' coordinates.
  constexpr int CellWidth = 1 + (Dim + 1) * Dim;
  const CandidateList own = this->FindCandidates(connectivity, numberOfCells, executor);
  const bool aborted = executor.ShouldAbort();
  std::vector<double> sent{ aborted ? 1.0 : 0.0, 0.0 };
  if (!aborted && !own.empty())
  {
    std::vector<std::uint8_t> corner(static_cast<std::size_t>(numberOfPoints), 0);
    for (const auto& candidate : own)
    {
      for (const std::int64_t id : IdsOf(connectivity, candidate.second))
      {
        corner[id] = 1;
      }
    }
    for (std::int64_t c = 0; c < numberOfCells; ++c)
    {
      const CellIds ids = IdsOf(connectivity, c);
      if (std::none_of(ids.begin(), ids.end(), [&](std::int64_t id) { return corner[id] != 0; }))
      {
        continue;
      }
      sent.push_back(static_cast<double>(this->Material(c)));
      for (const std::int64_t id : ids)
      {
        sent.insert(sent.end(), this->Point(id), this->Point(id) + Dim);
      }
      sent[1] += 1.0;
    }
  }
  const std::vector<double> all = this->Options.Exchange->Gather(sent);

  // The union of the pieces' cells: points matched by position, each cell once, in the pieces'
  // order (the same on every piece).
  std::map<std::array<double, Dim>, std::int64_t> unionPointIds;
  std::vector<double> unionPoints;
  std::vector<std::int64_t> unionConnectivity, unionMaterials;
  std::set<CellIds> unionCells; // by sorted corner ids
  bool anyAborted = false;
  for (std::size_t at = 0; at + 2 <= all.size();)
  {
    anyAborted = anyAborted || all[at] != 0.0;
    const auto count = static_cast<std::size_t>(all[at + 1]);
    at += 2;
    if (count > (all.size() - at) / CellWidth)
    {
      return Status::Invalid("the pieces' cells for the edge splits arrived incomplete");
    }
    for (std::size_t k = 0; k < count; ++k, at += CellWidth)
    {
      CellIds ids;
      for (int v = 0; v <= Dim; ++v)
      {
        std::array<double, Dim> position;
        std::copy(
          all.data() + at + 1 + v * Dim, all.data() + at + 1 + (v + 1) * Dim, position.begin());
        const auto inserted =
          unionPointIds.emplace(position, static_cast<std::int64_t>(unionPoints.size() / Dim));
        if (inserted.second)
        {
          unionPoints.insert(unionPoints.end(), position.begin(), position.end());
        }
        ids[v] = inserted.first->second;
      }
      CellIds sorted = ids;
      std::sort(sorted.begin(), sorted.end());
      if (unionCells.insert(sorted).second)
      {
        unionConnectivity.insert(unionConnectivity.end(), ids.begin(), ids.end());
        unionMaterials.push_back(static_cast<std::int64_t>(all[at]));
      }
    }
  }
  if (anyAborted)
  {
    return Status::Aborted();
  }

  // The whole mesh's splits, from the union.
  InteriorEdgeSplitOptions wholeOptions;
  wholeOptions.MaxConditionNumber = this->Options.MaxConditionNumber;
  wholeOptions.MinDihedralAngle = this->Options.MinDihedralAngle;
  InteriorEdgeSplit whole;
  const std::int64_t unionInputPoints = static_cast<std::int64_t>(unionPoints.size() / Dim);
  const Status status = whole.Split(unionPoints.data(), unionInputPoints, unionConnectivity.data(),
    static_cast<std::int64_t>(unionMaterials.size()), unionMaterials.data(), wholeOptions,
    executor);
  if (!status.IsOk())
  {
    return status;
  }
  this->Candidates = whole.Candidates;
  this->WorstBefore = whole.WorstBefore;
  this->WorstAfter = whole.WorstAfter;
  if (whole.NewPoints.empty())
  {
    return Status::Ok();
  }

  // This piece's points and cells among the union's. Every cell a split changes or splits from
  // is among the changed input cells.
  std::map<CellIds, std::int64_t> changedBySortedIds;
  for (const auto& changed : whole.Changed)
  {
    CellIds sorted = whole.InputCell(changed.first);
    std::sort(sorted.begin(), sorted.end());
    changedBySortedIds.emplace(sorted, changed.first);
  }
  std::vector<std::int64_t> localPoint(static_cast<std::size_t>(unionInputPoints), -1);
  std::vector<std::int64_t> unionPoint(static_cast<std::size_t>(numberOfPoints), -1);
  for (std::int64_t p = 0; p < numberOfPoints; ++p)
  {
    std::array<double, Dim> position;
    std::copy(this->Point(p), this->Point(p) + Dim, position.begin());
    const auto found = unionPointIds.find(position);
    if (found != unionPointIds.end())
    {
      unionPoint[p] = found->second;
      localPoint[found->second] = p;
    }
  }
  std::map<std::int64_t, std::int64_t> localCell;
  for (std::int64_t c = 0; c < numberOfCells; ++c)
  {
    CellIds sorted = IdsOf(connectivity, c);
    bool inUnion = true;
    for (std::int64_t& id : sorted)
    {
      id = unionPoint[id];
      inUnion = inUnion && id >= 0;
    }
    if (!inUnion)
    {
      continue;
    }
    std::sort(sorted.begin(), sorted.end());
    const auto found = changedBySortedIds.find(sorted);
    if (found != changedBySortedIds.end())
    {
      localCell[found->second] = c;
    }
  }

  // The new points this piece's cells use, numbered after its points in the union's order; an
  // end of a split edge stays in one of the two cells that replace each cell around it, so the
  // ends of the piece's new points are the piece's too.
  std::vector<std::int64_t> localNew(whole.NewPoints.size(), -1);
  auto useNewPoints = [&](const CellIds& ids)
  {
    for (const std::int64_t id : ids)
    {
      if (id >= unionInputPoints)
      {
        localNew[static_cast<std::size_t>(id - unionInputPoints)] = 0;
      }
    }
  };
  for (const auto& changed : whole.Changed)
  {
    if (localCell.count(changed.first))
    {
      useNewPoints(changed.second);
    }
  }
  for (std::size_t k = 0; k < whole.Appended.size(); ++k)
  {
    if (localCell.count(whole.AppendedParents[k]))
    {
      useNewPoints(whole.Appended[k]);
    }
  }
  std::int64_t next = numberOfPoints;
  for (std::int64_t& id : localNew)
  {
    id = id == 0 ? next++ : -1;
  }
  auto toLocal = [&](std::int64_t id)
  {
    return id < unionInputPoints ? localPoint[static_cast<std::size_t>(id)]
                                 : localNew[static_cast<std::size_t>(id - unionInputPoints)];
  };
  bool complete = true;
  auto cellToLocal = [&](const CellIds& ids)
  {
    CellIds local;
    for (int v = 0; v <= Dim; ++v)
    {
      local[v] = toLocal(ids[v]);
      complete = complete && local[v] >= 0;
    }
    return local;
  };
  for (std::size_t n = 0; n < whole.NewPoints.size(); ++n)
  {
    if (localNew[n] >= 0)
    {
      const NewPoint& point = whole.NewPoints[n];
      this->NewPoints.push_back(NewPoint{ toLocal(point.A), toLocal(point.B), point.Position });
      complete = complete && this->NewPoints.back().A >= 0 && this->NewPoints.back().B >= 0;
    }
  }
  for (const auto& changed : whole.Changed)
  {
    const auto found = localCell.find(changed.first);
    if (found != localCell.end())
    {
      this->Changed[found->second] = cellToLocal(changed.second);
    }
  }
  for (std::size_t k = 0; k < whole.Appended.size(); ++k)
  {
    const auto found = localCell.find(whole.AppendedParents[k]);
    if (found != localCell.end())
    {
      this->Appended.push_back(cellToLocal(whole.Appended[k]));
      this->AppendedParents.push_back(found->second);
    }
  }
  if (!complete)
  {
    *this = InteriorEdgeSplit();
    return Status::Invalid("a split edge's cells are not all in the piece: it needs the ghost "
                           "cells at its own cells' points");
  }
  return Status::Ok();
}

template <int Dim>
std::vector<std::int64_t> InteriorEdgeSplit<Dim>::InteriorRing(std::int64_t a, std::int64_t b) const
{
  const auto ofA = this->Incidence.find(a), ofB = this->Incidence.find(b);
  if (ofA == this->Incidence.end() || ofB == this->Incidence.end())
  {
    return {};
  }
  std::vector<std::int64_t> fromA = ofA->second, fromB = ofB->second, ring;
  std::sort(fromA.begin(), fromA.end());
  std::sort(fromB.begin(), fromB.end());
  std::set_intersection(
    fromA.begin(), fromA.end(), fromB.begin(), fromB.end(), std::back_inserter(ring));
  if (ring.empty())
  {
    return {};
  }
  // One material, and every facet through the edge (the corners but one of the others) shared
  // by exactly two cells of the ring.
  const std::int64_t material = this->Material(ring.front());
  std::map<std::vector<std::int64_t>, int> facets;
  for (const std::int64_t c : ring)
  {
    if (this->Material(c) != material)
    {
      return {};
    }
    const CellIds ids = this->Cell(c);
    for (int skip = 0; skip <= Dim; ++skip)
    {
      if (ids[skip] == a || ids[skip] == b)
      {
        continue;
      }
      std::vector<std::int64_t> facet;
      for (int v = 0; v <= Dim; ++v)
      {
        if (v != skip)
        {
          facet.push_back(ids[v]);
        }
      }
      std::sort(facet.begin(), facet.end());
      ++facets[facet];
    }
  }
  for (const auto& facet : facets)
  {
    if (facet.second != 2)
    {
      return {};
    }
  }
  return ring;
}

template <int Dim>
double InteriorEdgeSplit<Dim>::BestSplit(std::int64_t a, std::int64_t b,
  const std::vector<std::int64_t>& ring, std::array<double, Dim>& position) const
{
  // The new cells: each ring cell with m (id -2) in place of a, and in place of b.
  constexpr std::int64_t M = -2;
  std::vector<std::pair<CellIds, double>> cells;
  for (const std::int64_t c : ring)
  {
    const CellIds ids = this->Cell(c);
    const double orientation = this->Orientation(ids);
    for (const std::int64_t end : { a, b })
    {
      CellIds child = ids;
      std::replace(child.begin(), child.end(), end, M);
      cells.emplace_back(child, orientation);
    }
  }
  auto worstAt = [&](const double* x)
  {
    double worst = 0.0;
    for (const auto& cell : cells)
    {
      worst = std::max(worst, this->Badness(cell.first, M, x, cell.second));
    }
    return worst;
  };
  const double* pa = this->Point(a);
  const double* pb = this->Point(b);
  double length = 0.0;
  for (int c = 0; c < Dim; ++c)
  {
    position[c] = 0.5 * (pa[c] + pb[c]);
    length += (pb[c] - pa[c]) * (pb[c] - pa[c]);
  }
  length = std::sqrt(length);
  double best = worstAt(position.data());
  for (double step = 0.25 * length; step >= 1e-3 * length;)
  {
    bool improved = false;
    for (int axis = 0; axis < Dim && !improved; ++axis)
    {
      for (const double sign : { 1.0, -1.0 })
      {
        std::array<double, Dim> trial = position;
        trial[axis] += sign * step;
        const double worst = worstAt(trial.data());
        if (worst < best)
        {
          best = worst;
          position = trial;
          improved = true;
          break;
        }
      }
    }
    if (!improved)
    {
      step *= 0.5;
    }
  }
  return best;
}

template <int Dim>
void InteriorEdgeSplit<Dim>::Apply(std::int64_t a, std::int64_t b,
  const std::vector<std::int64_t>& ring, const std::array<double, Dim>& position)
{
  const std::int64_t m =
    this->NumberOfInputPoints + static_cast<std::int64_t>(this->NewPoints.size());
  this->NewPoints.push_back(NewPoint{ a, b, position });
  std::vector<std::int64_t>& aroundM = this->Incidence[m];
  for (const std::int64_t c : ring)
  {
    const CellIds ids = this->Cell(c);
    CellIds keep = ids, added = ids;
    std::replace(keep.begin(), keep.end(), a, m);   // the slot keeps b
    std::replace(added.begin(), added.end(), b, m); // the appended cell keeps a
    if (c < this->NumberOfInputCells)
    {
      this->Changed[c] = keep;
    }
    else
    {
      this->Appended[static_cast<std::size_t>(c - this->NumberOfInputCells)] = keep;
    }
    const std::int64_t appended =
      this->NumberOfInputCells + static_cast<std::int64_t>(this->Appended.size());
    this->Appended.push_back(added);
    this->AppendedParents.push_back(c < this->NumberOfInputCells
        ? c
        : this->AppendedParents[static_cast<std::size_t>(c - this->NumberOfInputCells)]);
    // a leaves c for the appended cell; the others (b excepted) are in both.
    for (const std::int64_t id : ids)
    {
      const auto tracked = this->Incidence.find(id);
      if (tracked == this->Incidence.end() || id == b)
      {
        continue;
      }
      if (id == a)
      {
        std::replace(tracked->second.begin(), tracked->second.end(), c, appended);
      }
      else
      {
        tracked->second.push_back(appended);
      }
    }
    aroundM.push_back(c);
    aroundM.push_back(appended);
  }
}

} // namespace stm

#endif
