// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreMultiMaterialCut_h
#define stmCoreMultiMaterialCut_h

// Cutting a labelled simplicial mesh at the interfaces between any number of materials.
//
// Material fractions (CornerFractions): every point gets, for each material, the share of the
// angle (2D) or solid angle (3D) around it that the cells of that material cover. On the
// tessellation of a label image, whose points lie on the lattice of half voxels, this equals the
// d-linear interpolation of the material's voxel indicator on the dual grid: 1/2^d per voxel at a
// voxel corner, as the binary labels function (paper eq. 2) has it for the body. A material's
// region is where its fraction is the largest; the fractions are carried as a sparse vector per
// point, the vector-valued affiliation of the paper's section 3.
//
// Peeling (MultiMaterialCut): the K materials are taken in a fixed order m_0, ..., m_(K-1). Step
// k cuts the cells not yet assigned ("remaining") with the binary marching simplices at the zero
// of
//   g_k = max_{j > k} phi_j - phi_k
// and gives the negative pieces material m_k; what is left after step K - 2 is m_(K-1). A cut
// point's fractions are the linear interpolation of its edge's ends at the cut, so the next steps
// see the same piecewise linear fractions. A cut must split every cell around its edge, assigned
// or not, for the mesh to stay conforming; so g_k is taken as 0 at points that no remaining cell
// uses. An assigned cell then has an edge cut only when both ends touch the remaining region and
// g_k changes sign between them, which happens where the step's interface meets an earlier one
// (a triple line); its pieces keep its material. Step k visits only the cells whose points carry
// m_k (a negative point carries it, and so does every cell around it), so the total work follows
// the cells near the interfaces. Everything is deterministic: the steps are applied one after the
// other and each cut numbers its points in sorted edge order. Consecutive steps whose points are
// disjoint (the two hemispheres' copies of an atlas region) are computed side by side first.
//
// A remaining cell whose points all have g_k = 0 (a tie, e.g. inside a flat one-voxel-thick
// layer, whose voxel corners are all ties) goes to m_k when its input cell was m_k, or was a
// material already peeled and m_k is present at one of its points; so thin layers of either
// side are kept.

#include "../Common/Determinant.h"
#include "../Common/ExactSum.h"
#include "../Common/Execution.h"
#include "../Common/GhostRings.h"
#include "../Common/PointCells.h"
#include "../Common/Status.h"
#include "MarchingSimplices.h"
#include "VertexSnap.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace stm
{

/// Sparse per-point material fractions: each point's row, [Begins[p], Ends[p]) in Materials
/// and Values, sorted by material index (the position in the peeling order). Rows are appended;
/// a replaced row moves to the end.
struct MaterialFractions
{
  std::vector<std::int64_t> Begins;
  std::vector<std::int64_t> Ends;
  std::vector<std::int32_t> Materials;
  std::vector<double> Values;

  std::int64_t GetNumberOfPoints() const { return static_cast<std::int64_t>(this->Begins.size()); }

  /// The fraction of `material` at `point` (0 when absent).
  double Of(std::int64_t point, std::int32_t material) const
  {
    for (std::int64_t e = this->Begins[point]; e < this->Ends[point]; ++e)
    {
      if (this->Materials[e] == material)
      {
        return this->Values[e];
      }
    }
    return 0.0;
  }

  /// Appends a point whose fractions are (1 - t) a + t b of the rows a and b of `from` (which
  /// may be this object).
  void AppendInterpolated(const MaterialFractions& from, std::int64_t a, std::int64_t b, double t)
  {
    this->Begins.push_back(static_cast<std::int64_t>(this->Materials.size()));
    this->AppendRow(from, a, b, t);
    this->Ends.push_back(static_cast<std::int64_t>(this->Materials.size()));
  }

  /// Gives `point` the fractions of row `row` of `from` (another object), at the end.
  void ReplaceRow(std::int64_t point, const MaterialFractions& from, std::int64_t row)
  {
    this->Begins[point] = static_cast<std::int64_t>(this->Materials.size());
    this->Materials.insert(this->Materials.end(), from.Materials.begin() + from.Begins[row],
      from.Materials.begin() + from.Ends[row]);
    this->Values.insert(this->Values.end(), from.Values.begin() + from.Begins[row],
      from.Values.begin() + from.Ends[row]);
    this->Ends[point] = static_cast<std::int64_t>(this->Materials.size());
  }

private:
  // Indices, not references: `from` may be this object, whose arrays grow meanwhile.
  void AppendRow(const MaterialFractions& from, std::int64_t a, std::int64_t b, double t)
  {
    std::int64_t i = from.Begins[a], j = from.Begins[b];
    const std::int64_t iEnd = from.Ends[a], jEnd = from.Ends[b];
    while (i < iEnd || j < jEnd)
    {
      std::int32_t material;
      double value = 0.0;
      if (j >= jEnd || (i < iEnd && from.Materials[i] < from.Materials[j]))
      {
        material = from.Materials[i];
        value = (1.0 - t) * from.Values[i++];
      }
      else if (i >= iEnd || from.Materials[j] < from.Materials[i])
      {
        material = from.Materials[j];
        value = t * from.Values[j++];
      }
      else
      {
        material = from.Materials[i];
        value = (1.0 - t) * from.Values[i++] + t * from.Values[j++];
      }
      if (value > 0.0)
      {
        this->Materials.push_back(material);
        this->Values.push_back(value);
      }
    }
  }
};

/// The angle (2D), solid angle (3D) or 1 (1D) of a simplex at its corner `corner`, from points
/// with three coordinates each (a 2D mesh may lie in any plane).
template <int Dim>
double CornerAngle(const double* const* corners, int corner)
{
  static_assert(Dim >= 1 && Dim <= 3, "corner angles are defined for dimensions 1 to 3");
  if (Dim == 1)
  {
    return 1.0;
  }
  const double* apex = corners[corner];
  double edges[Dim][3];
  for (int k = 0, e = 0; k <= Dim; ++k)
  {
    if (k != corner)
    {
      for (int c = 0; c < 3; ++c)
      {
        edges[e][c] = corners[k][c] - apex[c];
      }
      ++e;
    }
  }
  auto dot = [](const double* u, const double* v)
  { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; };
  auto cross = [](const double* u, const double* v, double* w)
  {
    w[0] = u[1] * v[2] - u[2] * v[1];
    w[1] = u[2] * v[0] - u[0] * v[2];
    w[2] = u[0] * v[1] - u[1] * v[0];
  };
  if (Dim == 2)
  {
    double w[3];
    cross(edges[0], edges[1], w);
    return std::atan2(std::sqrt(dot(w, w)), dot(edges[0], edges[1]));
  }
  // Van Oosterom and Strackee: tan(omega / 2) = |a.(b x c)| / (abc + (a.b)c + (a.c)b + (b.c)a).
  const double* a = edges[0];
  const double* b = edges[1 % Dim];
  const double* c = edges[2 % Dim];
  double bc[3];
  cross(b, c, bc);
  const double la = std::sqrt(dot(a, a)), lb = std::sqrt(dot(b, b)), lc = std::sqrt(dot(c, c));
  const double numerator = std::abs(dot(a, bc));
  const double denominator = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
  return 2.0 * std::atan2(numerator, denominator);
}

/// The full angle around a point: 2 (two directions), 2 pi, 4 pi.
template <int Dim>
constexpr double FullAngle()
{
  return Dim == 1 ? 2.0 : Dim == 2 ? 2.0 * 3.14159265358979323846 : 4.0 * 3.14159265358979323846;
}

/// The material fractions of every point: the share of the (solid) angle around it covered by
/// each material's cells. points: three coordinates per point; materials: per cell, an index in
/// [0, numberOfMaterials). On the mesh boundary the angle no cell covers belongs to
/// outsideMaterial (as the voxels beyond an image are background), or, when it is -1, the
/// covered angle is the whole. A point no cell uses gets no fraction.
template <int Dim, class IdType, class Executor>
Status CornerFractions(const double* points, std::int64_t numberOfPoints,
  const IdType* connectivity, std::int64_t numberOfCells, const std::int32_t* materials,
  int numberOfMaterials, int outsideMaterial, MaterialFractions& fractions, Executor& executor)
{
  if (outsideMaterial < -1 || outsideMaterial >= numberOfMaterials)
  {
    return Status::Invalid("the outside material index is out of range");
  }
  for (std::int64_t i = 0; i < numberOfCells * (Dim + 1); ++i)
  {
    if (connectivity[i] < 0 || connectivity[i] >= numberOfPoints)
    {
      return Status::Invalid("a cell refers to a point id outside the mesh");
    }
  }
  for (std::int64_t c = 0; c < numberOfCells; ++c)
  {
    if (materials[c] < 0 || materials[c] >= numberOfMaterials)
    {
      return Status::Invalid("a cell's material index is out of range");
    }
  }
  std::vector<double> angles(static_cast<std::size_t>(numberOfCells * (Dim + 1)));
  struct AngleKernel
  {
    using Scratch = NoScratch;
    const double* Points;
    const IdType* Connectivity;
    double* Angles;
    std::atomic<bool>* NotFinite;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t cell = begin; cell < end; ++cell)
      {
        const double* corners[Dim + 1];
        for (int k = 0; k <= Dim; ++k)
        {
          corners[k] =
            this->Points + 3 * static_cast<std::int64_t>(this->Connectivity[cell * (Dim + 1) + k]);
        }
        for (int k = 0; k <= Dim; ++k)
        {
          const double angle = CornerAngle<Dim>(corners, k);
          this->Angles[cell * (Dim + 1) + k] = angle;
          if (!std::isfinite(angle))
          {
            this->NotFinite->store(true, std::memory_order_relaxed);
          }
        }
      }
    }
  };
  std::atomic<bool> notFinite{ false };
  AngleKernel angleKernel{ points, connectivity, angles.data(), &notFinite };
  executor.For(0, numberOfCells, 1 << 14, angleKernel);
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }
  if (notFinite)
  {
    return Status::Invalid("a point's coordinates are not finite (NaN or infinite)");
  }
  executor.ReportProgress(0.3);
  PointCells<Dim> incidence;
  incidence.Build(connectivity, numberOfCells, numberOfPoints, executor);
  executor.ReportProgress(0.5);

  // Each point's (material, angle) sums, counted then written, in parallel over points.
  std::vector<std::int64_t> counts(static_cast<std::size_t>(numberOfPoints) + 1, 0);
  struct GatherKernel
  {
    struct Scratch
    {
      std::vector<std::pair<std::int32_t, double>> Sums;
    };
    const PointCells<Dim>* Incidence;
    const IdType* Connectivity;
    const std::int32_t* Materials;
    const double* Angles;
    std::int32_t Outside;
    std::int64_t* Counts;
    MaterialFractions* Out; // null in the counting pass
    void operator()(Scratch& scratch, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t point = begin; point < end; ++point)
      {
        auto& sums = scratch.Sums;
        sums.clear();
        double total = 0.0;
        for (std::int64_t i = this->Incidence->Offsets[point];
             i < this->Incidence->Offsets[point + 1]; ++i)
        {
          const std::int64_t cell = this->Incidence->Cells[i];
          int corner = 0;
          while (static_cast<std::int64_t>(this->Connectivity[cell * (Dim + 1) + corner]) != point)
          {
            ++corner;
          }
          const double angle = this->Angles[cell * (Dim + 1) + corner];
          total += angle;
          auto found = std::find_if(sums.begin(), sums.end(),
            [&](const std::pair<std::int32_t, double>& s)
            { return s.first == this->Materials[cell]; });
          if (found == sums.end())
          {
            sums.emplace_back(this->Materials[cell], angle);
          }
          else
          {
            found->second += angle;
          }
        }
        // Rounding leaves a few ulps of the full angle uncovered at interior points.
        constexpr double full = FullAngle<Dim>();
        if (this->Outside >= 0 && !sums.empty() && full - total > 1e-9 * full)
        {
          auto found = std::find_if(sums.begin(), sums.end(),
            [&](const std::pair<std::int32_t, double>& s) { return s.first == this->Outside; });
          if (found == sums.end())
          {
            sums.emplace_back(this->Outside, 0.0);
            found = sums.end() - 1;
          }
          found->second += full - total;
          total = full;
        }
        if (!this->Out)
        {
          this->Counts[point + 1] = static_cast<std::int64_t>(sums.size());
          continue;
        }
        std::sort(sums.begin(), sums.end());
        std::int64_t next = this->Out->Begins[point];
        for (const auto& sum : sums)
        {
          this->Out->Materials[next] = sum.first;
          this->Out->Values[next++] = total > 0.0 ? sum.second / total : 0.0;
        }
      }
    }
  };
  GatherKernel countKernel{ &incidence, connectivity, materials, angles.data(), outsideMaterial,
    counts.data(), nullptr };
  executor.For(0, numberOfPoints, 1 << 12, countKernel);
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }
  for (std::int64_t p = 0; p < numberOfPoints; ++p)
  {
    counts[p + 1] += counts[p];
  }
  executor.ReportProgress(0.7);
  fractions.Begins.assign(counts.begin(), counts.end() - 1);
  fractions.Ends.assign(counts.begin() + 1, counts.end());
  fractions.Materials.assign(static_cast<std::size_t>(counts.back()), 0);
  fractions.Values.assign(static_cast<std::size_t>(counts.back()), 0.0);
  GatherKernel writeKernel{ &incidence, connectivity, materials, angles.data(), outsideMaterial,
    nullptr, &fractions };
  executor.For(0, numberOfPoints, 1 << 12, writeKernel);
  executor.ReportProgress(1.0);
  return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
}

struct MultiMaterialCutOptions
{
  /// g_k within this of 0 is a tie (a zero vertex of step k).
  double ZeroTolerance = 1e-9;
  /// Before each step's cut, snap the points next to its interface onto it (VertexSnap, with
  /// Snap's rule and Alpha; needs the points' coordinates). Only points whose cells are all
  /// still unassigned move, so earlier interfaces keep their place.
  bool SnapVertices = false;
  VertexSnapOptions Snap = QualityDrivenSnap();
  /// Compute consecutive steps whose points are disjoint side by side (Run): the same result
  /// as one step at a time, which false gives (for comparison).
  bool StepsSideBySide = true;
  /// A piece of a distributed mesh: per input cell, nonzero for a ghost cell (one that another
  /// piece owns), and the exchanges with the other pieces. With both (and SnapVertices), the
  /// snaps decide the points of the piece's own cells as the whole mesh's cut does, one step at
  /// a time; every piece makes every step, with or without cells.
  const std::uint8_t* GhostCells = nullptr;
  StepSnapExchanges* Exchanges = nullptr;

  static VertexSnapOptions QualityDrivenSnap()
  {
    VertexSnapOptions snap;
    snap.Rule = SnapRule::QualityDriven;
    return snap;
  }
};

/// The volume (area in 2D) of the simplices of each material index (0 to K - 1), leaving out the
/// cells with skipped[c] != 0 (when given: a piece's ghost cells). Exact sums: the pieces of a
/// mesh add up to the whole mesh's volumes exactly (by their parts).
template <int Dim, class IdType, class MaterialType>
std::vector<ExactSum> VolumePerMaterial(const double* points, const IdType* connectivity,
  std::int64_t numberOfCells, const MaterialType* materials, int numberOfMaterials,
  const std::uint8_t* skipped = nullptr)
{
  std::vector<ExactSum> volumes(static_cast<std::size_t>(numberOfMaterials));
  double factorial = 1.0;
  for (int k = 2; k <= Dim; ++k)
  {
    factorial *= k;
  }
  for (std::int64_t c = 0; c < numberOfCells; ++c)
  {
    if (skipped && skipped[c])
    {
      continue;
    }
    const IdType* ids = connectivity + c * (Dim + 1);
    double edges[Dim][Dim];
    for (int col = 0; col < Dim; ++col)
    {
      for (int r = 0; r < Dim; ++r)
      {
        edges[r][col] = points[static_cast<std::int64_t>(ids[col + 1]) * Dim + r] -
          points[static_cast<std::int64_t>(ids[0]) * Dim + r];
      }
    }
    volumes[static_cast<std::size_t>(materials[c])].Add(
      std::abs(Determinant<Dim>(edges)) / factorial);
  }
  return volumes;
}

/// Counts of one run.
struct MultiMaterialCutCounts
{
  std::int64_t Steps = 0;              // steps that visited at least one cell
  std::int64_t VisitedCells = 0;       // cell visits over all steps
  std::int64_t SplitCells = 0;         // cells split, over all steps
  std::int64_t SplitAssignedCells = 0; // of those, cells already assigned (triple lines)
  std::int64_t AddedPoints = 0;
  std::int64_t SnappedPoints = 0;   // snaps, summed over the steps
  std::int64_t SideBySideSteps = 0; // steps computed beside others of their batch (Run)
};

/// Cuts a simplicial mesh (Dim + 1 point ids per cell) into the regions of K materials.
/// Usage: Run, then read the points' parents, the cells, their materials and parents.
template <int Dim>
class MultiMaterialCut
{
public:
  using Cut = MarchingSimplices<Dim>;
  static constexpr std::int32_t Remaining = -1;

  /// materials: per input cell, its material index in [0, K) (ties follow it); fractions: per
  /// input point (see CornerFractions); points: Dim coordinates per input point, or null (then
  /// no snapping, and GetPoints is empty). The peeling order is the index order.
  template <class IdType, class Executor>
  Status Run(std::int64_t numberOfPoints, const double* points, const IdType* connectivity,
    std::int64_t numberOfCells, const std::int32_t* materials, int numberOfMaterials,
    MaterialFractions fractions, const MultiMaterialCutOptions& options, Executor& executor);

  std::int64_t GetNumberOfInputPoints() const { return this->NumberOfInputPoints; }
  std::int64_t GetNumberOfPoints() const { return this->Fractions.GetNumberOfPoints(); }
  /// The edge each added point lies on, in point order: ids A and B (both smaller than the
  /// point's own id, so points can be placed in order), the point at (1 - T) x_A + T x_B
  /// (with the places x_A, x_B had when it was cut; snapping may move a point later).
  const std::vector<CutEdge>& GetAddedPoints() const { return this->AddedPoints; }
  /// Dim coordinates per output point, snapped points moved (empty without input points).
  const std::vector<double>& GetPoints() const { return this->Points; }
  std::int64_t GetNumberOfCells() const
  {
    return static_cast<std::int64_t>(this->CellMaterials.size());
  }
  const std::vector<std::int64_t>& GetCells() const { return this->Cells; }
  /// Moves the cells out (GetCells is empty after; GetNumberOfCells stays), so that a caller
  /// that copies them into its own arrays can free them at once.
  std::vector<std::int64_t> TakeCells() { return std::move(this->Cells); }
  /// Per output cell: its material index, and the input cell it lies in.
  const std::vector<std::int32_t>& GetCellMaterials() const { return this->CellMaterials; }
  const std::vector<std::int64_t>& GetCellParents() const { return this->CellParents; }
  /// The fractions of every output point (input points first).
  const MaterialFractions& GetFractions() const { return this->Fractions; }
  const MultiMaterialCutCounts& GetCounts() const { return this->Counts; }

private:
  /// Forwards For and ShouldAbort; the steps report their own progress.
  template <class Executor>
  struct QuietExecutor
  {
    Executor* Outer;
    template <class Kernel>
    void For(std::int64_t begin, std::int64_t end, std::int64_t grain, Kernel& kernel)
    {
      this->Outer->For(begin, end, grain, kernel);
    }
    bool ShouldAbort() { return this->Outer->ShouldAbort(); }
    void ReportProgress(double) {}
  };

  double StepValue(std::int64_t point, std::int32_t step) const
  {
    if (this->RemainingIncidence[point] == 0)
    {
      return 0.0;
    }
    double own = 0.0, others = 0.0;
    for (std::int64_t e = this->Fractions.Begins[point]; e < this->Fractions.Ends[point]; ++e)
    {
      const std::int32_t material = this->Fractions.Materials[e];
      if (material == step)
      {
        own = this->Fractions.Values[e];
      }
      else if (material > step)
      {
        others = std::max(others, this->Fractions.Values[e]);
      }
    }
    return others - own;
  }

  /// The materials with a step after `step` carried by the points of a cell, each once,
  /// ascending (the last material has no step).
  void LaterMaterials(
    const std::int64_t* ids, std::int32_t step, std::vector<std::int32_t>& out) const
  {
    out.clear();
    for (int v = 0; v <= Dim; ++v)
    {
      for (std::int64_t e = this->Fractions.Begins[ids[v]]; e < this->Fractions.Ends[ids[v]]; ++e)
      {
        if (this->Fractions.Materials[e] > step &&
          this->Fractions.Materials[e] + 1 < this->NumberOfMaterials)
        {
          out.push_back(this->Fractions.Materials[e]);
        }
      }
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  }

  /// Room for `extra` more values, growing by a quarter at least (not the doubling of
  /// push_back): the cell arrays are the largest of the cut.
  template <class Value>
  static void GrowCapacity(std::vector<Value>& values, std::int64_t extra)
  {
    const std::size_t needed = values.size() + static_cast<std::size_t>(extra);
    if (needed > values.capacity())
    {
      values.reserve(std::max(needed, values.capacity() + values.capacity() / 4));
    }
  }

  static void AdjustIncidence(
    std::vector<std::int32_t>& incidence, const std::int64_t* ids, int change)
  {
    for (int v = 0; v <= Dim; ++v)
    {
      incidence[ids[v]] += change;
    }
  }

  /// What one step computes before it changes anything shared (see Run): its cells and their
  /// points in a local numbering, the snapped points and the cut, in local ids.
  struct StepWork
  {
    std::int32_t Step = 0;
    std::vector<std::int64_t> Cells;       // the visited cells, ascending
    std::vector<std::int64_t> Points;      // local id -> point id, in order of first use
    std::vector<std::int64_t> Local;       // Cells in local ids
    std::vector<std::uint8_t> Moved;       // per local point: snapped (empty without snapping)
    std::vector<std::int64_t> MovedPoints; // local ids, ascending
    std::vector<double> MovedPlaces;       // Dim per moved point
    MaterialFractions MovedFractions;      // a row per moved point
    std::int64_t Snapped = 0;
    std::vector<CutEdge> CutEdges; // ends in local ids
    std::vector<std::int64_t> PieceIds, Parents;
    std::vector<std::uint8_t> Sides;
    std::vector<std::int64_t> TouchedCells; // positions in Cells with a moved corner, ascending
    Status Result;
  };

  /// The steps from `first` on, in order, that may run side by side (Run's comment).
  std::vector<std::int32_t> Batch(std::int32_t first);

  /// Computes a step from the shared state, which it only reads but for its own cells and points
  /// (LocalIds as scratch; the unsplit cells it assigns and their points' remaining counts):
  /// the steps of a batch share neither.
  template <class Executor>
  Status ComputeStep(StepWork& work, Executor& executor);

  /// Snaps the step's points (local numbering) in `work`; movable: free points carrying the
  /// step's material. Gives the moved points' places and fractions.
  template <class Executor>
  Status SnapStep(StepWork& work, std::vector<double>& values, Executor& executor);

  /// Applies a computed step to the shared state: moved points, added points and pieces.
  void CommitStep(StepWork& work);

  /// Run's work, without the pieces' closing agreement.
  template <class IdType, class Executor>
  Status RunSteps(std::int64_t numberOfPoints, const double* points, const IdType* connectivity,
    std::int64_t numberOfCells, const std::int32_t* materials, int numberOfMaterials,
    MaterialFractions fractions, const MultiMaterialCutOptions& options, Executor& executor);

  /// The other end of the edge along which another piece snapped each of `moved` (local ids, of
  /// a step's points): the neighbour in the direction the point moved, from its place before
  /// the step (Points) to `after` (Dim coordinates per local point); -1 for a point that did
  /// not move.
  std::vector<std::int64_t> SnapPartners(
    const StepWork& work, const std::vector<std::int64_t>& moved, const double* after) const;

  std::int64_t NumberOfInputPoints = 0;
  std::int32_t NumberOfMaterials = 0;
  const std::int32_t* InputMaterials = nullptr; // during Run
  double Tolerance = 0.0;
  MaterialFractions Fractions;
  std::vector<CutEdge> AddedPoints;
  std::vector<std::int64_t> Cells;
  std::vector<std::int32_t> CellMaterials;
  std::vector<std::int64_t> CellParents;
  std::vector<std::int32_t> RemainingIncidence; // per point: remaining cells that use it
  std::vector<double> Points;                   // Dim per point, or empty
  bool SnapVertices = false;
  VertexSnapOptions SnapOptions;
  std::vector<std::vector<std::int64_t>> Visits; // per material index: the cells of its step
  std::vector<std::int64_t> LocalIds;            // per point: id in its step, or -1
  std::vector<std::int32_t> Claims;              // per point: Batch's scratch
  std::int32_t ClaimRound = 0;
  StepSnapExchanges* Exchanges = nullptr; // during Run, for a piece that exchanges
  const std::uint8_t* GhostCells = nullptr;
  std::vector<std::uint8_t> ExchangedSteps; // per material: its step's snap exchanges
  bool StoppedTogether = false;             // a snap stopped every piece at once

  MultiMaterialCutCounts Counts;

  /// Rings of input cells on either side of a piece's border within which a step's material
  /// makes its snap exchange (BorderMaterials).
  static constexpr int BorderRings = 4;
  /// Per material, 1 where it is carried by a point of a cell within BorderRings rings of the
  /// border between the piece's own cells and its ghost cells.
  template <class Executor>
  std::vector<std::uint8_t> BorderMaterials(Executor& executor) const;
  /// The status of a piece that another stopped, from the pieces' agreement (1: aborted,
  /// 2: failed).
  static Status StoppedByAnother(double stopped)
  {
    return stopped > 1.0 ? Status::Invalid("another piece of the mesh could not be cut")
                         : Status::Aborted();
  }
};

template <int Dim>
template <class IdType, class Executor>
Status MultiMaterialCut<Dim>::Run(std::int64_t numberOfPoints, const double* points,
  const IdType* connectivity, std::int64_t numberOfCells, const std::int32_t* materials,
  int numberOfMaterials, MaterialFractions fractions, const MultiMaterialCutOptions& options,
  Executor& executor)
{
  this->Exchanges = options.SnapVertices && options.GhostCells ? options.Exchanges : nullptr;
  this->GhostCells = options.GhostCells;
  this->StoppedTogether = false;
  Status status = this->RunSteps(numberOfPoints, points, connectivity, numberOfCells, materials,
    numberOfMaterials, std::move(fractions), options, executor);
  // The pieces' last agreement: a piece that stopped outside a snap says so here, or at the
  // agreement before the rounds of the snap the others are in, so no piece waits for it.
  if (this->Exchanges && !this->StoppedTogether)
  {
    const bool aborted =
      status.GetCode() == Status::Code::Aborted || (status.IsOk() && executor.ShouldAbort());
    const double stopped = this->Exchanges->Maximum(aborted ? 1.0 : status.IsOk() ? 0.0 : 2.0);
    if (status.IsOk() && stopped > 0.0)
    {
      status = StoppedByAnother(stopped);
    }
  }
  this->Exchanges = nullptr;
  this->GhostCells = nullptr;
  return status;
}

template <int Dim>
template <class IdType, class Executor>
Status MultiMaterialCut<Dim>::RunSteps(std::int64_t numberOfPoints, const double* points,
  const IdType* connectivity, std::int64_t numberOfCells, const std::int32_t* materials,
  int numberOfMaterials, MaterialFractions fractions, const MultiMaterialCutOptions& options,
  Executor& executor)
{
  if (!(options.ZeroTolerance >= 0.0) || !std::isfinite(options.ZeroTolerance) ||
    options.ZeroTolerance >= 0.5)
  {
    return Status::Invalid("the zero tolerance must be in [0, 0.5)");
  }
  if (numberOfMaterials < 1)
  {
    return Status::Invalid("there must be at least one material");
  }
  bool rowsValid = fractions.GetNumberOfPoints() == numberOfPoints &&
    static_cast<std::int64_t>(fractions.Ends.size()) == numberOfPoints &&
    fractions.Materials.size() == fractions.Values.size();
  for (std::int64_t p = 0; p < numberOfPoints && rowsValid; ++p)
  {
    rowsValid = fractions.Begins[p] >= 0 && fractions.Begins[p] <= fractions.Ends[p] &&
      fractions.Ends[p] <= static_cast<std::int64_t>(fractions.Materials.size());
  }
  if (!rowsValid)
  {
    return Status::Invalid("the material fractions do not match the points");
  }
  if (options.SnapVertices && points == nullptr)
  {
    return Status::Invalid("snapping needs the points' coordinates");
  }
  if (points != nullptr)
  {
    for (std::int64_t i = 0; i < numberOfPoints * Dim; ++i)
    {
      if (!std::isfinite(points[i]))
      {
        return Status::Invalid("a point's coordinates are not finite (NaN or infinite)");
      }
    }
  }
  for (std::int64_t c = 0; c < numberOfCells; ++c)
  {
    if (materials[c] < 0 || materials[c] >= numberOfMaterials)
    {
      return Status::Invalid("a cell's material index is out of range");
    }
  }
  for (std::size_t e = 0; e < fractions.Materials.size(); ++e)
  {
    if (fractions.Materials[e] < 0 || fractions.Materials[e] >= numberOfMaterials ||
      !std::isfinite(fractions.Values[e]))
    {
      return Status::Invalid("a material fraction has a material index out of range or is not "
                             "finite");
    }
  }
  this->Tolerance = options.ZeroTolerance;
  this->SnapVertices = options.SnapVertices;
  this->SnapOptions = options.Snap;
  this->SnapOptions.IsoValue = 0.0;
  this->SnapOptions.ZeroTolerance = options.ZeroTolerance;
  if (points != nullptr)
  {
    this->Points.assign(points, points + numberOfPoints * Dim);
  }
  else
  {
    this->Points.clear();
  }
  this->NumberOfMaterials = numberOfMaterials;
  this->NumberOfInputPoints = numberOfPoints;
  this->InputMaterials = materials;
  this->Fractions = std::move(fractions);
  this->AddedPoints.clear();
  this->Counts = MultiMaterialCutCounts();
  // The pieces add about a tenth to the cells (AAL, 116 labels: 9 %): room for an eighth more
  // up front, and GrowCapacity after, instead of the doubling of push_back, which left the
  // cells' three arrays at twice their size at the peak of the cut (AAL: 560 MB of 1.43 GB).
  const auto roomyCells = static_cast<std::size_t>(numberOfCells + numberOfCells / 8);
  this->Cells.clear();
  this->Cells.reserve(roomyCells * (Dim + 1));
  this->Cells.resize(static_cast<std::size_t>(numberOfCells * (Dim + 1)));
  for (std::int64_t i = 0; i < numberOfCells * (Dim + 1); ++i)
  {
    if (connectivity[i] < 0 || connectivity[i] >= numberOfPoints)
    {
      return Status::Invalid("a cell refers to a point id outside the mesh");
    }
    this->Cells[i] = static_cast<std::int64_t>(connectivity[i]);
  }
  this->CellMaterials.clear();
  this->CellMaterials.reserve(roomyCells);
  this->CellMaterials.assign(static_cast<std::size_t>(numberOfCells), Remaining);
  this->CellParents.clear();
  this->CellParents.reserve(roomyCells);
  this->CellParents.resize(static_cast<std::size_t>(numberOfCells));
  this->RemainingIncidence.assign(static_cast<std::size_t>(numberOfPoints), 0);
  this->LocalIds.assign(static_cast<std::size_t>(numberOfPoints), -1);
  this->Visits.assign(static_cast<std::size_t>(numberOfMaterials), {});
  for (std::int64_t cell = 0; cell < numberOfCells; ++cell)
  {
    this->CellParents[cell] = cell;
    AdjustIncidence(this->RemainingIncidence, this->Cells.data() + cell * (Dim + 1), 1);
  }
  // Each cell visits the steps of the later materials its points carry: gathered over fixed
  // ranges of cells side by side and joined in range order, so every step's cells ascend
  // whatever the number of threads.
  {
    constexpr std::int64_t Ranges = 16;
    const std::int64_t rangeCells = (numberOfCells + Ranges - 1) / Ranges;
    std::vector<std::vector<std::vector<std::int64_t>>> rangeVisits(
      static_cast<std::size_t>(Ranges));
    struct VisitKernel
    {
      struct Scratch
      {
        std::vector<std::int32_t> Later;
      };
      const MultiMaterialCut* Self;
      std::int64_t NumberOfCells;
      std::int64_t RangeCells;
      std::vector<std::vector<std::int64_t>>* Lists;
      void operator()(Scratch& scratch, std::int64_t begin, std::int64_t end) const
      {
        for (std::int64_t r = begin; r < end; ++r)
        {
          std::vector<std::vector<std::int64_t>>& lists = this->Lists[r];
          lists.resize(static_cast<std::size_t>(this->Self->NumberOfMaterials));
          const std::int64_t last = std::min(this->NumberOfCells, (r + 1) * this->RangeCells);
          for (std::int64_t cell = r * this->RangeCells; cell < last; ++cell)
          {
            this->Self->LaterMaterials(
              this->Self->Cells.data() + cell * (Dim + 1), -1, scratch.Later);
            for (const std::int32_t material : scratch.Later)
            {
              lists[material].push_back(cell);
            }
          }
        }
      }
    };
    VisitKernel visits{ this, numberOfCells, rangeCells, rangeVisits.data() };
    executor.For(0, Ranges, 1, visits);
    for (std::int32_t material = 0; material < numberOfMaterials; ++material)
    {
      std::size_t size = 0;
      for (const auto& lists : rangeVisits)
      {
        size += lists.empty() ? 0 : lists[material].size();
      }
      this->Visits[material].reserve(size);
      for (auto& lists : rangeVisits)
      {
        if (!lists.empty())
        {
          this->Visits[material].insert(
            this->Visits[material].end(), lists[material].begin(), lists[material].end());
          std::vector<std::int64_t>().swap(lists[material]);
        }
      }
    }
  }
  // A piece of a distributed mesh: the pieces agree to start (one may have stopped before),
  // and which steps' snaps exchange. Only a step whose material lies near a piece's border can
  // make a decision that reads another piece's points, so the others run with no exchange and
  // no agreement: each piece goes its own way through them.
  this->ExchangedSteps.assign(static_cast<std::size_t>(numberOfMaterials), 0);
  if (this->Exchanges)
  {
    const double stopped = this->Exchanges->Maximum(executor.ShouldAbort() ? 1.0 : 0.0);
    if (stopped > 0.0)
    {
      this->StoppedTogether = true;
      return StoppedByAnother(stopped);
    }
    this->ExchangedSteps = this->BorderMaterials(executor);
    this->Exchanges->AnyPiece(this->ExchangedSteps);
  }
  // Batches of steps with disjoint points (Batch) run side by side: a step with more than two
  // thirds of a batch's cells runs first, alone, with the threads in its loops; the others run
  // one per thread (their loops then run on that thread). Each step is computed from the state
  // the earlier steps leave, and the steps are applied in order, so the result is that of the
  // steps one after the other, whatever the number of threads.
  std::vector<StepWork> works;
  for (std::int32_t first = 0; first + 1 < numberOfMaterials;)
  {
    if (executor.ShouldAbort())
    {
      return Status::Aborted();
    }
    // The pieces of a distributed mesh exchange inside the snaps of some steps, in step order.
    const std::vector<std::int32_t> batch = options.StepsSideBySide && !this->Exchanges
      ? this->Batch(first)
      : std::vector<std::int32_t>{ first };
    works.assign(batch.size(), StepWork());
    std::int64_t total = 0;
    for (std::size_t i = 0; i < batch.size(); ++i)
    {
      works[i].Step = batch[i];
      works[i].Cells.swap(this->Visits[batch[i]]);
      total += static_cast<std::int64_t>(works[i].Cells.size());
    }
    std::vector<std::size_t> beside;
    for (std::size_t i = 0; i < works.size(); ++i)
    {
      if (3 * static_cast<std::int64_t>(works[i].Cells.size()) > 2 * total)
      {
        works[i].Result = this->ComputeStep(works[i], executor);
      }
      else
      {
        beside.push_back(i);
      }
    }
    struct StepKernel
    {
      using Scratch = NoScratch;
      MultiMaterialCut* Self;
      std::vector<StepWork>* Works;
      const std::vector<std::size_t>* Beside;
      Executor* Exec;
      void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
      {
        for (std::int64_t i = begin; i < end; ++i)
        {
          StepWork& work = (*this->Works)[(*this->Beside)[i]];
          work.Result = this->Self->ComputeStep(work, *this->Exec);
        }
      }
    };
    this->Counts.SideBySideSteps +=
      beside.size() > 1 ? static_cast<std::int64_t>(beside.size()) : 0;
    StepKernel kernel{ this, &works, &beside, &executor };
    executor.For(0, static_cast<std::int64_t>(beside.size()), 1, kernel);
    if (executor.ShouldAbort())
    {
      return Status::Aborted();
    }
    for (StepWork& work : works)
    {
      if (!work.Result.IsOk())
      {
        return work.Result;
      }
      this->CommitStep(work);
      work = StepWork();
    }
    first = batch.back() + 1;
    executor.ReportProgress(static_cast<double>(first) / numberOfMaterials);
  }
  for (std::int32_t& material : this->CellMaterials)
  {
    material = material == Remaining ? numberOfMaterials - 1 : material;
  }
  std::vector<std::int32_t>().swap(this->RemainingIncidence);
  std::vector<std::int64_t>().swap(this->LocalIds);
  this->InputMaterials = nullptr;
  return executor.ShouldAbort() ? Status::Aborted() : Status::Ok();
}

template <int Dim>
std::vector<std::int32_t> MultiMaterialCut<Dim>::Batch(std::int32_t first)
{
  // The next step joins the batch when its points are none of the batch's: the points of a
  // step's cells are the points that carry its material, so such steps read and write disjoint
  // cells, points and fraction rows, and none adds cells to another's list (a piece or a
  // snapped point carries only materials of its parent cell's points). At most Window steps:
  // the test scans every cell of each.
  constexpr std::size_t Window = 8;
  if (++this->ClaimRound == std::numeric_limits<std::int32_t>::max())
  {
    std::fill(this->Claims.begin(), this->Claims.end(), 0);
    this->ClaimRound = 1;
  }
  this->Claims.resize(static_cast<std::size_t>(this->GetNumberOfPoints()), 0);
  std::vector<std::int32_t> batch;
  for (std::int32_t step = first; step + 1 < this->NumberOfMaterials && batch.size() < Window;
       ++step)
  {
    for (const std::int64_t cell : this->Visits[step])
    {
      const std::int64_t* ids = this->Cells.data() + cell * (Dim + 1);
      for (int v = 0; v <= Dim; ++v)
      {
        if (this->Claims[ids[v]] == this->ClaimRound)
        {
          return batch;
        }
      }
    }
    for (const std::int64_t cell : this->Visits[step])
    {
      const std::int64_t* ids = this->Cells.data() + cell * (Dim + 1);
      for (int v = 0; v <= Dim; ++v)
      {
        this->Claims[ids[v]] = this->ClaimRound;
      }
    }
    batch.push_back(step);
  }
  return batch;
}

template <int Dim>
template <class Executor>
Status MultiMaterialCut<Dim>::ComputeStep(StepWork& work, Executor& executor)
{
  std::vector<std::int64_t>& cells = work.Cells;
  // Snapping adds cells that may be listed already.
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  if (cells.empty())
  {
    // A piece without cells of the step still takes part in its snap's exchanges.
    std::vector<double> none;
    return this->Exchanges && this->ExchangedSteps[work.Step] ? this->SnapStep(work, none, executor)
                                                              : Status::Ok();
  }
  const std::int32_t step = work.Step;
  const auto count = static_cast<std::int64_t>(cells.size());

  // The step's points, numbered in order of first use, and the cells in those numbers.
  std::vector<std::int64_t>& points = work.Points;
  std::vector<std::int64_t>& local = work.Local;
  local.resize(static_cast<std::size_t>(count * (Dim + 1)));
  for (std::int64_t c = 0; c < count; ++c)
  {
    const std::int64_t* ids = this->Cells.data() + cells[c] * (Dim + 1);
    for (int v = 0; v <= Dim; ++v)
    {
      std::int64_t& id = this->LocalIds[ids[v]];
      if (id < 0)
      {
        id = static_cast<std::int64_t>(points.size());
        points.push_back(ids[v]);
      }
      local[c * (Dim + 1) + v] = id;
    }
  }
  for (const std::int64_t point : points)
  {
    this->LocalIds[point] = -1;
  }
  std::vector<double> values(points.size());
  for (std::size_t p = 0; p < points.size(); ++p)
  {
    values[p] = this->StepValue(points[p], step);
  }
  // The fraction row of a local point once this step's snaps are applied.
  std::vector<std::int64_t> movedRows;
  if (this->SnapVertices)
  {
    const Status snapped = this->SnapStep(work, values, executor);
    if (!snapped.IsOk())
    {
      return snapped;
    }
    movedRows.assign(points.size(), -1);
    for (std::size_t i = 0; i < work.MovedPoints.size(); ++i)
    {
      movedRows[work.MovedPoints[i]] = static_cast<std::int64_t>(i);
    }
  }
  auto allZeroSide = [&](std::int64_t c)
  {
    const std::int32_t original = this->InputMaterials[this->CellParents[cells[c]]];
    if (original == step)
    {
      return CutSide::Inside;
    }
    for (int v = 0; v <= Dim && original < step; ++v)
    {
      const std::int64_t id = local[c * (Dim + 1) + v];
      const std::int64_t row = movedRows.empty() ? -1 : movedRows[id];
      const double fraction =
        row >= 0 ? work.MovedFractions.Of(row, step) : this->Fractions.Of(points[id], step);
      if (fraction > 0.0)
      {
        return CutSide::Inside;
      }
    }
    return CutSide::Outside;
  };
  MarchingSimplicesOptions cutOptions;
  cutOptions.ZeroTolerance = this->Tolerance;
  QuietExecutor<Executor> quiet{ &executor };
  Cut cut;
  Status status = cut.Classify(values.data(), static_cast<std::int64_t>(points.size()),
    local.data(), count, cutOptions, allZeroSide, quiet);
  if (!status.IsOk())
  {
    return status;
  }
  const std::int64_t pieces = cut.GetNumberOfCells();
  work.PieceIds.resize(static_cast<std::size_t>(pieces * (Dim + 1)));
  work.Parents.resize(static_cast<std::size_t>(pieces));
  work.Sides.resize(static_cast<std::size_t>(pieces));
  status = cut.WriteCells(
    local.data(), work.PieceIds.data(), work.Parents.data(), work.Sides.data(), quiet);
  work.CutEdges = cut.GetCutEdges();
  if (!status.IsOk())
  {
    return status;
  }
  // An unsplit cell is its own piece (MarchingSimplices copies its ids): only its material can
  // change, and it is changed here, beside the other steps of the batch, not in the serial
  // commit (AAL, 116 labels: 8.9 of 9.3 million visits; rewriting their ids and counts in the
  // commits took 0.55 s).
  for (std::int64_t piece = 0; piece < pieces; ++piece)
  {
    const std::int64_t parent = work.Parents[piece];
    const bool unsplit = (piece == 0 || work.Parents[piece - 1] != parent) &&
      (piece + 1 == pieces || work.Parents[piece + 1] != parent);
    const std::int64_t slot = cells[parent];
    if (unsplit && this->CellMaterials[slot] == Remaining &&
      static_cast<CutSide>(work.Sides[piece]) == CutSide::Inside)
    {
      this->CellMaterials[slot] = step;
      AdjustIncidence(this->RemainingIncidence, this->Cells.data() + slot * (Dim + 1), -1);
    }
  }
  // The cells around the snapped points, whose later materials the commit looks up again.
  for (std::int64_t c = 0; c < count && !work.MovedPoints.empty(); ++c)
  {
    bool touched = false;
    for (int v = 0; v <= Dim; ++v)
    {
      touched = touched || work.Moved[local[c * (Dim + 1) + v]] != 0;
    }
    if (touched)
    {
      work.TouchedCells.push_back(c);
    }
  }
  return status;
}

template <int Dim>
void MultiMaterialCut<Dim>::CommitStep(StepWork& work)
{
  const std::vector<std::int64_t>& cells = work.Cells;
  if (cells.empty())
  {
    return;
  }
  const std::int32_t step = work.Step;
  const std::vector<std::int64_t>& points = work.Points;
  ++this->Counts.Steps;
  this->Counts.VisitedCells += static_cast<std::int64_t>(cells.size());

  // The snapped points: their places and fractions (the cut points below interpolate them).
  this->Counts.SnappedPoints += work.Snapped;
  for (std::size_t i = 0; i < work.MovedPoints.size(); ++i)
  {
    const std::int64_t point = points[work.MovedPoints[i]];
    this->Fractions.ReplaceRow(point, work.MovedFractions, static_cast<std::int64_t>(i));
    std::copy(work.MovedPlaces.data() + i * Dim, work.MovedPlaces.data() + (i + 1) * Dim,
      this->Points.data() + point * Dim);
  }
  // A moved point may now carry materials its cells did not: they join those steps (which
  // drop repeated cells), so that every cell around a later cut edge is cut.
  std::vector<std::int32_t> later;
  for (const std::int64_t c : work.TouchedCells)
  {
    this->LaterMaterials(this->Cells.data() + cells[c] * (Dim + 1), step, later);
    for (const std::int32_t material : later)
    {
      this->Visits[material].push_back(cells[c]);
    }
  }

  // The cut points: appended with interpolated fractions.
  const std::int64_t firstAdded = this->GetNumberOfPoints();
  for (const CutEdge& edge : work.CutEdges)
  {
    const std::int64_t a = points[edge.A], b = points[edge.B];
    this->Fractions.AppendInterpolated(this->Fractions, a, b, edge.T);
    this->AddedPoints.push_back(CutEdge{ a, b, edge.T });
  }
  const auto added = static_cast<std::int64_t>(work.CutEdges.size());
  this->Counts.AddedPoints += added;
  if (!this->Points.empty())
  {
    this->Points.resize(static_cast<std::size_t>((firstAdded + added) * Dim));
    for (std::int64_t e = 0; e < added; ++e)
    {
      const CutEdge& edge = this->AddedPoints[firstAdded - this->NumberOfInputPoints + e];
      for (int c = 0; c < Dim; ++c)
      {
        this->Points[(firstAdded + e) * Dim + c] =
          (1.0 - edge.T) * this->Points[edge.A * Dim + c] + edge.T * this->Points[edge.B * Dim + c];
      }
    }
  }
  this->RemainingIncidence.resize(static_cast<std::size_t>(firstAdded + added), 0);
  this->LocalIds.resize(static_cast<std::size_t>(firstAdded + added), -1);
  auto global = [&](std::int64_t id)
  {
    return id < static_cast<std::int64_t>(points.size())
      ? points[id]
      : firstAdded + id - static_cast<std::int64_t>(points.size());
  };

  // Each parent's first piece takes its slot, the others are appended and visited by the later
  // steps of the materials its parent carries.
  const auto pieces = static_cast<std::int64_t>(work.Parents.size());
  const std::vector<std::int64_t>& parents = work.Parents;
  std::int64_t appended = 0;
  for (std::int64_t piece = 1; piece < pieces; ++piece)
  {
    appended += parents[piece] == parents[piece - 1] ? 1 : 0;
  }
  GrowCapacity(this->Cells, appended * (Dim + 1));
  GrowCapacity(this->CellMaterials, appended);
  GrowCapacity(this->CellParents, appended);
  std::int64_t ids[Dim + 1];
  for (std::int64_t first = 0; first < pieces;)
  {
    std::int64_t last = first + 1;
    while (last < pieces && parents[last] == parents[first])
    {
      ++last;
    }
    const std::int64_t slot = cells[parents[first]];
    std::int64_t* slotIds = this->Cells.data() + slot * (Dim + 1);
    const std::int32_t before = this->CellMaterials[slot];
    if (last - first == 1)
    {
      first = last; // assigned by ComputeStep
      continue;
    }
    ++this->Counts.SplitCells;
    this->Counts.SplitAssignedCells += before == Remaining ? 0 : 1;
    this->LaterMaterials(slotIds, step, later);
    if (before == Remaining)
    {
      AdjustIncidence(this->RemainingIncidence, slotIds, -1);
    }
    const std::int64_t parent = this->CellParents[slot];
    for (std::int64_t piece = first; piece < last; ++piece)
    {
      for (int v = 0; v <= Dim; ++v)
      {
        ids[v] = global(work.PieceIds[piece * (Dim + 1) + v]);
      }
      const std::int32_t material = before != Remaining              ? before
        : static_cast<CutSide>(work.Sides[piece]) == CutSide::Inside ? step
                                                                     : Remaining;
      std::int64_t cell = slot;
      if (piece != first)
      {
        cell = this->GetNumberOfCells();
        this->Cells.insert(this->Cells.end(), ids, ids + Dim + 1);
        this->CellMaterials.push_back(material);
        this->CellParents.push_back(parent);
        for (const std::int32_t visitor : later)
        {
          this->Visits[visitor].push_back(cell);
        }
      }
      else
      {
        // slotIds may have moved with the appends of earlier parents; write through the index.
        std::copy(ids, ids + Dim + 1, this->Cells.data() + slot * (Dim + 1));
        this->CellMaterials[slot] = material;
      }
      if (material == Remaining)
      {
        AdjustIncidence(this->RemainingIncidence, this->Cells.data() + cell * (Dim + 1), 1);
      }
    }
    first = last;
  }
}

template <int Dim>
template <class Executor>
Status MultiMaterialCut<Dim>::SnapStep(
  StepWork& work, std::vector<double>& values, Executor& executor)
{
  const std::int32_t step = work.Step;
  const std::vector<std::int64_t>& points = work.Points;
  const auto count = static_cast<std::int64_t>(points.size());
  std::vector<double> coordinates(static_cast<std::size_t>(count * Dim));
  std::vector<std::uint8_t> movable(static_cast<std::size_t>(count), 0);
  for (std::int64_t p = 0; p < count; ++p)
  {
    const std::int64_t point = points[p];
    std::copy(this->Points.data() + point * Dim, this->Points.data() + (point + 1) * Dim,
      coordinates.data() + p * Dim);
    // Carrying the step's material, so that every cell around it is one of the step's.
    movable[p] = this->Fractions.Of(point, step) > 0.0 ? 1 : 0;
  }
  const std::vector<double> before = values;
  VertexSnapOptions options = this->SnapOptions;
  options.Movable = movable.data();
  const auto numberOfCells = static_cast<std::int64_t>(work.Local.size()) / (Dim + 1);
  // A piece's own points: those on its own cells among the step's (each lies on some piece's).
  std::vector<std::uint8_t> own;
  const bool exchanged = this->Exchanges && this->ExchangedSteps[step];
  if (exchanged)
  {
    own.assign(static_cast<std::size_t>(count), 0);
    for (std::int64_t c = 0; c < numberOfCells; ++c)
    {
      for (int v = 0; v <= Dim && !this->GhostCells[this->CellParents[work.Cells[c]]]; ++v)
      {
        own[work.Local[c * (Dim + 1) + v]] = 1;
      }
    }
    options.Exchange = &this->Exchanges->ForStep(coordinates.data(), own.data(), count);
  }
  QuietExecutor<Executor> quiet{ &executor };
  VertexSnap<Dim> snap;
  const Status status = snap.Snap(
    coordinates.data(), values.data(), count, work.Local.data(), numberOfCells, options, quiet);
  if (!status.IsOk())
  {
    // An exchanging snap stops every piece at the same agreement.
    this->StoppedTogether = snap.GetStopsAgreed();
    return status;
  }
  work.Snapped = snap.GetCounts().Snapped;
  // A moved point takes the fractions of the place it moved to on its edge, from the rows as
  // they were before any of this step's moves.
  work.Moved = snap.GetMovedFlags();
  std::vector<std::int64_t> edges = snap.GetSnapEdges();
  if (exchanged)
  {
    // Which edge another piece snapped along is not sent: the direction of the move tells.
    std::vector<std::int64_t> received;
    for (std::int64_t p = 0; p < count; ++p)
    {
      if (work.Moved[p] && edges[p] < 0)
      {
        received.push_back(p);
      }
    }
    const std::vector<std::int64_t> partners =
      this->SnapPartners(work, received, coordinates.data());
    for (std::size_t i = 0; i < received.size(); ++i)
    {
      edges[received[i]] = partners[i];
    }
  }
  for (std::int64_t p = 0; p < count; ++p)
  {
    if (!work.Moved[p])
    {
      continue;
    }
    const std::int64_t w = edges[p] >= 0 ? edges[p] : p;
    const double other = work.Moved[w] ? before[w] : values[w];
    const double t = w == p ? 0.0 : std::min(1.0, std::max(0.0, before[p] / (before[p] - other)));
    work.MovedFractions.AppendInterpolated(this->Fractions, points[p], points[w], t);
    work.MovedPoints.push_back(p);
    work.MovedPlaces.insert(
      work.MovedPlaces.end(), coordinates.data() + p * Dim, coordinates.data() + (p + 1) * Dim);
  }
  return Status::Ok();
}

template <int Dim>
template <class Executor>
std::vector<std::uint8_t> MultiMaterialCut<Dim>::BorderMaterials(Executor& executor) const
{
  // A decision for an own point reads three rings of cells (VertexSnap), and a point whose
  // state changes is the end of a cut edge, so it or its neighbour carries the material. The
  // cut only splits cells and moves points within their cells' stars, so rings of input cells
  // bound those of the cut's cells, and a piece's rings on the ghost side, or-ed over the
  // pieces, are the other pieces' on the own side.
  const auto numberOfCells = static_cast<std::int64_t>(this->CellParents.size());
  const std::int64_t numberOfPoints = this->GetNumberOfPoints();
  std::vector<std::uint8_t> own(static_cast<std::size_t>(numberOfCells));
  for (std::int64_t c = 0; c < numberOfCells; ++c)
  {
    own[c] = this->GhostCells[c] ? 0 : 1;
  }
  // The ghost cells by their rings from the own cells, and the own cells by theirs from the
  // ghost cells.
  const std::vector<std::uint8_t> ghostSide = GhostRings(this->Cells.data(), Dim + 1, numberOfCells,
    numberOfPoints, this->GhostCells, BorderRings, executor);
  const std::vector<std::uint8_t> ownSide = GhostRings(
    this->Cells.data(), Dim + 1, numberOfCells, numberOfPoints, own.data(), BorderRings, executor);
  std::vector<std::uint8_t> reached(static_cast<std::size_t>(numberOfPoints), 0);
  for (std::int64_t c = 0; c < numberOfCells; ++c)
  {
    const std::uint8_t ring = this->GhostCells[c] ? ghostSide[c] : ownSide[c];
    for (int v = 0; v <= Dim && ring >= 1 && ring <= BorderRings; ++v)
    {
      reached[this->Cells[c * (Dim + 1) + v]] = 1;
    }
  }
  std::vector<std::uint8_t> materials(static_cast<std::size_t>(this->NumberOfMaterials), 0);
  for (std::int64_t p = 0; p < numberOfPoints; ++p)
  {
    for (std::int64_t e = this->Fractions.Begins[p]; e < this->Fractions.Ends[p] && reached[p]; ++e)
    {
      materials[this->Fractions.Materials[e]] |= this->Fractions.Values[e] > 0.0 ? 1 : 0;
    }
  }
  return materials;
}

template <int Dim>
std::vector<std::int64_t> MultiMaterialCut<Dim>::SnapPartners(
  const StepWork& work, const std::vector<std::int64_t>& moved, const double* after) const
{
  std::vector<std::int64_t> partners(moved.size(), -1);
  if (moved.empty())
  {
    return partners;
  }
  std::vector<std::int64_t> slot(work.Points.size(), -1);
  for (std::size_t i = 0; i < moved.size(); ++i)
  {
    slot[moved[i]] = static_cast<std::int64_t>(i);
  }
  // The edge a point moved along points where it moved to: of its neighbours, the one with the
  // largest cosine between the two directions (1 but for rounding; other edges are well apart).
  std::vector<double> best(moved.size(), -2.0);
  const auto numberOfCells = static_cast<std::int64_t>(work.Local.size()) / (Dim + 1);
  for (std::int64_t c = 0; c < numberOfCells; ++c)
  {
    const std::int64_t* ids = work.Local.data() + c * (Dim + 1);
    for (int v = 0; v <= Dim; ++v)
    {
      const std::int64_t i = slot[ids[v]];
      if (i < 0)
      {
        continue;
      }
      const double* from = this->Points.data() + work.Points[ids[v]] * Dim;
      double step[Dim], stepLength = 0.0;
      for (int k = 0; k < Dim; ++k)
      {
        step[k] = after[ids[v] * Dim + k] - from[k];
        stepLength += step[k] * step[k];
      }
      for (int w = 0; w <= Dim; ++w)
      {
        const double* to = this->Points.data() + work.Points[ids[w]] * Dim;
        double dot = 0.0, edgeLength = 0.0;
        for (int k = 0; k < Dim; ++k)
        {
          dot += step[k] * (to[k] - from[k]);
          edgeLength += (to[k] - from[k]) * (to[k] - from[k]);
        }
        const double cosine = w == v ? -2.0 : dot / std::sqrt(stepLength * edgeLength);
        if (cosine > best[i])
        {
          best[i] = cosine;
          partners[i] = ids[w];
        }
      }
    }
  }
  return partners;
}

} // namespace stm

#endif
