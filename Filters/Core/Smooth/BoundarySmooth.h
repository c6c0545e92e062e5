// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreBoundarySmooth_h
#define stmCoreBoundarySmooth_h

// Smoothing of the boundary and the material interfaces of a simplicial mesh (paper, section
// 3.4), followed by volumetric Laplacian smoothing of a few layers of interior points next to
// them (section 4, end), with every move validated against inversion and element quality.
//
// Decisions where the paper is silent:
// - Surface facets are facets shared by two cells of different material, plus outer-boundary
//   facets (in one cell only) whose cell is not BackgroundMaterial. The outer-boundary facets of
//   background cells are the box of background that the tessellation adds around the body:
//   their points are fixed, bit for bit. A point that is both on the surface and fixed is fixed.
//   Surface neighbours of a surface point are the points joined to it by edges of surface facets
//   (polylines in 2D, triangles in 3D); in 1D facets are points and have no edges, so surface
//   points never move there and only interior layers are smoothed.
// - Junctions (issue 7: several materials): each surface facet carries its material pair (the
//   outer boundary counting as a material). Where surface facets of two or more pairs share a
//   face of dimension Dim - 2 the surface has a junction: in 3D the edges of the lines where
//   three or more materials meet (or an interface meets the outer boundary). A point on exactly
//   two junction edges moves only along its line: its surface neighbours become its two line
//   neighbours, so a straight line stays straight bit for bit. A point on one or three or more
//   (a line's end, a quadruple point) is fixed, and so is every junction point in 2D (a triple
//   point) and 4D (its junction surfaces are not smoothed). With one material pair, as the
//   two-material pipeline's cut, nothing changes. Non-manifold points of one interface (two
//   cubes of one material touching along an edge) are not junctions.
// - Methods (uniform weights): Laplacian x += lambda (c - x), c the centroid of the surface
//   neighbours, which shrinks a closed surface; Taubin (the default) a lambda step then a mu
//   step per iteration with 1 / mu = PassBand - 1 / lambda (mu < -lambda), which does not.
//   The two steps of a Taubin iteration are composed before the validation (the mu step
//   smooths the lambda targets) and the point moves once: validating each step on its own
//   lets a rejected shrink be followed by an accepted inflation or the reverse, and the
//   rejections, frequent next to the slivers of a cut, then drift the volume (20 iterations on
//   a labels-function ball of radius 6 voxels: +2.5% with separate steps, +1.2% composed;
//   scaling the mu step by the lambda step's accepted fraction instead gives -1.3% on the
//   analytic ball, against +0.3% composed).
// - Each step is Jacobi: targets are computed from the previous positions, in parallel. They
//   are applied in a deterministic parallel order: the movable points of a step, in blocks of
//   256 consecutive ids, and a greedy colouring of the blocks, computed once in block order,
//   gives blocks that share a cell different colours; colours are applied one after another,
//   the blocks of one colour in parallel and the points of a block one after the other. A
//   point's move only changes its incident cells, which no point of another block of its colour
//   touches, so the result does not depend on the number of threads. Blocks rather than single
//   points: a block's cells stay in cache while its points move, where each colour of single
//   points spans the whole mesh and fetches every cell from memory once per corner (AAL, 116
//   labels: the 20 iterations 22.5 s -> 16 s).
//   With CellRootColours (a mesh of a spacetree: each cell's root cell, coloured by its
//   indices modulo 3 per axis, stm::RootColouring) the blocks come from the root cells instead:
//   a point takes the smallest colour of its cells, which names one root cell whose closure
//   holds it, and a block is a set of points of one colour joined by shared cells. Two points of
//   one colour that share a cell lie in the same root cell (their root cells hold a common
//   cell's corners, so their indices differ by at most 2 per axis, and are equal modulo 3), so a
//   block never leaves its root cell, and the blocks, their colours and each block's order
//   (ascending ids) depend only on the root grid and the order of the ids, not on how the
//   mesh is numbered otherwise or cut into pieces: a piece that owns a root cell has every cell
//   around its points and moves them as the whole mesh does. 27 colours in 3D instead of about
//   13 cost nothing measurable (AAL, 116 labels, the smooth stage in six interleaved pairs).
// - A move is accepted iff every incident simplex keeps a strictly positive volume (the sign of
//   the input simplex), its worst condition number is at most max(old worst of the incident
//   simplices, min(MaxConditionNumber, worst of the input)) and its smallest dihedral angle at
//   least min(old smallest of the incident simplices, max(MinDihedralAngle, smallest of the
//   input)). Both bounds are at least as strict as the input's extremes and a move never makes
//   its neighbourhood worse than itself beyond them, so the global worst element never gets
//   worse. A rejected move is tried at half and a quarter of its length, else the point stays.
//   Cost (every point moves at every iteration, each move measures ~20-40 cells): the angles
//   are compared as cosines, so acos never runs per move; a cell that SimplexSlack shows
//   within both bounds (no roots or divisions for the test; most cells) skips the exact measure,
//   and is cached as (condition -slack, cosine -1): cached figures only enter the limits
//   through max(figure, bound), where any figure within the bounds gives the bound, so the
//   decisions are those of the exact figures. The slack is a distance that the moves of the
//   cell's corners may add up to before it must be tested again: a move shorter than the slack
//   of each of its cells needs no measure at all, only the subtraction (AAL, 116 labels: 79% of
//   the cells of a move; the 20 iterations 35 s -> 22.5 s, the same points bit for bit). The
//   slack's bounds take one corner's move at a time (since 2026-12-05: 39% fewer slacks
//   computed for the same moves; docs/performance.md, "Larger slacks").
// - MaxDisplacement > 0 clips the displacement from the original position to that length. The
//   projector, when given, moves each tentative surface position (e.g. onto f = 0) before the
//   validation; when it fails, that tentative position is rejected.
// - Interior layers: the NumberOfInteriorLayers rings (edge hops) of points next to the surface
//   that are neither surface nor fixed; after every InteriorRelaxationInterval-th surface
//   iteration and after the last, one volumetric Laplacian pass (lambda toward the centroid of
//   all edge neighbours) with the same validation, which restores the quality that surface
//   moves cost (the paper's experience). Not after every iteration: the Taubin steps move the
//   surface back and forth, and a pass that follows each of them costs more moves than the
//   surface gains (AAL, 116 labels, 20 iterations, intervals 1 to 5: worst condition 4.43,
//   4.44, 4.35, 4.34, 4.33 and smallest dihedral 14.65, 14.30, 14.62, 14.67, 14.30 degrees,
//   with 367,844, 299,671 (interval 3) and 290,462 (interval 5) rejected surface moves; the
//   smooth stage 15.7 s at interval 1, 11.5 s at 4).
// - Small parts (SmallPartPoints, issue 7: no component of the image may be lost). A part is a
//   set of interior-layer points joined by edges (so of one material); a part with at most
//   SmallPartPoints points and no deeper interior point next to it (a single voxel, a 2 x 2
//   block in 2D) is kept as the cut made it: its points and every corner of its cells stay,
//   except that the quality improvement may move the surface points among them (KeptSurface),
//   as it moves other surface points. So do the tips, interior-layer points with at most one
//   interior neighbour: the centre of a single voxel that touches a larger part of its material
//   along an edge, the tip of a spike.
//   Why: Taubin's steps and the interior relaxation shrink such a part and move its centre (by
//   0.1 to 0.2 voxel), and the volume restoration gives the volume back to the material, not to
//   the part, so the part left its voxel (Brodmann atlas, 41 labels: 9 of 197 components lost
//   after the smoothing, all single voxels; none with it). A held interior point's cells keep
//   their material and their orientation, so the part keeps covering it.
// - Volume restoration (issue 7), with target volumes (TargetVolumes, or the input volumes of
//   the cells per VolumeTargetMaterials): after the iterations, the surface points between
//   exactly two materials (the outside counting as one; junction points stay) move along the
//   gradient g of the first material's volume, by (lambda_a - lambda_b) g for the pair (a, b).
//   To first order that changes a's volume by the sum of (lambda_a - lambda_b) |g|^2 over its
//   interface points: a graph Laplacian in the lambdas of the materials with a target, the
//   background and the outside held at 0, which conjugate gradients solve for the volume
//   errors (the smallest displacement that corrects them to first order). The moves are
//   validated like smoothing moves, and rounds repeat until every material is within
//   VolumeTolerance of its target (at most NumberOfVolumeRounds). Why: the multi-material cut
//   gives a junction line to the material that holds half of its voxels, which costs small
//   labels up to 4% of their volume (docs/multi-material.md); restoring each label's voxel
//   volume spreads that over its whole interface (AAL: 5 of 114 labels over 2% -> none over
//   0.01%, two rounds).
// - Quality improvement (issue 7): after the iterations (and the restoration), up to
//   NumberOfImprovementSweeps sweeps move the smoothable points (surface and interior-layer points)
//   of the cells beyond the bounds (condition above MaxConditionNumber or dihedral angle below
//   MinDihedralAngle) to lower the worst "badness" of their incident cells, max(condition /
//   MaxConditionNumber, MinDihedralAngle / angle), under the same validation as a smoothing move. A
//   point moves only in the directions that keep the volume of every material around it, and the
//   body's on the outer boundary, to first order: the complement of the gradients of those volumes
//   at the point. So an interior-layer point moves freely, an interface point in its tangent plane,
//   a junction-line point along its line, and a quadruple point not at all; where the gradients
//   have lower rank than the materials require (a folded interface) the point does not move. The
//   search is a compass search over every combination of -1, 0 and 1 times those directions, from a
//   fifth of the point's longest edge down to 1/256 of its shortest, within 0.6 of the longest edge
//   per sweep (a needle's short edge must grow by more than its own length). The points of a sweep
//   move in the root blocks of CellRootColours (else coloured greedily in point order), so the
//   result depends neither on the number of threads nor, with root colours, on the numbering. The
//   slivers of a multi-material cut sit between junction lines where the smoothing's targets do not
//   help (AAL, 116 labels: worst condition number 10.7 -> 5.1, smallest dihedral angle 5.7 -> 11.5
//   degrees). With ImprovementMovesInterfaces, when those sweeps end with cells still beyond the
//   bounds, as many sweeps again let the interface points (between exactly two materials, the
//   outside counting as one) move in every direction, off their interface: a needle whose corners
//   are interface points over a short edge cannot widen within the tangent planes, and a move of a
//   point next to a bad cell changes the volumes by a negligible amount (AAL, 116 labels: worst
//   condition number 4.76 -> 4.43, smallest dihedral angle 13.7 -> 14.7 degrees; the largest
//   volume error stays below 0.005%). Junction-line points still move only along their lines
//   and quadruple points not at all.
//   Only in 2D and 3D: the bounds are those of triangles and tetrahedra, and the 4D measure is too
//   costly for a search.
// - SinglePrecision rounds every tentative position to float before validating it, so that a
//   float point array receives exactly the positions that were validated.

#include "Check/SimplexQuality.h"
#include "Common/CubeInfo.h"
#include "Common/Determinant.h"
#include "Common/ExactSum.h"
#include "Common/Execution.h"
#include "Common/PointCells.h"
#include "Common/Status.h"
#include "Common/UninitializedVector.h"
#include "Smooth/SmoothingExchange.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace stm
{

enum class SmoothingMethod
{
  Taubin = 0,
  Laplacian = 1
};

struct BoundarySmoothOptions
{
  SmoothingMethod Method = SmoothingMethod::Taubin;
  /// Surface iterations (a Taubin iteration is a lambda and a mu step), >= 0.
  int NumberOfIterations = 20;
  /// lambda, in (0, 1].
  double RelaxationFactor = 0.5;
  /// Taubin's pass band k, in (0, 1): 1 / mu = k - 1 / lambda.
  double PassBand = 0.1;
  /// Largest distance of a point from its original position; 0 = unlimited.
  double MaxDisplacement = 0.0;
  /// Rings of interior points next to the surface smoothed after each surface iteration, >= 0.
  int NumberOfInteriorLayers = 2;
  /// Surface iterations per relaxation of the interior layers, >= 1: after every k-th
  /// iteration and after the last (header comment).
  int InteriorRelaxationInterval = 4;
  /// Small parts (header comment): parts of a material whose interior has at most this many
  /// points, all in the interior layers, keep their points, and so do interior-layer points
  /// with at most one interior neighbour; >= 0, 0 turns both off.
  int SmallPartPoints = 8;
  /// Quality bounds of the move validation (see the header's comment), >= 1 and in [0, 180).
  double MaxConditionNumber = 3.5;
  double MinDihedralAngle = 15.0;
  /// Sweeps of the quality improvement after the iterations (header comment), >= 0.
  int NumberOfImprovementSweeps = 10;
  /// Whether further improvement sweeps may move interface points off their interface where
  /// cells stay beyond the bounds (header comment).
  bool ImprovementMovesInterfaces = true;
  /// Volume restoration (header comment), which needs materials: the target volume per
  /// material, or when that is empty, per cell the material whose target volume the cell's
  /// input volume counts toward (e.g. its material before a cut; nullptr: no restoration).
  std::map<std::int64_t, double> TargetVolumes;
  const std::int64_t* VolumeTargetMaterials = nullptr;
  /// Most rounds of the volume restoration, >= 0; it stops once every material is within
  /// VolumeTolerance (relative, >= 0) of its target.
  int NumberOfVolumeRounds = 10;
  double VolumeTolerance = 1e-4;
  /// Cells of this material on the outer boundary hold their boundary points fixed.
  std::int64_t BackgroundMaterial = 0;
  /// Rounds tentative positions to float before validation (for float point arrays).
  bool SinglePrecision = false;
  /// Per point, non-zero for a point that no step moves (nullptr: none), e.g. the points of a
  /// piece's ghost cells, so that adjacent pieces keep their shared points. Held points count
  /// as fixed and are their neighbours' fixed neighbours.
  const std::uint8_t* HeldPoints = nullptr;
  /// Per cell, non-zero for a copy of another piece's cell (a piece's ghost layer; nullptr:
  /// none). Its quality enters neither the bounds nor the reported extremes: the layer ends
  /// where the piece's image ends, and its far cells are cut there as at a false boundary. Its
  /// volume enters neither the volume restoration nor the reported volumes: a ghost cell's
  /// points are held, so it keeps its volume, and counted, it made the restoration's relative
  /// tolerance depend on how many ghost cells the piece carries.
  const std::uint8_t* GhostCells = nullptr;
  /// Per cell, the colour of the spacetree root cell it lies in (stm::RootColouring: less than
  /// 3^Dim; nullptr: blocks of consecutive ids), by which the moves are ordered alike in a whole
  /// mesh and in its pieces (header comment).
  const std::uint8_t* CellRootColours = nullptr;
  /// A piece of a distributed mesh (nullptr: none): the points another piece moves are
  /// HeldPoints, and the steps of the iterations move this piece's points as the whole mesh's
  /// are moved, given CellRootColours: the roles and the steps' targets and positions of the
  /// held points come from the pieces that move them, and the bounds from all pieces' cells
  /// (header comment). So are the small parts (their sizes and depths are summed over all
  /// pieces), the volume restoration's rounds (the volumes and the weights of its system are
  /// exact sums over all pieces) and the quality improvement's sweeps (their candidates move in
  /// root blocks, the sweeps end together). GhostPoints: per point, non-zero for a point of a
  /// ghost cell, by which the small parts find the points other pieces may have.
  SmoothingExchange* Exchange = nullptr;
  const std::uint8_t* GhostPoints = nullptr;
};

struct BoundarySmoothStats
{
  std::int64_t SurfacePoints = 0;
  std::int64_t FixedPoints = 0;
  std::int64_t InteriorLayerPoints = 0;
  /// The small parts SmallPartPoints kept, and the points it held (counted in FixedPoints, not
  /// in SurfacePoints or InteriorLayerPoints).
  std::int64_t SmallParts = 0;
  std::int64_t KeptPoints = 0;
  /// Laplacian passes over the interior layers (InteriorRelaxationInterval).
  int InteriorRelaxations = 0;
  /// Surface points on a junction line (3D), which move only along it, and junction points
  /// held fixed (quadruple points, line ends; in 2D and 4D every junction point).
  std::int64_t JunctionLinePoints = 0;
  std::int64_t JunctionCornerPoints = 0;
  int NumberOfColours = 0;
  /// Whether the blocks came from CellRootColours.
  bool RootCellBlocks = false;
  /// Points that a move changed (kept as a flag per point rather than by comparing with a copy
  /// of every point's start, 8 * Dim bytes per point at the smoother's peak).
  std::int64_t MovedPoints = 0;
  /// Moves accepted in full, accepted at half or a quarter, and rejected (the point stayed).
  std::int64_t AcceptedMoves = 0;
  std::int64_t ReducedMoves = 0;
  std::int64_t RejectedMoves = 0;
  /// Points the quality improvement moved (counted once per sweep).
  std::int64_t ImprovedPoints = 0;
  /// The volume restoration's targets, and the largest relative difference of a material's
  /// volume from its target before and after it (0 without targets).
  std::map<std::int64_t, double> TargetVolumes;
  double LargestVolumeErrorBefore = 0.0;
  double LargestVolumeErrorAfter = 0.0;
  double WorstConditionBefore = 0.0;
  double WorstConditionAfter = 0.0;
  double MinDihedralBefore = 180.0;
  double MinDihedralAfter = 180.0;
  /// Volume per cell material (without materials: all under BackgroundMaterial + 1).
  std::map<std::int64_t, double> VolumeBefore;
  std::map<std::int64_t, double> VolumeAfter;
};

/// The projector of a smoothing without one.
struct NoProjection
{
  bool operator()(std::int64_t, double*) const { return true; }
};

template <int Dim>
class BoundarySmoother
{
public:
  static_assert(Dim >= 1 && Dim <= 4, "boundary smoothing supports dimensions 1 to 4");

  enum PointRole : std::uint8_t
  {
    Other = 0,
    Surface = 1,
    InteriorLayer = 2,
    Fixed = 3,
    /// A surface point of a small part: only the quality improvement moves it.
    KeptSurface = 4
  };

  /// Smooths in place `points` (Dim doubles per point) of the mesh of `numberOfCells` simplices
  /// `connectivity` (Dim + 1 ids each) with per-cell `materials` (nullptr: all one material that
  /// is not the background). projector(pointId, double* x) may move a tentative surface position
  /// x and returns false to reject it. On failure the points may be partly smoothed.
  template <class IdType, class MaterialType, class Projector, class Executor>
  Status Smooth(double* points, std::int64_t numberOfPoints, const IdType* connectivity,
    std::int64_t numberOfCells, const MaterialType* materials, const BoundarySmoothOptions& options,
    Projector&& projector, Executor& executor);

  template <class IdType, class MaterialType, class Executor>
  Status Smooth(double* points, std::int64_t numberOfPoints, const IdType* connectivity,
    std::int64_t numberOfCells, const MaterialType* materials, const BoundarySmoothOptions& options,
    Executor& executor)
  {
    return this->Smooth(points, numberOfPoints, connectivity, numberOfCells, materials, options,
      NoProjection(), executor);
  }

  const BoundarySmoothStats& GetStats() const { return this->Stats; }
  /// PointRole of every point after Smooth.
  const std::vector<std::uint8_t>& GetPointRoles() const { return this->Roles; }

  /// mu of Taubin's method for lambda and the pass band k.
  static double TaubinMu(double lambda, double passBand) { return 1.0 / (passBand - 1.0 / lambda); }

private:
  /// Point ids in the neighbour rows: 32-bit (Smooth refuses 2^31 points or more), as the rows
  /// of the interior layers are one of the larger arrays at the smoother's peak.
  using NeighbourId = std::int32_t;

  /// A cell's quality as the move validation compares it: the cosine of the smallest dihedral
  /// angle rather than the angle, so that the hot loop never calls acos (the angle is monotone
  /// in the cosine, so "no smaller angle" is "no larger cosine"). A cached figure is only ever
  /// used through max(figure, bound), so a cell that SimplexSlack shows within the bounds is
  /// cached as (-slack, -1): any figures within the bounds, and how far its corners may still
  /// move in all before it must be measured again. One record, so one cache miss per cell.
  struct Shape
  {
    double Condition;
    double Cosine;
  };

  /// Per-thread buffers of the kernels.
  struct Scratch
  {
    std::vector<std::int64_t> Ids;
    std::vector<Shape> Shapes;
  };

  /// The root of `a`'s set in a union-find forest, halving the path on the way.
  static std::int64_t FindRoot(std::vector<std::int64_t>& parent, std::int64_t a)
  {
    while (parent[a] != a)
    {
      parent[a] = parent[parent[a]];
      a = parent[a];
    }
    return a;
  }
  /// Small parts, once the interior layers and their edge neighbours are known (header comment);
  /// tips: the interior-layer points with at most one interior neighbour.
  template <class IdType>
  void KeepSmallParts(const IdType* connectivity, const std::vector<std::uint8_t>& tips);
  /// With an exchange: each part's size and depth over all pieces (KeepSmallParts).
  template <class IdType, class Find>
  void JoinPartsOfPieces(const IdType* connectivity, Find& find, std::vector<std::int64_t>& size,
    std::vector<std::uint8_t>& deep) const;

  /// Junctions, after the surface neighbours are known: see the header comment.
  template <class IdType, class MaterialType, class Executor>
  void ConstrainJunctions(const IdType* connectivity, const MaterialType* materials,
    const std::vector<std::uint8_t>& surfaceMasks, Executor& executor);

  /// Sets sums[key] to the sum of value(c) over the cells c of that key but the skipped ones, and
  /// with an exchange over all pieces' cells: exact sums, rounded once, so the same whatever the
  /// order of the cells or their split into pieces. One map lookup per run of one key: runs are
  /// the rule, cells come leaf by leaf.
  template <class Key, class Value>
  static void SumPerKey(std::int64_t cells, Key&& key, Value&& value,
    std::map<std::int64_t, double>& sums, const std::uint8_t* skipped,
    SmoothingExchange* exchange = nullptr)
  {
    std::map<std::int64_t, ExactSum> exact;
    auto current = exact.end();
    for (std::int64_t c = 0; c < cells; ++c)
    {
      if (skipped && skipped[c])
      {
        continue;
      }
      const std::int64_t k = key(c);
      if (current == exact.end() || current->first != k)
      {
        current = exact.emplace(k, ExactSum()).first;
      }
      current->second.Add(value(c));
    }
    SumOverPieces(exact, exchange);
    sums.clear();
    for (const auto& entry : exact)
    {
      sums.emplace(entry.first, entry.second.Value());
    }
  }

  /// The exact sums per key of all pieces, in every piece (nothing to do without an exchange).
  template <class Key>
  static void SumOverPieces(std::map<Key, ExactSum>& sums, SmoothingExchange* exchange);

  /// Compressed rows from rows gathered per chunk of points: offsets holds each point's count
  /// at p + 1 and becomes the prefix sums; the chunks are joined in order and freed.
  static void JoinRows(std::vector<std::vector<NeighbourId>>& chunks,
    std::vector<std::int64_t>& offsets, std::vector<NeighbourId>& rows)
  {
    for (std::size_t p = 0; p + 1 < offsets.size(); ++p)
    {
      offsets[p + 1] += offsets[p];
    }
    rows.clear();
    rows.reserve(static_cast<std::size_t>(offsets.back()));
    for (std::vector<NeighbourId>& chunk : chunks)
    {
      rows.insert(rows.end(), chunk.begin(), chunk.end());
      std::vector<NeighbourId>().swap(chunk);
    }
  }

  /// Greedy colouring in the order of `items`: each gets the smallest colour that no item
  /// visited by forEachNeighbour(item, visit) has in `colours` (indexed by item, -1: none yet).
  /// Returns the items by colour; `colours` keeps the colours of `items`.
  template <class ForEachNeighbour>
  static std::vector<std::vector<std::int64_t>> GreedyColouring(
    const std::vector<std::int64_t>& items, std::vector<std::int32_t>& colours,
    ForEachNeighbour&& forEachNeighbour)
  {
    std::vector<std::vector<std::int64_t>> byColour;
    std::vector<char> used;
    for (const std::int64_t item : items)
    {
      used.assign(byColour.size() + 1, 0);
      forEachNeighbour(item,
        [&](std::int64_t other)
        {
          if (colours[other] >= 0)
          {
            used[colours[other]] = 1;
          }
        });
      const auto colour =
        static_cast<std::int32_t>(std::find(used.begin(), used.end(), 0) - used.begin());
      if (colour == static_cast<std::int32_t>(byColour.size()))
      {
        byColour.emplace_back();
      }
      colours[item] = colour;
      byColour[colour].push_back(item);
    }
    return byColour;
  }

  template <class IdType>
  void CellCorners(const IdType* ids, std::int64_t cell, std::int64_t movedPoint,
    const double* movedPosition, const double* (&corners)[Dim + 1]) const;

  /// The gradient of the cell's determinant (in CellCorners's orientation, so Dim! times its
  /// volume) with respect to its corner `point`: the determinant is affine in each corner.
  template <class IdType>
  void CornerGradient(
    const IdType* ids, std::int64_t cell, std::int64_t point, double (&gradient)[Dim]) const;

  template <class IdType>
  Shape MeasureCell(const IdType* ids, std::int64_t cell, std::int64_t movedPoint,
    const double* movedPosition, double* determinant) const;

  /// The points of a step in blocks of consecutive ids, the blocks coloured so that no two
  /// blocks of one colour share a cell. A colour's blocks move in parallel and each block's
  /// points one after the other: a block's cells stay in cache while its points move, where a
  /// colouring of single points spreads every colour over the whole mesh and fetches each cell
  /// from memory once per corner.
  struct PointBlocks
  {
    std::vector<std::int64_t> Points;                // ascending
    std::vector<std::int64_t> Offsets;               // block b: Points[Offsets[b], Offsets[b + 1])
    std::vector<std::vector<std::int64_t>> ByColour; // the blocks of each colour
  };
  /// A kernel over the points of a list run over whole blocks of one colour instead: each
  /// block's points in order, the blocks in parallel.
  template <class PointKernel>
  struct BlockKernel
  {
    using Scratch = typename PointKernel::Scratch;
    const PointKernel* Kernel;
    const PointBlocks* Blocks;
    const std::vector<std::int64_t>* Colour;
    void operator()(Scratch& scratch, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t i = begin; i < end; ++i)
      {
        const std::int64_t block = (*this->Colour)[i];
        (*this->Kernel)(scratch, this->Blocks->Offsets[block], this->Blocks->Offsets[block + 1]);
      }
    }
  };
  static constexpr std::int64_t BlockSize = 256;
  /// Root colours (CellRootColours): 3^Dim, as stm::RootColouring counts them.
  static constexpr int NumberOfRootColours = Dim == 1 ? 3 : Dim == 2 ? 9 : Dim == 3 ? 27 : 81;

  template <class IdType, class Executor>
  void MakeBlocks(const IdType* connectivity, std::vector<std::int64_t> points, PointBlocks& blocks,
    Executor& executor) const;
  /// MakeBlocks from CellRootColours (header comment): ByColour has one entry per root colour.
  template <class IdType, class Executor>
  void MakeRootBlocks(const IdType* connectivity, std::vector<std::int64_t> points,
    PointBlocks& blocks, Executor& executor) const;

  /// A validated Jacobi step of the points of `blocks` toward lambda (c - x), followed, when mu
  /// is not zero, by mu (c - x) on the lambda targets before the validation.
  /// With `given`, the targets are already in Targets (lambda and mu are not used).
  template <class IdType, class Projector, class Executor>
  Status Step(const PointBlocks& blocks, bool surface, double lambda, double mu,
    const IdType* connectivity, Projector& projector, bool project, Executor& executor,
    bool given = false);

  /// The volume restoration: see the header comment.
  template <class IdType, class MaterialType, class Projector, class Executor>
  Status RestoreVolumes(const PointBlocks& surfaceBlocks, const IdType* connectivity,
    const MaterialType* materials, Projector& projector, Executor& executor);

  /// The quality improvement: see the header comment.
  template <class IdType, class MaterialType, class Projector, class Executor>
  Status Improve(const IdType* connectivity, const MaterialType* materials, Projector& projector,
    bool project, Executor& executor);

  /// Per material of the cells around point p, the gradient at p of the sum of their
  /// determinants (Dim! times the volume); whether p is on the outer boundary; the sum of the
  /// gradients' absolute components (a scale). False when a cell around p is degenerate.
  struct MaterialGradient
  {
    std::int64_t Material;
    double Vector[Dim];
  };
  template <class IdType, class MaterialType>
  bool VolumeGradients(const IdType* connectivity, const MaterialType* materials, std::int64_t p,
    std::vector<MaterialGradient>& gradients, bool& outer, double& scale) const;

  /// The directions (orthonormal, at most Dim) in which point p may move in the improvement:
  /// those that keep every material's volume, and the body's, to first order; with
  /// `offInterface`, every direction for a point between exactly two materials.
  template <class IdType, class MaterialType>
  int FreeDirections(const IdType* connectivity, const MaterialType* materials, std::int64_t p,
    bool offInterface, double (&directions)[Dim][Dim]) const;

  template <class IdType>
  Status CheckInput(const double* points, std::int64_t numberOfPoints, const IdType* connectivity,
    std::int64_t numberOfCells, const BoundarySmoothOptions& options) const;
  /// With an exchange: the held points' roles from the pieces that move them.
  void ShareRoles();
  /// With an exchange: the shapes of the cells around points whose positions another piece
  /// changed.
  template <class IdType>
  void MeasureAround(const IdType* connectivity, const std::vector<std::int64_t>& changed);
  Status Validate(const double* points, std::int64_t numberOfPoints, std::int64_t numberOfCells,
    const BoundarySmoothOptions& options) const;

  BoundarySmoothStats Stats;
  BoundarySmoothOptions Options;
  double* Points = nullptr;
  std::int64_t NumberOfPoints = 0;
  std::int64_t NumberOfCells = 0;
  // Copied from the points by the threads before the iterations (UninitializedVector).
  UninitializedVector<double> Original; // only with MaxDisplacement: 8 * Dim bytes per point
  std::vector<std::uint8_t> Moved;      // per point: 1 once a move changed it
  UninitializedVector<double> Targets;
  // Taubin's targets after the mu step, by the point's position in its step (surface points
  // only, not every point: 8 * Dim bytes per point at the smoother's peak).
  UninitializedVector<double> Composed;
  std::vector<std::uint8_t> Roles;
  std::vector<std::uint8_t> OnOuterBoundary; // per point: a corner of a facet with no neighbour
  // 32-bit rows: a move reads its point's row three times, and the rows are the smoother's
  // largest array (AAL, 116 labels: 111 MB instead of 222 MB).
  using Incidences = PointCells<Dim, std::int32_t>;
  Incidences Incidence;
  std::vector<std::int64_t> SurfaceOffsets; // point -> its surface neighbours (CSR)
  std::vector<NeighbourId> SurfaceNeighbours;
  // Written in full by the first measure, which touches them first (UninitializedVector).
  UninitializedVector<std::int8_t> Signs;
  std::vector<std::int64_t> EdgeOffsets; // interior-layer point -> its edge neighbours (CSR)
  std::vector<NeighbourId> EdgeNeighbours;
  UninitializedVector<Shape> Shapes;        // per cell, together: a move reads and writes both
  UninitializedVector<double> Determinants; // only while a measure sums the volumes
  double ConditionBound = 0.0;
  // Whether Step exchanges with the other pieces (Options.Exchange, during the iterations).
  bool Exchanging = false;

  /// executor.ShouldAbort(), agreed by all pieces when they exchange (collective then): a piece
  /// that stopped alone would leave the others waiting at their next exchange. Every call site
  /// is one that all pieces reach in the same order.
  template <class Executor>
  bool StopAgreed(Executor& executor) const
  {
    const bool stop = executor.ShouldAbort();
    return this->Options.Exchange ? this->Options.Exchange->Maximum(stop ? 1.0 : 0.0) > 0.0 : stop;
  }
  double CosineBound = 1.0;
  double OptionCosine = 1.0; // the cosine of MinDihedralAngle
  std::atomic<std::int64_t> Accepted{ 0 };
  std::atomic<std::int64_t> Reduced{ 0 };
  std::atomic<std::int64_t> Rejected{ 0 };
};

// --- implementation ----------------------------------------------------------------------------

template <int Dim>
template <class Key>
void BoundarySmoother<Dim>::SumOverPieces(
  std::map<Key, ExactSum>& sums, SmoothingExchange* exchange)
{
  if (!exchange)
  {
    return;
  }
  // Rows of the key's integers (exact as doubles below 2^53, and the Outside marker -2^63) and
  // one part of the sum.
  constexpr bool pair = !std::is_same<Key, std::int64_t>::value;
  constexpr std::size_t width = pair ? 3 : 2;
  std::vector<double> rows;
  for (const auto& entry : sums)
  {
    std::vector<double> parts = entry.second.Parts();
    if (parts.empty())
    {
      parts.push_back(0.0); // a zero sum still names its key in every piece
    }
    for (const double part : parts)
    {
      if constexpr (pair)
      {
        rows.push_back(static_cast<double>(entry.first.first));
        rows.push_back(static_cast<double>(entry.first.second));
      }
      else
      {
        rows.push_back(static_cast<double>(entry.first));
      }
      rows.push_back(part);
    }
  }
  const std::vector<double> all = exchange->Gather(rows);
  sums.clear();
  for (std::size_t at = 0; at + width <= all.size(); at += width)
  {
    Key key;
    if constexpr (pair)
    {
      key = { static_cast<std::int64_t>(all[at]), static_cast<std::int64_t>(all[at + 1]) };
    }
    else
    {
      key = static_cast<std::int64_t>(all[at]);
    }
    sums[key].Add(all[at + width - 1]);
  }
}

template <int Dim>
template <class IdType, class MaterialType, class Executor>
void BoundarySmoother<Dim>::ConstrainJunctions(const IdType* connectivity,
  const MaterialType* materials, const std::vector<std::uint8_t>& surfaceMasks, Executor& executor)
{
  if (Dim < 2 || !materials)
  {
    return;
  }
  // Junction faces: faces of dimension Dim - 2 where surface facets of two or more material
  // pairs meet (in 3D the edges of the junction lines, in 2D points). Every surface facet that
  // holds a face holds the face's smallest point, so each point p finds the faces it is the
  // smallest point of from its own cells' surface facets: in parallel over chunks of points,
  // each chunk listing its junction faces' points (3D: the line edges, both ways).
  constexpr int FaceOthers = Dim > 2 ? Dim - 2 : 0; // points of a face besides its smallest
  constexpr std::int64_t Outside = std::numeric_limits<std::int64_t>::min();
  struct FaceRecord
  {
    std::int64_t Others[FaceOthers > 0 ? FaceOthers : 1];
    std::int64_t Low, High; // the facet's material pair (Outside: the outer boundary)
    bool SameFace(const FaceRecord& other) const
    {
      return std::equal(this->Others, this->Others + FaceOthers, other.Others);
    }
    bool operator<(const FaceRecord& other) const
    {
      for (int k = 0; k < FaceOthers; ++k)
      {
        if (this->Others[k] != other.Others[k])
        {
          return this->Others[k] < other.Others[k];
        }
      }
      return std::tie(this->Low, this->High) < std::tie(other.Low, other.High);
    }
  };
  constexpr std::int64_t Chunk = 16384;
  const std::int64_t chunks = (this->NumberOfPoints + Chunk - 1) / Chunk;
  std::vector<std::vector<std::int64_t>> chunkPoints(static_cast<std::size_t>(chunks));
  struct JunctionKernel
  {
    using Entry = typename Incidences::FacetEntry;
    struct Scratch
    {
      std::vector<Entry> Entries;
      std::vector<FaceRecord> Records;
    };
    const BoundarySmoother* Self;
    const IdType* Connectivity;
    const MaterialType* Materials;
    const std::uint8_t* SurfaceMasks;
    std::vector<std::int64_t>* Points; // per chunk: junction face points (3D: edge pairs)
    void operator()(Scratch& scratch, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t chunk = begin; chunk < end; ++chunk)
      {
        const std::int64_t last = std::min(this->Self->NumberOfPoints, (chunk + 1) * Chunk);
        for (std::int64_t p = chunk * Chunk; p < last; ++p)
        {
          if (this->Self->Roles[p] != Surface && this->Self->Roles[p] != Fixed)
          {
            continue; // on no surface facet
          }
          this->Junctions(scratch, p, this->Points[chunk]);
        }
      }
    }
    void Junctions(Scratch& scratch, std::int64_t p, std::vector<std::int64_t>& out) const
    {
      scratch.Records.clear();
      this->Self->Incidence.ForEachFacetAt(
        this->Connectivity, p, false, scratch.Entries,
        [this](std::int64_t cell, int corner) { return (this->SurfaceMasks[cell] >> corner) & 1; },
        [&](const Entry* first, const Entry* last)
        {
          const auto own = static_cast<std::int64_t>(this->Materials[first->Cell]);
          const std::int64_t other =
            last - first == 1 ? Outside : static_cast<std::int64_t>(this->Materials[first[1].Cell]);
          // The facet's faces through p of which p is the smallest point: drop one other point.
          for (int drop = 0; drop < Dim - 1; ++drop)
          {
            FaceRecord record{ {}, std::min(own, other), std::max(own, other) };
            bool smallest = true;
            for (int k = 0, f = 0; k < Dim - 1; ++k)
            {
              if (k != drop)
              {
                smallest = smallest && first->Others[k] > p;
                record.Others[f++] = first->Others[k];
              }
            }
            if (smallest)
            {
              scratch.Records.push_back(record);
            }
          }
        });
      std::sort(scratch.Records.begin(), scratch.Records.end());
      const std::vector<FaceRecord>& records = scratch.Records;
      for (std::size_t first = 0; first < records.size();)
      {
        std::size_t last = first + 1;
        bool junction = false;
        while (last < records.size() && records[last].SameFace(records[first]))
        {
          junction = junction || records[last].Low != records[first].Low ||
            records[last].High != records[first].High;
          ++last;
        }
        if (junction)
        {
          out.push_back(p);
          out.insert(out.end(), records[first].Others, records[first].Others + FaceOthers);
        }
        first = last;
      }
    }
  };
  JunctionKernel kernel{ this, connectivity, materials, surfaceMasks.data(), chunkPoints.data() };
  executor.For(0, chunks, 1, kernel);
  std::vector<std::int64_t> facePoints;
  for (std::vector<std::int64_t>& chunk : chunkPoints)
  {
    facePoints.insert(facePoints.end(), chunk.begin(), chunk.end());
    std::vector<std::int64_t>().swap(chunk);
  }
  if constexpr (Dim != 3)
  {
    // 2D: a junction point; 4D: the points of a junction face are not smoothed along their
    // surface.
    std::sort(facePoints.begin(), facePoints.end());
    facePoints.erase(std::unique(facePoints.begin(), facePoints.end()), facePoints.end());
    for (const std::int64_t p : facePoints)
    {
      if (this->Roles[p] == Surface)
      {
        this->Roles[p] = Fixed;
        ++this->Stats.JunctionCornerPoints;
      }
    }
    return;
  }
  std::vector<std::pair<std::int64_t, std::int64_t>> lineEdges;
  for (std::size_t k = 0; k + 1 < facePoints.size(); k += 2)
  {
    lineEdges.emplace_back(facePoints[k], facePoints[k + 1]);
    lineEdges.emplace_back(facePoints[k + 1], facePoints[k]);
  }
  if (lineEdges.empty())
  {
    return;
  }
  // 3D: a point on exactly two junction edges moves along its line (toward the midpoint of its
  // two line neighbours); where lines meet or end (a quadruple point) it is fixed.
  std::sort(lineEdges.begin(), lineEdges.end());
  lineEdges.erase(std::unique(lineEdges.begin(), lineEdges.end()), lineEdges.end());
  std::vector<std::int64_t> offsets(this->SurfaceOffsets);
  std::vector<NeighbourId> neighbours;
  neighbours.reserve(this->SurfaceNeighbours.size());
  std::size_t edge = 0;
  for (std::int64_t p = 0; p < this->NumberOfPoints; ++p)
  {
    std::size_t end = edge;
    while (end < lineEdges.size() && lineEdges[end].first == p)
    {
      ++end;
    }
    const std::size_t count = end - edge;
    if (count == 2 && this->Roles[p] == Surface)
    {
      neighbours.push_back(static_cast<NeighbourId>(lineEdges[edge].second));
      neighbours.push_back(static_cast<NeighbourId>(lineEdges[edge + 1].second));
      ++this->Stats.JunctionLinePoints;
    }
    else
    {
      if (count > 0 && this->Roles[p] == Surface)
      {
        this->Roles[p] = Fixed;
        ++this->Stats.JunctionCornerPoints;
      }
      neighbours.insert(neighbours.end(), this->SurfaceNeighbours.begin() + this->SurfaceOffsets[p],
        this->SurfaceNeighbours.begin() + this->SurfaceOffsets[p + 1]);
    }
    offsets[p + 1] = static_cast<std::int64_t>(neighbours.size());
    edge = end;
  }
  this->SurfaceOffsets.swap(offsets);
  this->SurfaceNeighbours.swap(neighbours);
}

template <int Dim>
Status BoundarySmoother<Dim>::Validate(const double* points, std::int64_t numberOfPoints,
  std::int64_t numberOfCells, const BoundarySmoothOptions& options) const
{
  if (numberOfPoints < 0 || numberOfCells < 0 || (numberOfPoints > 0 && !points))
  {
    return Status::Invalid("no points or negative counts");
  }
  if (!Incidences::FitsCellIds(numberOfCells))
  {
    return Status::Invalid(
      "the smoother takes at most 2^31 - 1 cells, the mesh has " + std::to_string(numberOfCells));
  }
  if (numberOfPoints > std::numeric_limits<NeighbourId>::max())
  {
    return Status::Invalid(
      "the smoother takes at most 2^31 - 1 points, the mesh has " + std::to_string(numberOfPoints));
  }
  if (options.NumberOfIterations < 0)
  {
    return Status::Invalid("the number of iterations must be >= 0");
  }
  if (!(options.RelaxationFactor > 0.0 && options.RelaxationFactor <= 1.0))
  {
    return Status::Invalid("the relaxation factor must be in (0, 1]");
  }
  if (!(options.PassBand > 0.0 && options.PassBand < 1.0))
  {
    return Status::Invalid("the pass band must be in (0, 1)");
  }
  if (!(options.MaxDisplacement >= 0.0) || !std::isfinite(options.MaxDisplacement))
  {
    return Status::Invalid("the maximum displacement must be finite and >= 0");
  }
  if (options.NumberOfInteriorLayers < 0)
  {
    return Status::Invalid("the number of interior layers must be >= 0");
  }
  if (options.InteriorRelaxationInterval < 1)
  {
    return Status::Invalid("the interior relaxation interval must be >= 1");
  }
  if (options.SmallPartPoints < 0)
  {
    return Status::Invalid("the number of small-part points must be >= 0");
  }
  if (!(options.MaxConditionNumber >= 1.0))
  {
    return Status::Invalid("the maximum condition number must be >= 1");
  }
  if (!(options.MinDihedralAngle >= 0.0 && options.MinDihedralAngle < 180.0))
  {
    return Status::Invalid("the minimum dihedral angle must be in [0, 180) degrees");
  }
  if (options.NumberOfImprovementSweeps < 0)
  {
    return Status::Invalid("the number of improvement sweeps must be >= 0");
  }
  if (options.NumberOfVolumeRounds < 0)
  {
    return Status::Invalid("the number of volume rounds must be >= 0");
  }
  if (!(options.VolumeTolerance >= 0.0))
  {
    return Status::Invalid("the volume tolerance must be >= 0");
  }
  return Status::Ok();
}

template <int Dim>
template <class IdType>
Status BoundarySmoother<Dim>::CheckInput(const double* points, std::int64_t numberOfPoints,
  const IdType* connectivity, std::int64_t numberOfCells,
  const BoundarySmoothOptions& options) const
{
  Status status = this->Validate(points, numberOfPoints, numberOfCells, options);
  if (!status.IsOk())
  {
    return status;
  }
  if (numberOfCells > 0 && !connectivity)
  {
    return Status::Invalid("no connectivity");
  }
  constexpr std::int64_t Corners = Dim + 1;
  for (std::int64_t i = 0; i < numberOfCells * Corners; ++i)
  {
    const auto id = static_cast<std::int64_t>(connectivity[i]);
    if (id < 0 || id >= numberOfPoints)
    {
      return Status::Invalid(
        "cell " + std::to_string(i / Corners) + " has an invalid point id " + std::to_string(id));
    }
  }
  if (options.CellRootColours)
  {
    for (std::int64_t c = 0; c < numberOfCells; ++c)
    {
      if (options.CellRootColours[c] >= NumberOfRootColours)
      {
        return Status::Invalid("cell " + std::to_string(c) + " has root colour " +
          std::to_string(options.CellRootColours[c]) + ", not below 3^" + std::to_string(Dim));
      }
    }
  }
  if (options.Exchange && !(options.CellRootColours && options.HeldPoints))
  {
    return Status::Invalid("an exchange between pieces needs root colours and held points");
  }
  for (std::int64_t i = 0; i < numberOfPoints * Dim; ++i)
  {
    if (!std::isfinite(points[i]))
    {
      return Status::Invalid("point " + std::to_string(i / Dim) + " has a non-finite coordinate");
    }
  }
  return Status::Ok();
}

template <int Dim>
template <class IdType>
void BoundarySmoother<Dim>::CellCorners(const IdType* ids, std::int64_t cell,
  std::int64_t movedPoint, const double* movedPosition, const double* (&corners)[Dim + 1]) const
{
  for (int v = 0; v <= Dim; ++v)
  {
    const auto id = static_cast<std::int64_t>(ids[v]);
    corners[v] = id == movedPoint ? movedPosition : this->Points + id * Dim;
  }
  // A cell of the other orientation is measured with two corners swapped, so that "keeps the
  // input's sign" and "positive" are one test.
  if (this->Signs[cell] < 0)
  {
    std::swap(corners[0], corners[1]);
  }
}

template <int Dim>
template <class IdType>
void BoundarySmoother<Dim>::CornerGradient(
  const IdType* ids, std::int64_t cell, std::int64_t point, double (&gradient)[Dim]) const
{
  const double* corners[Dim + 1];
  this->CellCorners(ids, cell, -1, nullptr, corners);
  int own = 0;
  while (corners[own] != this->Points + point * Dim)
  {
    ++own;
  }
  if constexpr (Dim == 1)
  {
    gradient[0] = own == 0 ? -1.0 : 1.0;
  }
  else
  {
    // det[x1 - x0, ..., xd - x0]: the gradient in corner k >= 1 is column k's cofactors; corner
    // 0 enters every column with a minus sign.
    double edges[Dim][Dim];
    for (int col = 0; col < Dim; ++col)
    {
      for (int r = 0; r < Dim; ++r)
      {
        edges[r][col] = corners[col + 1][r] - corners[0][r];
      }
    }
    std::fill(gradient, gradient + Dim, 0.0);
    for (int col = 0; col < Dim; ++col)
    {
      if (own != 0 && col != own - 1)
      {
        continue;
      }
      for (int r = 0; r < Dim; ++r)
      {
        double minor[Dim - 1][Dim - 1];
        for (int i = 0, mi = 0; i < Dim; ++i)
        {
          if (i == r)
          {
            continue;
          }
          for (int j = 0, mj = 0; j < Dim; ++j)
          {
            if (j != col)
            {
              minor[mi][mj++] = edges[i][j];
            }
          }
          ++mi;
        }
        const double cofactor = ((r + col) % 2 == 0 ? 1.0 : -1.0) * Determinant<Dim - 1>(minor);
        gradient[r] += own == 0 ? -cofactor : cofactor;
      }
    }
  }
}

template <int Dim>
template <class IdType>
typename BoundarySmoother<Dim>::Shape BoundarySmoother<Dim>::MeasureCell(const IdType* ids,
  std::int64_t cell, std::int64_t movedPoint, const double* movedPosition,
  double* determinant) const
{
  const double* corners[Dim + 1];
  this->CellCorners(ids, cell, movedPoint, movedPosition, corners);
  const SimplexCosines shape = MeasureSimplexCosines<Dim>(corners);
  if (determinant)
  {
    *determinant = shape.Determinant;
  }
  return { shape.Condition, shape.LargestDihedralCosine };
}

template <int Dim>
template <class IdType>
void BoundarySmoother<Dim>::KeepSmallParts(
  const IdType* connectivity, const std::vector<std::uint8_t>& tips)
{
  // Parts: the interior-layer points joined by edges, by union-find (a root is the smallest id
  // of its part); a part with a deeper interior point next to it is no small part.
  const std::int64_t n = this->NumberOfPoints;
  std::vector<std::int64_t> root(static_cast<std::size_t>(n), -1);
  auto find = [&root](std::int64_t p) { return FindRoot(root, p); };
  std::vector<std::int64_t> size(static_cast<std::size_t>(n), 0);
  std::vector<std::uint8_t> deep(static_cast<std::size_t>(n), 0);
  // A piece joins the edges, counts the points and finds the depth of the points it moves,
  // whose edges it has in full; the held points join their movers' parts across the pieces.
  const std::uint8_t* held =
    this->Options.Exchange ? this->Options.HeldPoints : static_cast<const std::uint8_t*>(nullptr);
  for (std::int64_t p = 0; p < n; ++p)
  {
    if (this->Roles[p] != InteriorLayer)
    {
      continue;
    }
    if (root[p] < 0)
    {
      root[p] = p; // else a held point an earlier point joined
    }
    if (held && held[p])
    {
      continue;
    }
    for (std::int64_t k = this->EdgeOffsets[p]; k < this->EdgeOffsets[p + 1]; ++k)
    {
      const std::int64_t q = this->EdgeNeighbours[k];
      if (this->Roles[q] == Other)
      {
        deep[p] = 1;
      }
      else if ((q < p || (held && held[q])) && this->Roles[q] == InteriorLayer)
      {
        if (root[q] < 0)
        {
          root[q] = q; // a held point after p
        }
        const std::int64_t a = find(p), b = find(q);
        root[std::max(a, b)] = std::min(a, b);
      }
    }
  }
  for (std::int64_t p = 0; p < n; ++p)
  {
    if (root[p] >= 0)
    {
      const std::int64_t r = find(p);
      const bool counted = !(held && held[p]);
      size[r] += counted;
      deep[r] |= counted && deep[p];
    }
  }
  if (held)
  {
    this->JoinPartsOfPieces(connectivity, find, size, deep);
  }
  // Kept: the tips, and the points of the small parts with every corner of their cells.
  std::vector<std::int64_t> kept;
  for (std::int64_t p = 0; p < n; ++p)
  {
    if (root[p] < 0)
    {
      continue;
    }
    const std::int64_t r = find(p);
    const bool small = !deep[r] && size[r] <= this->Options.SmallPartPoints;
    this->Stats.SmallParts += small && r == p;
    if (!small)
    {
      if (tips[p])
      {
        kept.push_back(p);
      }
      continue;
    }
    for (std::int64_t k = this->Incidence.Offsets[p]; k < this->Incidence.Offsets[p + 1]; ++k)
    {
      const IdType* ids = connectivity + this->Incidence.Cells[k] * (Dim + 1);
      kept.insert(kept.end(), ids, ids + Dim + 1);
    }
  }
  for (const std::int64_t p : kept)
  {
    if (this->Roles[p] == InteriorLayer || this->Roles[p] == Surface)
    {
      this->Roles[p] = this->Roles[p] == Surface ? KeptSurface : Fixed;
      ++this->Stats.KeptPoints;
    }
  }
}

template <int Dim>
template <class IdType, class Find>
void BoundarySmoother<Dim>::JoinPartsOfPieces(const IdType* connectivity, Find& find,
  std::vector<std::int64_t>& size, std::vector<std::uint8_t>& deep) const
{
  constexpr std::int64_t Corners = Dim + 1;
  const std::int64_t n = this->NumberOfPoints;
  // The points other pieces may have: the held points, and the corners of the cells at a point
  // of a ghost cell (what the exchange sends). Their positions have not moved yet: they name
  // the points alike in every piece.
  const std::uint8_t* ghostPoints = this->Options.GhostPoints;
  std::vector<std::uint8_t> shared(this->Options.HeldPoints, this->Options.HeldPoints + n);
  for (std::int64_t c = 0; ghostPoints && c < this->NumberOfCells; ++c)
  {
    const IdType* ids = connectivity + c * Corners;
    if (std::any_of(ids, ids + Corners, [&](IdType id) { return ghostPoints[id] != 0; }))
    {
      for (int v = 0; v < Corners; ++v)
      {
        shared[static_cast<std::size_t>(ids[v])] = 1;
      }
    }
  }
  // This piece's block: its parts with a shared point (their size and depth here), then the
  // shared points (part, position).
  std::map<std::int64_t, std::int64_t> partIndex;
  std::vector<double> parts, rows;
  for (std::int64_t p = 0; p < n; ++p)
  {
    if (shared[p] && this->Roles[p] == InteriorLayer)
    {
      const std::int64_t r = find(p);
      const auto found = partIndex.emplace(r, static_cast<std::int64_t>(partIndex.size()));
      if (found.second)
      {
        parts.push_back(static_cast<double>(size[r]));
        parts.push_back(deep[r]);
      }
      rows.push_back(static_cast<double>(found.first->second));
      rows.insert(rows.end(), this->Points + p * Dim, this->Points + (p + 1) * Dim);
    }
  }
  std::vector<double> block{ static_cast<double>(partIndex.size()),
    static_cast<double>(rows.size() / (Dim + 1)) };
  block.insert(block.end(), parts.begin(), parts.end());
  block.insert(block.end(), rows.begin(), rows.end());
  const std::vector<double> all = this->Options.Exchange->Gather(block);

  // Every piece's parts as nodes, joined where they share a point.
  std::vector<std::int64_t> parent;
  std::vector<std::int64_t> nodeSize;
  std::vector<std::uint8_t> nodeDeep;
  auto findNode = [&parent](std::int64_t a) { return FindRoot(parent, a); };
  std::map<std::array<double, Dim>, std::int64_t> nodeOfPoint;
  for (std::size_t at = 0; at + 2 <= all.size();)
  {
    const auto partCount = static_cast<std::int64_t>(all[at]);
    const auto rowCount = static_cast<std::int64_t>(all[at + 1]);
    at += 2;
    const auto first = static_cast<std::int64_t>(parent.size());
    for (std::int64_t i = 0; i < partCount; ++i, at += 2)
    {
      parent.push_back(first + i);
      nodeSize.push_back(static_cast<std::int64_t>(all[at]));
      nodeDeep.push_back(all[at + 1] != 0.0);
    }
    for (std::int64_t i = 0; i < rowCount; ++i, at += Dim + 1)
    {
      const std::int64_t node = first + static_cast<std::int64_t>(all[at]);
      std::array<double, Dim> position;
      std::copy(all.begin() + at + 1, all.begin() + at + 1 + Dim, position.begin());
      const auto found = nodeOfPoint.emplace(position, node);
      if (!found.second)
      {
        const std::int64_t a = findNode(node), b = findNode(found.first->second);
        parent[std::max(a, b)] = std::min(a, b);
      }
    }
  }
  std::vector<std::int64_t> totalSize(parent.size(), 0);
  std::vector<std::uint8_t> totalDeep(parent.size(), 0);
  for (std::size_t node = 0; node < parent.size(); ++node)
  {
    const std::int64_t r = findNode(static_cast<std::int64_t>(node));
    totalSize[r] += nodeSize[node];
    totalDeep[r] |= nodeDeep[node];
  }
  // This piece's parts take the totals of the nodes their shared points belong to.
  for (std::int64_t p = 0; p < n; ++p)
  {
    if (shared[p] && this->Roles[p] == InteriorLayer)
    {
      const std::int64_t r = find(p);
      std::array<double, Dim> position;
      std::copy(this->Points + p * Dim, this->Points + (p + 1) * Dim, position.begin());
      const std::int64_t node = findNode(nodeOfPoint.at(position));
      size[r] = totalSize[node];
      deep[r] = totalDeep[node];
    }
  }
}

template <int Dim>
template <class IdType, class MaterialType, class Projector, class Executor>
Status BoundarySmoother<Dim>::Smooth(double* points, std::int64_t numberOfPoints,
  const IdType* connectivity, std::int64_t numberOfCells, const MaterialType* materials,
  const BoundarySmoothOptions& options, Projector&& projector, Executor& executor)
{
  this->Stats = BoundarySmoothStats();
  Status status = this->CheckInput(points, numberOfPoints, connectivity, numberOfCells, options);
  if (options.Exchange && !options.Exchange->AllReady(status.IsOk()) && status.IsOk())
  {
    status = Status::Invalid("the smoothing of another piece failed");
  }
  if (!status.IsOk())
  {
    return status;
  }
  this->Options = options;
  this->Points = points;
  this->NumberOfPoints = numberOfPoints;
  this->NumberOfCells = numberOfCells;
  this->Accepted = 0;
  this->Reduced = 0;
  this->Rejected = 0;
  const std::int64_t cells = numberOfCells;
  constexpr std::int64_t Corners = Dim + 1;

  const std::int64_t background = options.BackgroundMaterial;
  auto isBackground = [&](std::int64_t cell)
  { return materials && static_cast<std::int64_t>(materials[cell]) == background; };
  auto sameMaterial = [&](std::int64_t a, std::int64_t b)
  { return !materials || materials[a] == materials[b]; };

  this->Incidence.Build(connectivity, cells, numberOfPoints, executor);
  if (this->StopAgreed(executor))
  {
    return Status::Aborted();
  }

  // The input's shapes: orientation, quality, volume.
  this->Signs.resize(static_cast<std::size_t>(cells));
  this->Shapes.resize(static_cast<std::size_t>(cells));
  this->Determinants.resize(static_cast<std::size_t>(cells));
  struct MeasureKernel
  {
    using Scratch = NoScratch;
    BoundarySmoother* Self;
    const IdType* Connectivity;
    bool First;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t c = begin; c < end; ++c)
      {
        const IdType* ids = this->Connectivity + c * Corners;
        if (this->First)
        {
          double edges[Dim][Dim];
          for (int col = 0; col < Dim; ++col)
          {
            for (int r = 0; r < Dim; ++r)
            {
              edges[r][col] =
                this->Self->Points[static_cast<std::int64_t>(ids[col + 1]) * Dim + r] -
                this->Self->Points[static_cast<std::int64_t>(ids[0]) * Dim + r];
            }
          }
          const double det = Determinant<Dim>(edges);
          this->Self->Signs[c] = det > 0.0 ? 1 : det < 0.0 ? -1 : 0;
        }
        double det = 0.0;
        const Shape shape = this->Self->MeasureCell(ids, c, -1, nullptr, &det);
        this->Self->Shapes[c] = shape;
        this->Self->Determinants[c] = this->Self->Signs[c] == 0 ? 0.0 : std::abs(det);
      }
    }
  };
  auto summarize = [&](double& worst, double& smallest, std::map<std::int64_t, double>& volumes)
  {
    worst = 0.0;
    double largestCosine = -1.0;
    for (std::int64_t c = 0; c < cells; ++c)
    {
      if (options.GhostCells && options.GhostCells[c])
      {
        continue;
      }
      worst = std::max(worst, this->Shapes[c].Condition);
      largestCosine = std::max(largestCosine, this->Shapes[c].Cosine);
    }
    SumPerKey(
      cells,
      [&](std::int64_t c)
      { return materials ? static_cast<std::int64_t>(materials[c]) : background + 1; },
      [&](std::int64_t c) { return this->Determinants[c] / Factorial(Dim); }, volumes,
      options.GhostCells);
    // What MeasureSimplex reports for the worst cell: acos is monotone, so the angle of the
    // largest cosine is the smallest angle.
    smallest = Dim == 1 || cells == 0 ? 180.0 : DihedralDegrees(largestCosine);
    return largestCosine;
  };
  MeasureKernel measure{ this, connectivity, true };
  executor.For(0, cells, 4096, measure);
  if (this->StopAgreed(executor))
  {
    return Status::Aborted();
  }
  double largestCosineBefore = summarize(
    this->Stats.WorstConditionBefore, this->Stats.MinDihedralBefore, this->Stats.VolumeBefore);
  if (options.Exchange)
  {
    // The bounds of the whole mesh (its own cells' volumes stay the piece's).
    this->Stats.WorstConditionBefore = options.Exchange->Maximum(this->Stats.WorstConditionBefore);
    largestCosineBefore = options.Exchange->Maximum(largestCosineBefore);
    this->Stats.MinDihedralBefore = Dim == 1 ? 180.0 : DihedralDegrees(largestCosineBefore);
  }
  if (!options.TargetVolumes.empty() && materials)
  {
    this->Stats.TargetVolumes = options.TargetVolumes;
  }
  else if (options.VolumeTargetMaterials && materials)
  {
    SumPerKey(
      cells, [&](std::int64_t c) { return options.VolumeTargetMaterials[c]; },
      [&](std::int64_t c) { return this->Determinants[c] / Factorial(Dim); },
      this->Stats.TargetVolumes, options.GhostCells, options.Exchange);
  }
  // The volumes are summed; the final measure makes the determinants again (8 bytes per cell
  // less at the peak of the iterations).
  UninitializedVector<double>().swap(this->Determinants);
  this->ConditionBound = std::min(options.MaxConditionNumber, this->Stats.WorstConditionBefore);
  // The dihedral bound max(MinDihedralAngle, smallest of the input) as a cosine: the input's
  // largest cosine itself, and the largest cosine whose angle is at least MinDihedralAngle
  // (cos rounds, so it is nudged until DihedralDegrees agrees), so that comparing cosines
  // accepts no angle that the comparison of degrees would refuse.
  double optionCosine = std::cos(options.MinDihedralAngle * (3.14159265358979323846 / 180.0));
  while (optionCosine > -1.0 && DihedralDegrees(optionCosine) < options.MinDihedralAngle)
  {
    optionCosine = std::nextafter(optionCosine, -2.0);
  }
  while (optionCosine < 1.0 &&
    DihedralDegrees(std::nextafter(optionCosine, 2.0)) >= options.MinDihedralAngle)
  {
    optionCosine = std::nextafter(optionCosine, 2.0);
  }
  this->CosineBound = std::min(optionCosine, largestCosineBefore);
  this->OptionCosine = optionCosine;
  executor.ReportProgress(0.05);

  // Facets: per cell, which of its facets (bit i: the facet opposite corner i) are surface
  // facets, fixed outer-boundary facets and outer-boundary facets, each facet found once from
  // its smallest point. A cell's facets are found from several points, possibly on several
  // threads, so the three masks share one atomic word per cell while they are made (zeroed by
  // the value-initialization). These words and the masks made of them are freed once used:
  // 5 bytes per cell that the iterations' peak held before (AAL upsampled 2.5x: 249 MB).
  std::unique_ptr<std::atomic<std::uint16_t>[]> facetBits(
    new std::atomic<std::uint16_t>[static_cast<std::size_t>(cells)]());
  struct FacetKernel
  {
    using Entry = typename Incidences::FacetEntry;
    struct Scratch
    {
      std::vector<Entry> Entries;
    };
    enum : int
    {
      FixedShift = Dim + 1,
      OuterShift = 2 * (Dim + 1)
    };
    const BoundarySmoother* Self;
    const IdType* Connectivity;
    std::atomic<std::uint16_t>* Bits;
    const decltype(isBackground)* IsBackground;
    const decltype(sameMaterial)* SameMaterial;
    void operator()(Scratch& scratch, std::int64_t begin, std::int64_t end) const
    {
      auto mark = [this](const Entry& entry, int shift)
      {
        this->Bits[entry.Cell].fetch_or(
          static_cast<std::uint16_t>(1u << (entry.Corner + shift)), std::memory_order_relaxed);
      };
      for (std::int64_t p = begin; p < end; ++p)
      {
        this->Self->Incidence.ForEachFacetAt(
          this->Connectivity, p, true, scratch.Entries, [](std::int64_t, int) { return true; },
          [&](const Entry* first, const Entry* last)
          {
            if (last - first == 1)
            {
              mark(*first, OuterShift);
              mark(*first, (*this->IsBackground)(first->Cell) ? FixedShift : 0);
              return;
            }
            // Beyond two cells (not conforming), each takes the smallest other one.
            for (const Entry* entry = first; entry != last; ++entry)
            {
              const std::int64_t neighbour = entry == first ? first[1].Cell : first->Cell;
              if (!(*this->SameMaterial)(entry->Cell, neighbour))
              {
                mark(*entry, 0);
              }
            }
          });
      }
    }
  };
  FacetKernel facets{ this, connectivity, facetBits.get(), &isBackground, &sameMaterial };
  executor.For(0, numberOfPoints, 4096, facets);
  if (this->StopAgreed(executor))
  {
    return Status::Aborted();
  }
  std::vector<std::uint8_t> surfaceMasks(static_cast<std::size_t>(cells));
  std::vector<std::uint8_t> fixedMasks(static_cast<std::size_t>(cells));
  std::vector<std::uint8_t> outerMasks(static_cast<std::size_t>(cells));
  constexpr unsigned CornerBits = (1u << Corners) - 1u;
  for (std::int64_t c = 0; c < cells; ++c)
  {
    const unsigned bits = facetBits[c].load(std::memory_order_relaxed);
    surfaceMasks[c] = static_cast<std::uint8_t>(bits & CornerBits);
    fixedMasks[c] = static_cast<std::uint8_t>(bits >> FacetKernel::FixedShift & CornerBits);
    outerMasks[c] = static_cast<std::uint8_t>(bits >> FacetKernel::OuterShift & CornerBits);
  }
  facetBits.reset();

  // Roles, and the surface neighbours (the other points of the surface facets around each
  // point), per point over its cells in parallel, each point's neighbours sorted and unique,
  // gathered per chunk of points and joined in chunk order: the rows of a serial pass.
  this->Roles.assign(static_cast<std::size_t>(numberOfPoints), Other);
  this->OnOuterBoundary.assign(static_cast<std::size_t>(numberOfPoints), 0);
  this->SurfaceOffsets.assign(static_cast<std::size_t>(numberOfPoints) + 1, 0);
  {
    constexpr std::int64_t RoleChunk = 4096;
    const std::int64_t roleChunks = (numberOfPoints + RoleChunk - 1) / RoleChunk;
    std::vector<std::vector<NeighbourId>> chunkNeighbours(static_cast<std::size_t>(roleChunks));
    struct RoleKernel
    {
      struct Scratch
      {
        std::vector<std::int64_t> Ids;
      };
      BoundarySmoother* Self;
      const IdType* Connectivity;
      const std::uint8_t* SurfaceMasks;
      const std::uint8_t* FixedMasks;
      const std::uint8_t* OuterMasks;
      std::vector<NeighbourId>* Chunks;
      void operator()(Scratch& scratch, std::int64_t begin, std::int64_t end) const
      {
        BoundarySmoother& self = *this->Self;
        for (std::int64_t chunk = begin; chunk < end; ++chunk)
        {
          std::vector<NeighbourId>& out = this->Chunks[chunk];
          const std::int64_t last = std::min(self.NumberOfPoints, (chunk + 1) * RoleChunk);
          for (std::int64_t p = chunk * RoleChunk; p < last; ++p)
          {
            bool fixed = false, surface = false;
            std::uint8_t outer = 0;
            scratch.Ids.clear();
            for (std::int64_t k = self.Incidence.Offsets[p]; k < self.Incidence.Offsets[p + 1]; ++k)
            {
              const std::int64_t c = self.Incidence.Cells[k];
              const IdType* ids = this->Connectivity + c * Corners;
              for (int corner = 0; corner <= Dim; ++corner)
              {
                if (static_cast<std::int64_t>(ids[corner]) != p)
                {
                  continue;
                }
                // The facets opposite the other corners hold p.
                for (int i = 0; i <= Dim; ++i)
                {
                  if (i == corner)
                  {
                    continue;
                  }
                  fixed = fixed || (this->FixedMasks[c] >> i & 1);
                  outer |= this->OuterMasks[c] >> i & 1;
                  if (this->SurfaceMasks[c] >> i & 1)
                  {
                    surface = true;
                    for (int b = 0; b <= Dim; ++b)
                    {
                      if (b != i && b != corner)
                      {
                        scratch.Ids.push_back(static_cast<std::int64_t>(ids[b]));
                      }
                    }
                  }
                }
              }
            }
            self.Roles[p] = fixed ? Fixed : surface ? Surface : Other;
            self.OnOuterBoundary[p] = outer;
            std::sort(scratch.Ids.begin(), scratch.Ids.end());
            const auto unique = std::unique(scratch.Ids.begin(), scratch.Ids.end());
            out.insert(out.end(), scratch.Ids.begin(), unique);
            self.SurfaceOffsets[p + 1] = static_cast<std::int64_t>(unique - scratch.Ids.begin());
          }
        }
      }
    };
    RoleKernel roles{ this, connectivity, surfaceMasks.data(), fixedMasks.data(), outerMasks.data(),
      chunkNeighbours.data() };
    executor.For(0, roleChunks, 1, roles);
    JoinRows(chunkNeighbours, this->SurfaceOffsets, this->SurfaceNeighbours);
  }
  std::vector<std::uint8_t>().swap(fixedMasks);
  std::vector<std::uint8_t>().swap(outerMasks);
  if (this->StopAgreed(executor))
  {
    return Status::Aborted();
  }
  this->ConstrainJunctions(connectivity, materials, surfaceMasks, executor);
  std::vector<std::uint8_t>().swap(surfaceMasks);
  if (options.Exchange)
  {
    // A held point's role is its mover's, which has all its cells.
    this->ShareRoles();
  }
  else if (options.HeldPoints)
  {
    // After the junctions, which may read any surface point, and before the interior layers,
    // which then stop at held points.
    for (std::int64_t p = 0; p < numberOfPoints; ++p)
    {
      this->Roles[p] = options.HeldPoints[p] ? static_cast<std::uint8_t>(Fixed) : this->Roles[p];
    }
  }

  // Interior layers by edge hops from the surface: layer k + 1 is the points without a role
  // that share a cell with a point of layer k (layer 0: the surface points). Each layer's points
  // gather their candidates in parallel, over chunks of the layer, reading the roles only; the
  // candidates are then taken in chunk order, each once.
  {
    std::vector<std::int64_t> frontier;
    for (std::int64_t p = 0; p < numberOfPoints; ++p)
    {
      if (this->Roles[p] == Surface)
      {
        frontier.push_back(p);
      }
    }
    constexpr std::int64_t LayerChunk = 4096;
    struct LayerKernel
    {
      using Scratch = NoScratch;
      const BoundarySmoother* Self;
      const IdType* Connectivity;
      const std::vector<std::int64_t>* Frontier;
      std::vector<std::int64_t>* Candidates; // per chunk of the frontier
      void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
      {
        const BoundarySmoother& self = *this->Self;
        const auto size = static_cast<std::int64_t>(this->Frontier->size());
        for (std::int64_t chunk = begin; chunk < end; ++chunk)
        {
          std::vector<std::int64_t>& candidates = this->Candidates[chunk];
          candidates.clear();
          const std::int64_t last = std::min(size, (chunk + 1) * LayerChunk);
          for (std::int64_t i = chunk * LayerChunk; i < last; ++i)
          {
            const std::int64_t p = (*this->Frontier)[i];
            for (std::int64_t k = self.Incidence.Offsets[p]; k < self.Incidence.Offsets[p + 1]; ++k)
            {
              const IdType* ids = this->Connectivity + self.Incidence.Cells[k] * Corners;
              for (int v = 0; v <= Dim; ++v)
              {
                const auto id = static_cast<std::int64_t>(ids[v]);
                if (self.Roles[id] == Other)
                {
                  candidates.push_back(id);
                }
              }
            }
          }
        }
      }
    };
    std::vector<std::vector<std::int64_t>> candidates;
    std::vector<std::uint8_t> wasOther;
    for (int layer = 0;
         layer < options.NumberOfInteriorLayers && (options.Exchange || !frontier.empty()); ++layer)
    {
      if (options.Exchange)
      {
        wasOther.resize(static_cast<std::size_t>(numberOfPoints));
        for (std::int64_t p = 0; p < numberOfPoints; ++p)
        {
          wasOther[p] = this->Roles[p] == Other;
        }
      }
      const std::int64_t chunks =
        (static_cast<std::int64_t>(frontier.size()) + LayerChunk - 1) / LayerChunk;
      if (static_cast<std::int64_t>(candidates.size()) < chunks)
      {
        candidates.resize(static_cast<std::size_t>(chunks));
      }
      LayerKernel kernel{ this, connectivity, &frontier, candidates.data() };
      executor.For(0, chunks, 1, kernel);
      std::vector<std::int64_t> next;
      for (std::int64_t chunk = 0; chunk < chunks; ++chunk)
      {
        for (const std::int64_t id : candidates[chunk])
        {
          if (this->Roles[id] == Other)
          {
            this->Roles[id] = InteriorLayer;
            next.push_back(id);
          }
        }
      }
      if (options.Exchange)
      {
        // A held point may be in the layer through cells this piece does not have: the next
        // frontier is every point the layer took, by the roles of the points' movers.
        this->ShareRoles();
        next.clear();
        for (std::int64_t p = 0; p < numberOfPoints; ++p)
        {
          if (wasOther[p] && this->Roles[p] == InteriorLayer)
          {
            next.push_back(p);
          }
        }
      }
      frontier.swap(next);
    }
  }
  if (this->StopAgreed(executor))
  {
    return Status::Aborted();
  }

  // Edge neighbours of the interior-layer points (their Laplacian targets), sorted by id, once:
  // gathering and sorting them from the incident cells at every pass cost more than the moves.
  // In parallel over chunks of points, each into its own list; a point's ids are made unique
  // with a per-thread stamp per point before the sort, so only the unique ones are sorted.
  constexpr std::int64_t EdgeChunk = 4096;
  const std::int64_t edgeChunks = (numberOfPoints + EdgeChunk - 1) / EdgeChunk;
  std::vector<std::vector<NeighbourId>> chunkNeighbours(static_cast<std::size_t>(edgeChunks));
  this->EdgeOffsets.assign(static_cast<std::size_t>(numberOfPoints) + 1, 0);
  struct EdgeKernel
  {
    struct Scratch
    {
      std::vector<std::int64_t> Stamps; // per point: the last point whose ids included it
      std::vector<std::int64_t> Ids;
    };
    BoundarySmoother* Self;
    const IdType* Connectivity;
    std::vector<NeighbourId>* Chunks;
    std::uint8_t* Tips; // per point: 1 for an interior-layer point with one interior neighbour
    void operator()(Scratch& scratch, std::int64_t begin, std::int64_t end) const
    {
      BoundarySmoother& self = *this->Self;
      scratch.Stamps.resize(static_cast<std::size_t>(self.NumberOfPoints), -1);
      for (std::int64_t chunk = begin; chunk < end; ++chunk)
      {
        std::vector<NeighbourId>& out = this->Chunks[chunk];
        const std::int64_t last = std::min(self.NumberOfPoints, (chunk + 1) * EdgeChunk);
        for (std::int64_t p = chunk * EdgeChunk; p < last; ++p)
        {
          if (self.Roles[p] != InteriorLayer)
          {
            continue;
          }
          scratch.Ids.clear();
          scratch.Stamps[p] = p;
          for (std::int64_t k = self.Incidence.Offsets[p]; k < self.Incidence.Offsets[p + 1]; ++k)
          {
            const IdType* ids = this->Connectivity + self.Incidence.Cells[k] * Corners;
            for (int v = 0; v <= Dim; ++v)
            {
              const auto id = static_cast<std::int64_t>(ids[v]);
              if (scratch.Stamps[id] != p)
              {
                scratch.Stamps[id] = p;
                scratch.Ids.push_back(id);
              }
            }
          }
          std::sort(scratch.Ids.begin(), scratch.Ids.end());
          out.insert(out.end(), scratch.Ids.begin(), scratch.Ids.end());
          self.EdgeOffsets[p + 1] = static_cast<std::int64_t>(scratch.Ids.size());
          if (self.Options.SmallPartPoints > 0)
          {
            const auto interior = std::count_if(scratch.Ids.begin(), scratch.Ids.end(),
              [&self](std::int64_t id)
              { return self.Roles[id] == InteriorLayer || self.Roles[id] == Other; });
            this->Tips[p] = interior <= 1;
          }
        }
      }
    }
  };
  std::vector<std::uint8_t> tips(
    options.SmallPartPoints > 0 ? static_cast<std::size_t>(numberOfPoints) : std::size_t{ 0 }, 0);
  EdgeKernel edges{ this, connectivity, chunkNeighbours.data(), tips.data() };
  executor.For(0, edgeChunks, 1, edges);
  JoinRows(chunkNeighbours, this->EdgeOffsets, this->EdgeNeighbours);
  if (this->StopAgreed(executor))
  {
    return Status::Aborted();
  }

  if (options.SmallPartPoints > 0)
  {
    this->KeepSmallParts(connectivity, tips);
    if (options.Exchange)
    {
      this->ShareRoles(); // the held points' kept roles are their movers'
    }
  }

  // The movable points of each step, in coloured blocks.
  PointBlocks surfaceBlocks, interiorBlocks;
  {
    std::vector<std::int64_t> surfacePoints, interiorPoints;
    for (std::int64_t p = 0; p < numberOfPoints; ++p)
    {
      const std::uint8_t role = this->Roles[p];
      this->Stats.FixedPoints += role == Fixed;
      if ((role == Surface || role == InteriorLayer) &&
        !(options.Exchange && options.HeldPoints[p]))
      {
        (role == Surface ? surfacePoints : interiorPoints).push_back(p);
      }
    }
    this->Stats.SurfacePoints = static_cast<std::int64_t>(surfacePoints.size());
    this->Stats.InteriorLayerPoints = static_cast<std::int64_t>(interiorPoints.size());
    this->MakeBlocks(connectivity, std::move(surfacePoints), surfaceBlocks, executor);
    this->MakeBlocks(connectivity, std::move(interiorPoints), interiorBlocks, executor);
    this->Stats.NumberOfColours =
      static_cast<int>(std::max(surfaceBlocks.ByColour.size(), interiorBlocks.ByColour.size()));
    this->Stats.RootCellBlocks = options.CellRootColours != nullptr;
  }
  if (this->StopAgreed(executor))
  {
    return Status::Aborted();
  }
  executor.ReportProgress(0.1);

  // The iterations.
  this->Original.resize(options.MaxDisplacement > 0.0
      ? static_cast<std::size_t>(numberOfPoints * Dim)
      : std::size_t{ 0 });
  this->Moved.assign(static_cast<std::size_t>(numberOfPoints), 0);
  this->Targets.resize(static_cast<std::size_t>(numberOfPoints * Dim));
  struct CopyKernel
  {
    using Scratch = NoScratch;
    BoundarySmoother* Self;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      BoundarySmoother& self = *this->Self;
      if (!self.Original.empty())
      {
        std::copy(
          self.Points + begin * Dim, self.Points + end * Dim, self.Original.data() + begin * Dim);
      }
      std::copy(
        self.Points + begin * Dim, self.Points + end * Dim, self.Targets.data() + begin * Dim);
    }
  };
  CopyKernel copies{ this };
  executor.For(0, numberOfPoints, 1 << 14, copies);
  if (this->StopAgreed(executor))
  {
    return Status::Aborted(); // the copies may be incomplete
  }
  const double lambda = options.RelaxationFactor;
  const double mu = TaubinMu(lambda, options.PassBand);
  constexpr bool project = !std::is_same<std::decay_t<Projector>, NoProjection>::value;
  this->Exchanging = options.Exchange != nullptr;
  for (int iteration = 0; iteration < options.NumberOfIterations; ++iteration)
  {
    const bool taubin = options.Method == SmoothingMethod::Taubin;
    status = this->Step(
      surfaceBlocks, true, lambda, taubin ? mu : 0.0, connectivity, projector, project, executor);
    const bool relax = (iteration + 1) % options.InteriorRelaxationInterval == 0 ||
      iteration + 1 == options.NumberOfIterations;
    if (status.IsOk() && options.NumberOfInteriorLayers > 0 && relax &&
      (options.Exchange || !interiorBlocks.Points.empty()))
    {
      status =
        this->Step(interiorBlocks, false, lambda, 0.0, connectivity, projector, false, executor);
      ++this->Stats.InteriorRelaxations;
    }
    if (!status.IsOk())
    {
      return status;
    }
    executor.ReportProgress(0.1 + 0.8 * (iteration + 1) / options.NumberOfIterations);
  }
  if (!this->Stats.TargetVolumes.empty())
  {
    status = this->RestoreVolumes(surfaceBlocks, connectivity, materials, projector, executor);
    if (!status.IsOk())
    {
      return status;
    }
  }
  status = this->Improve(connectivity, materials, projector, project, executor);
  if (!status.IsOk())
  {
    return status;
  }
  this->Exchanging = false;
  executor.ReportProgress(0.95);

  // What the moves needed goes before the final measure needs its determinants again.
  UninitializedVector<double>().swap(this->Targets);
  UninitializedVector<double>().swap(this->Composed);
  UninitializedVector<double>().swap(this->Original);
  std::vector<std::int64_t>().swap(this->EdgeOffsets);
  std::vector<NeighbourId>().swap(this->EdgeNeighbours);
  this->Determinants.resize(static_cast<std::size_t>(cells));
  measure.First = false;
  executor.For(0, cells, 4096, measure);
  if (this->StopAgreed(executor))
  {
    return Status::Aborted();
  }
  summarize(this->Stats.WorstConditionAfter, this->Stats.MinDihedralAfter, this->Stats.VolumeAfter);
  UninitializedVector<double>().swap(this->Determinants);
  this->Stats.MovedPoints = std::count(this->Moved.begin(), this->Moved.end(), std::uint8_t{ 1 });
  this->Stats.AcceptedMoves = this->Accepted;
  this->Stats.ReducedMoves = this->Reduced;
  this->Stats.RejectedMoves = this->Rejected;
  std::vector<std::uint8_t>().swap(this->Moved);
  executor.ReportProgress(1.0);
  return Status::Ok();
}

template <int Dim>
template <class IdType, class Executor>
void BoundarySmoother<Dim>::MakeBlocks(const IdType* connectivity, std::vector<std::int64_t> points,
  PointBlocks& blocks, Executor& executor) const
{
  if (this->Options.CellRootColours)
  {
    this->MakeRootBlocks(connectivity, std::move(points), blocks, executor);
    return;
  }
  constexpr std::int64_t Corners = Dim + 1;
  const auto count = static_cast<std::int64_t>(points.size());
  const std::int64_t numberOfBlocks = (count + BlockSize - 1) / BlockSize;
  blocks.Offsets.resize(static_cast<std::size_t>(numberOfBlocks) + 1);
  for (std::int64_t b = 0; b <= numberOfBlocks; ++b)
  {
    blocks.Offsets[b] = std::min(b * BlockSize, count);
  }
  std::vector<std::int32_t> blockOf(static_cast<std::size_t>(this->NumberOfPoints), -1);
  for (std::int64_t i = 0; i < count; ++i)
  {
    blockOf[points[i]] = static_cast<std::int32_t>(i / BlockSize);
  }
  blocks.Points = std::move(points);
  // The blocks that share a cell with each block, in parallel.
  std::vector<std::vector<std::int32_t>> neighbours(static_cast<std::size_t>(numberOfBlocks));
  struct NeighbourKernel
  {
    struct Scratch
    {
      std::vector<std::int64_t> Stamps; // per block: the last block whose list included it
    };
    const BoundarySmoother* Self;
    const IdType* Connectivity;
    const PointBlocks* Blocks;
    const std::int32_t* BlockOf;
    std::vector<std::int32_t>* Neighbours;
    std::int64_t NumberOfBlocks;
    void operator()(Scratch& scratch, std::int64_t begin, std::int64_t end) const
    {
      const BoundarySmoother& self = *this->Self;
      scratch.Stamps.resize(static_cast<std::size_t>(this->NumberOfBlocks), -1);
      for (std::int64_t b = begin; b < end; ++b)
      {
        std::vector<std::int32_t>& around = this->Neighbours[b];
        scratch.Stamps[b] = b;
        for (std::int64_t i = this->Blocks->Offsets[b]; i < this->Blocks->Offsets[b + 1]; ++i)
        {
          const std::int64_t p = this->Blocks->Points[i];
          for (std::int64_t k = self.Incidence.Offsets[p]; k < self.Incidence.Offsets[p + 1]; ++k)
          {
            const IdType* ids = this->Connectivity + self.Incidence.Cells[k] * Corners;
            for (int v = 0; v <= Dim; ++v)
            {
              const std::int32_t other = this->BlockOf[static_cast<std::int64_t>(ids[v])];
              if (other >= 0 && scratch.Stamps[other] != b)
              {
                scratch.Stamps[other] = b;
                around.push_back(other);
              }
            }
          }
        }
        std::sort(around.begin(), around.end());
      }
    }
  };
  NeighbourKernel kernel{ this, connectivity, &blocks, blockOf.data(), neighbours.data(),
    numberOfBlocks };
  executor.For(0, numberOfBlocks, 16, kernel);
  // Greedy colouring in block order.
  std::vector<std::int64_t> order(static_cast<std::size_t>(numberOfBlocks));
  std::iota(order.begin(), order.end(), std::int64_t{ 0 });
  std::vector<std::int32_t> colours(static_cast<std::size_t>(numberOfBlocks), -1);
  blocks.ByColour = GreedyColouring(order, colours,
    [&](std::int64_t b, auto&& visit)
    {
      for (const std::int32_t other : neighbours[b])
      {
        visit(other);
      }
    });
}

template <int Dim>
void BoundarySmoother<Dim>::ShareRoles()
{
  std::vector<double> roles(this->Roles.begin(), this->Roles.end());
  this->Options.Exchange->Share(roles.data(), 1, -1, nullptr);
  for (std::int64_t p = 0; p < this->NumberOfPoints; ++p)
  {
    if (this->Options.HeldPoints[p])
    {
      this->Roles[p] = static_cast<std::uint8_t>(roles[p]);
    }
  }
}

template <int Dim>
template <class IdType>
void BoundarySmoother<Dim>::MeasureAround(
  const IdType* connectivity, const std::vector<std::int64_t>& changed)
{
  constexpr std::int64_t Corners = Dim + 1;
  // Measured in full: a cached slack assumed the old corners. The moves decide by the measure
  // wherever a slack does not suffice, so a full measure decides as the whole mesh's cache does.
  for (const std::int64_t p : changed)
  {
    for (std::int64_t k = this->Incidence.Offsets[p]; k < this->Incidence.Offsets[p + 1]; ++k)
    {
      const std::int64_t cell = this->Incidence.Cells[k];
      this->Shapes[cell] =
        this->MeasureCell(connectivity + cell * Corners, cell, -1, nullptr, nullptr);
    }
  }
}

template <int Dim>
template <class IdType, class Executor>
void BoundarySmoother<Dim>::MakeRootBlocks(const IdType* connectivity,
  std::vector<std::int64_t> points, PointBlocks& blocks, Executor& executor) const
{
  constexpr std::int64_t Corners = Dim + 1;
  const auto count = static_cast<std::int64_t>(points.size());
  // Each point's colour (the smallest of its cells'), and its position among `points`.
  std::vector<std::int32_t> positions(static_cast<std::size_t>(this->NumberOfPoints), -1);
  std::vector<std::uint8_t> colours(points.size());
  // Joined in parallel: every link goes from the larger root to the smaller, so each block's
  // root ends as its first position, whatever the threads' interleaving.
  std::vector<std::atomic<std::int32_t>> parents(points.size());
  struct ColourKernel
  {
    using Scratch = NoScratch;
    const BoundarySmoother* Self;
    const std::vector<std::int64_t>* Points;
    std::int32_t* Positions;
    std::uint8_t* Colours;
    std::atomic<std::int32_t>* Parents;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      const BoundarySmoother& self = *this->Self;
      for (std::int64_t i = begin; i < end; ++i)
      {
        const std::int64_t p = (*this->Points)[i];
        this->Positions[p] = static_cast<std::int32_t>(i);
        std::uint8_t colour = std::numeric_limits<std::uint8_t>::max();
        for (std::int64_t k = self.Incidence.Offsets[p]; k < self.Incidence.Offsets[p + 1]; ++k)
        {
          colour = std::min(colour, self.Options.CellRootColours[self.Incidence.Cells[k]]);
        }
        this->Colours[i] = colour;
        this->Parents[i].store(static_cast<std::int32_t>(i), std::memory_order_relaxed);
      }
    }
  };
  ColourKernel colouring{ this, &points, positions.data(), colours.data(), parents.data() };
  executor.For(0, count, 4096, colouring);
  struct JoinKernel
  {
    using Scratch = NoScratch;
    const BoundarySmoother* Self;
    const IdType* Connectivity;
    const std::vector<std::int64_t>* Points;
    const std::int32_t* Positions;
    const std::uint8_t* Colours;
    std::atomic<std::int32_t>* Parents;
    // With path halving: a point's parent becomes its grandparent, still an ancestor whatever
    // the other threads do (only roots are linked, each under a smaller one).
    std::int32_t Find(std::int32_t i) const
    {
      for (;;)
      {
        const std::int32_t parent = this->Parents[i].load(std::memory_order_relaxed);
        if (parent == i)
        {
          return i;
        }
        const std::int32_t grandparent = this->Parents[parent].load(std::memory_order_relaxed);
        if (grandparent != parent)
        {
          this->Parents[i].store(grandparent, std::memory_order_relaxed);
        }
        i = grandparent;
      }
    }
    void Join(std::int32_t a, std::int32_t b) const
    {
      for (;;)
      {
        a = this->Find(a);
        b = this->Find(b);
        if (a == b)
        {
          return;
        }
        if (a < b)
        {
          std::swap(a, b);
        }
        std::int32_t expected = a;
        if (this->Parents[a].compare_exchange_weak(expected, b, std::memory_order_relaxed))
        {
          return;
        }
      }
    }
    // Per cell, its corners of one colour (a pass over the cells rather than over each point's
    // cells: a quarter of the visits).
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t c = begin; c < end; ++c)
      {
        const IdType* ids = this->Connectivity + c * Corners;
        std::int32_t corners[Dim + 1];
        int count = 0;
        for (int v = 0; v <= Dim; ++v)
        {
          const std::int32_t j = this->Positions[static_cast<std::int64_t>(ids[v])];
          if (j < 0)
          {
            continue;
          }
          int same = 0;
          while (same < count && this->Colours[corners[same]] != this->Colours[j])
          {
            ++same;
          }
          if (same < count)
          {
            this->Join(corners[same], j);
          }
          else
          {
            corners[count++] = j;
          }
        }
      }
    }
  };
  JoinKernel join{ this, connectivity, &points, positions.data(), colours.data(), parents.data() };
  executor.For(0, this->NumberOfCells, 8192, join);
  // Blocks in the order of their first points, each block's points in ascending order.
  std::vector<std::int32_t> blockOf(points.size());
  std::int64_t numberOfBlocks = 0;
  for (std::int64_t i = 0; i < count; ++i)
  {
    const std::int32_t root = join.Find(static_cast<std::int32_t>(i));
    blockOf[i] = root == i ? static_cast<std::int32_t>(numberOfBlocks++) : blockOf[root];
  }
  blocks.Offsets.assign(static_cast<std::size_t>(numberOfBlocks) + 1, 0);
  for (std::int64_t i = 0; i < count; ++i)
  {
    ++blocks.Offsets[blockOf[i] + 1];
  }
  blocks.ByColour.assign(static_cast<std::size_t>(NumberOfRootColours), {});
  for (std::int64_t b = 0; b < numberOfBlocks; ++b)
  {
    blocks.Offsets[b + 1] += blocks.Offsets[b];
  }
  blocks.Points.resize(points.size());
  std::vector<std::int64_t> next(blocks.Offsets.begin(), blocks.Offsets.end() - 1);
  for (std::int64_t i = 0; i < count; ++i)
  {
    const std::int32_t block = blockOf[i];
    if (next[block] == blocks.Offsets[block])
    {
      blocks.ByColour[colours[i]].push_back(block);
    }
    blocks.Points[next[block]++] = points[i];
  }
}

template <int Dim>
template <class IdType, class Projector, class Executor>
Status BoundarySmoother<Dim>::Step(const PointBlocks& blocks, bool surface, double lambda,
  double mu, const IdType* connectivity, Projector& projector, bool project, Executor& executor,
  bool given)
{
  constexpr std::int64_t Corners = Dim + 1;
  // Jacobi: every target from the positions before this step (Source), into Destination.
  struct TargetKernel
  {
    using Scratch = NoScratch;
    BoundarySmoother* Self;
    const std::vector<std::int64_t>* Points;
    const IdType* Connectivity;
    bool Surface;
    double Factor;
    const double* Source;
    double* Destination;
    bool ByPosition; // Destination by the point's position in Points, else by its id
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      const double* x = this->Source;
      for (std::int64_t i = begin; i < end; ++i)
      {
        const std::int64_t p = (*this->Points)[i];
        const NeighbourId* neighbours = nullptr;
        std::int64_t count = 0;
        if (this->Surface)
        {
          neighbours = this->Self->SurfaceNeighbours.data() + this->Self->SurfaceOffsets[p];
          count = this->Self->SurfaceOffsets[p + 1] - this->Self->SurfaceOffsets[p];
        }
        else
        {
          neighbours = this->Self->EdgeNeighbours.data() + this->Self->EdgeOffsets[p];
          count = this->Self->EdgeOffsets[p + 1] - this->Self->EdgeOffsets[p];
        }
        double* target = this->Destination + (this->ByPosition ? i : p) * Dim;
        if (count == 0)
        {
          for (int c = 0; c < Dim; ++c)
          {
            target[c] = x[p * Dim + c];
          }
          continue;
        }
        // Each neighbour's coordinates read once (the sums add in the same order as per axis).
        double sum[Dim] = {};
        for (std::int64_t k = 0; k < count; ++k)
        {
          const double* neighbour = x + neighbours[k] * Dim;
          for (int c = 0; c < Dim; ++c)
          {
            sum[c] += neighbour[c];
          }
        }
        for (int c = 0; c < Dim; ++c)
        {
          target[c] = x[p * Dim + c] + this->Factor * (sum[c] / count - x[p * Dim + c]);
        }
      }
    }
  };
  // Validated moves of the points of one colour.
  struct MoveKernel
  {
    using Scratch = typename BoundarySmoother::Scratch;
    BoundarySmoother* Self;
    const PointBlocks* Blocks;
    const std::vector<std::int64_t>* Colour; // its blocks
    const IdType* Connectivity;
    Projector* Project;
    bool UseProjector;
    const double* Targets;
    bool TargetsByPosition; // Targets by the point's position in the blocks, else by its id
    Executor* Exec;
    // The outcomes of Move besides the accepted attempt (0: in full, 1: half, 2: a quarter).
    enum : int
    {
      Rejected = 3,
      AtTarget = 4
    };

    // Requests the next point's cell shapes and corner ids while this one moves: the moves
    // wait mostly on these loads (AAL, 116 labels: smooth stage 15.97 -> 15.67 s, median of 3
    // interleaved pairs, the same points bit for bit).
    void Prefetch(std::int64_t p) const
    {
#if defined(__GNUC__)
      const BoundarySmoother& self = *this->Self;
      for (std::int64_t k = self.Incidence.Offsets[p]; k < self.Incidence.Offsets[p + 1]; ++k)
      {
        const std::int64_t cell = self.Incidence.Cells[k];
        __builtin_prefetch(self.Shapes.data() + cell);
        __builtin_prefetch(this->Connectivity + cell * Corners);
      }
#else
      (void)p;
#endif
    }

    // Moves point p toward its target, validated: in full, else half, else a quarter of it.
    int Move(Scratch& scratch, std::int64_t p, const double* target) const
    {
      BoundarySmoother& self = *this->Self;
      const BoundarySmoothOptions& options = self.Options;
      double* x = self.Points + p * Dim;
      if (std::equal(x, x + Dim, target))
      {
        return AtTarget;
      }
      const std::int64_t first = self.Incidence.Offsets[p], last = self.Incidence.Offsets[p + 1];
      // One pass over the cells per attempt: each cell's new shape is written in place and its
      // old one kept in the scratch, to be put back if the attempt fails (about 1 in 100).
      // Written by index: push_back was not inlined here and took 4 % of the 116-label run.
      if (scratch.Shapes.size() < static_cast<std::size_t>(last - first))
      {
        scratch.Shapes.resize(static_cast<std::size_t>(last - first));
      }
      Shape* saved = scratch.Shapes.data();
      // The bounds of a measured cell: the worst of the cells before the move, if worse than the
      // smoother's. Only a cell found not surely within the bounds is measured (brain mask: 1
      // visit in 800), so they are found when first needed, from the old shapes: saved up to
      // cell `upTo`, in place after.
      double conditionLimit = 0.0, cosineLimit = 0.0;
      bool limitsKnown = false;
      auto findLimits = [&](std::int64_t upTo)
      {
        double oldWorst = 0.0, oldLargestCosine = -1.0;
        for (std::int64_t k = first; k < last; ++k)
        {
          const Shape& old = k <= upTo ? saved[k - first] : self.Shapes[self.Incidence.Cells[k]];
          oldWorst = std::max(oldWorst, old.Condition);
          oldLargestCosine = std::max(oldLargestCosine, old.Cosine);
        }
        conditionLimit = std::max(oldWorst, self.ConditionBound);
        cosineLimit = std::max(oldLargestCosine, self.CosineBound);
        limitsKnown = true;
      };
      for (int attempt = 0; attempt < 3; ++attempt)
      {
        const double fraction = attempt == 0 ? 1.0 : attempt == 1 ? 0.5 : 0.25;
        double tentative[Dim];
        for (int c = 0; c < Dim; ++c)
        {
          tentative[c] = x[c] + fraction * (target[c] - x[c]);
        }
        if (options.MaxDisplacement > 0.0)
        {
          const double* original = self.Original.data() + p * Dim;
          double squared = 0.0;
          for (int c = 0; c < Dim; ++c)
          {
            squared += (tentative[c] - original[c]) * (tentative[c] - original[c]);
          }
          if (squared > options.MaxDisplacement * options.MaxDisplacement)
          {
            const double scale = options.MaxDisplacement / std::sqrt(squared);
            for (int c = 0; c < Dim; ++c)
            {
              tentative[c] = original[c] + scale * (tentative[c] - original[c]);
            }
          }
        }
        if (this->UseProjector && !(*this->Project)(p, static_cast<double*>(tentative)))
        {
          continue;
        }
        if (options.SinglePrecision)
        {
          for (int c = 0; c < Dim; ++c)
          {
            tentative[c] = static_cast<double>(static_cast<float>(tentative[c]));
          }
        }
        if (std::equal(x, x + Dim, static_cast<const double*>(tentative)))
        {
          continue;
        }
        double length = 0.0;
        for (int c = 0; c < Dim; ++c)
        {
          length += (tentative[c] - x[c]) * (tentative[c] - x[c]);
        }
        length = std::sqrt(length) * (1.0 + 1e-12);
        std::int64_t k = first;
        for (; k < last; ++k)
        {
          Shape& shape = self.Shapes[self.Incidence.Cells[k]];
          saved[k - first] = shape;
          // Most cells are well within the bounds, which a test without roots or divisions
          // shows, and stay so while the moves of their corners fit in its slack (Shape).
          const double slack = -shape.Condition;
          if (slack >= length)
          {
            shape = { -(slack - length), -1.0 };
            continue;
          }
          const std::int64_t cell = self.Incidence.Cells[k];
          const double* corners[Dim + 1];
          self.CellCorners(this->Connectivity + cell * Corners, cell, p, tentative, corners);
          const double newSlack = SimplexSlack<Dim>(corners, self.ConditionBound, self.CosineBound);
          if (newSlack >= 0.0)
          {
            shape = { -newSlack, -1.0 };
            continue;
          }
          if (!limitsKnown)
          {
            findLimits(k);
          }
          const SimplexCosines measured = MeasureSimplexCosines<Dim>(corners);
          if (!(measured.Determinant > 0.0 && measured.Condition <= conditionLimit &&
                measured.LargestDihedralCosine <= cosineLimit))
          {
            break;
          }
          shape = { measured.Condition, measured.LargestDihedralCosine };
        }
        if (k < last)
        {
          for (std::int64_t written = first; written < k; ++written)
          {
            self.Shapes[self.Incidence.Cells[written]] = saved[written - first];
          }
          continue;
        }
        for (int c = 0; c < Dim; ++c)
        {
          self.Moved[p] |= x[c] != tentative[c];
          x[c] = tentative[c];
        }
        return attempt;
      }
      return Rejected;
    }

    void operator()(Scratch& scratch, std::int64_t begin, std::int64_t end) const
    {
      if (this->Exec->ShouldAbort())
      {
        return;
      }
      std::int64_t accepted = 0, reduced = 0, rejected = 0;
      const PointBlocks& blocks = *this->Blocks;
      for (std::int64_t b = begin; b < end; ++b)
      {
        const std::int64_t block = (*this->Colour)[b];
        const std::int64_t blockEnd = blocks.Offsets[block + 1];
        for (std::int64_t i = blocks.Offsets[block]; i < blockEnd; ++i)
        {
          if (i + 1 < blockEnd)
          {
            this->Prefetch(blocks.Points[i + 1]);
          }
          const std::int64_t p = blocks.Points[i];
          const int outcome =
            this->Move(scratch, p, this->Targets + (this->TargetsByPosition ? i : p) * Dim);
          accepted += outcome == 0;
          reduced += outcome == 1 || outcome == 2;
          rejected += outcome == Rejected;
        }
      }
      BoundarySmoother& self = *this->Self;
      self.Accepted += accepted;
      self.Reduced += reduced;
      self.Rejected += rejected;
    }
  };

  const std::vector<std::int64_t>& all = blocks.Points;
  // Points outside the step keep Targets equal to their position (they never move or were
  // reset below), so the mu pass reads the lambda targets of neighbours in the step and the
  // positions of the others.
  TargetKernel targets{ this, &all, connectivity, surface, lambda, this->Points,
    this->Targets.data(), false };
  if (!given)
  {
    executor.For(0, static_cast<std::int64_t>(all.size()), 1024, targets);
  }
  const double* finalTargets = this->Targets.data();
  const bool composedTargets = mu != 0.0 && !given;
  if (composedTargets && this->Exchanging)
  {
    // The mu step reads the lambda targets of the neighbours, also of those other pieces move.
    this->Options.Exchange->Share(this->Targets.data(), Dim, -1, nullptr);
  }
  if (composedTargets)
  {
    this->Composed.resize(all.size() * Dim); // once: the surface steps have the same points
    TargetKernel composed{ this, &all, connectivity, surface, mu, this->Targets.data(),
      this->Composed.data(), true };
    executor.For(0, static_cast<std::int64_t>(all.size()), 1024, composed);
    finalTargets = this->Composed.data();
  }
  for (const auto& colour : blocks.ByColour)
  {
    if (this->StopAgreed(executor))
    {
      return Status::Aborted();
    }
    MoveKernel move{ this, &blocks, &colour, connectivity, &projector, project && surface,
      finalTargets, composedTargets, &executor };
    executor.For(0, static_cast<std::int64_t>(colour.size()), 1, move);
    if (this->Exchanging)
    {
      // The points other pieces moved in this colour, before the next colour's moves read them.
      std::vector<std::int64_t> changed;
      this->Options.Exchange->Share(
        this->Points, Dim, static_cast<int>(&colour - blocks.ByColour.data()), &changed);
      this->MeasureAround(connectivity, changed);
    }
  }
  // Back to "the target of a point outside a step is its position" for the next step (in
  // parallel: the points of a step are scattered, and this loop was most of a step's serial
  // time).
  struct ResetKernel
  {
    using Scratch = NoScratch;
    BoundarySmoother* Self;
    const std::vector<std::int64_t>* All;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t i = begin; i < end; ++i)
      {
        const std::int64_t p = (*this->All)[i];
        std::copy(this->Self->Points + p * Dim, this->Self->Points + (p + 1) * Dim,
          this->Self->Targets.data() + p * Dim);
      }
    }
  };
  ResetKernel reset{ this, &all };
  executor.For(0, static_cast<std::int64_t>(all.size()), 1 << 14, reset);
  if (this->Exchanging && composedTargets)
  {
    for (std::int64_t p = 0; p < this->NumberOfPoints; ++p)
    {
      if (this->Options.HeldPoints[p])
      {
        std::copy(
          this->Points + p * Dim, this->Points + (p + 1) * Dim, this->Targets.data() + p * Dim);
      }
    }
  }
  return this->StopAgreed(executor) ? Status::Aborted() : Status::Ok();
}

template <int Dim>
template <class IdType, class MaterialType>
bool BoundarySmoother<Dim>::VolumeGradients(const IdType* connectivity,
  const MaterialType* materials, std::int64_t p, std::vector<MaterialGradient>& gradients,
  bool& outer, double& scale) const
{
  constexpr int Corners = Dim + 1;
  gradients.clear();
  outer = this->OnOuterBoundary[p] != 0;
  scale = 0.0;
  for (std::int64_t k = this->Incidence.Offsets[p]; k < this->Incidence.Offsets[p + 1]; ++k)
  {
    const std::int64_t cell = this->Incidence.Cells[k];
    const IdType* ids = connectivity + cell * Corners;
    if (this->Signs[cell] == 0)
    {
      return false; // a degenerate input cell: no move of its points is ever validated
    }
    const std::int64_t material = materials ? static_cast<std::int64_t>(materials[cell]) : 0;
    auto found = std::find_if(gradients.begin(), gradients.end(),
      [&](const MaterialGradient& g) { return g.Material == material; });
    if (found == gradients.end())
    {
      gradients.push_back(MaterialGradient{ material, {} });
      found = gradients.end() - 1;
    }
    double cellGradient[Dim];
    this->CornerGradient(ids, cell, p, cellGradient);
    for (int axis = 0; axis < Dim; ++axis)
    {
      found->Vector[axis] += cellGradient[axis];
      scale += std::abs(cellGradient[axis]);
    }
  }
  return true;
}

template <int Dim>
template <class IdType, class MaterialType>
int BoundarySmoother<Dim>::FreeDirections(const IdType* connectivity, const MaterialType* materials,
  std::int64_t p, bool offInterface, double (&directions)[Dim][Dim]) const
{
  std::vector<MaterialGradient> gradients;
  bool outer = false;
  double scale = 0.0;
  if (!this->VolumeGradients(connectivity, materials, p, gradients, outer, scale))
  {
    return 0;
  }
  if (offInterface && gradients.size() + (outer ? 1 : 0) == 2)
  {
    for (int q = 0; q < Dim; ++q)
    {
      for (int c = 0; c < Dim; ++c)
      {
        directions[q][c] = q == c ? 1.0 : 0.0;
      }
    }
    return Dim;
  }
  double total[Dim] = {};
  for (const MaterialGradient& g : gradients)
  {
    for (int c = 0; c < Dim; ++c)
    {
      total[c] += g.Vector[c];
    }
  }
  // Constraints: each material's volume, and the body's on the outer boundary. A material set of
  // m members (the outside counting as one) gives min(Dim, m - 1) independent constraints; when
  // the gradients give fewer (a folded interface) the point does not move.
  std::vector<const double*> constraints;
  for (const MaterialGradient& g : gradients)
  {
    constraints.push_back(g.Vector);
  }
  if (outer)
  {
    constraints.push_back(total);
  }
  const int expected = std::min<int>(Dim, static_cast<int>(gradients.size()) + (outer ? 1 : 0) - 1);
  double basis[Dim][Dim];
  int rank = 0;
  auto orthogonalize = [&](const double* v, double(&r)[Dim], int count, double(&against)[Dim][Dim])
  {
    std::copy(v, v + Dim, r);
    for (int q = 0; q < count; ++q)
    {
      double dot = 0.0;
      for (int c = 0; c < Dim; ++c)
      {
        dot += against[q][c] * r[c];
      }
      for (int c = 0; c < Dim; ++c)
      {
        r[c] -= dot * against[q][c];
      }
    }
    double norm = 0.0;
    for (int c = 0; c < Dim; ++c)
    {
      norm += r[c] * r[c];
    }
    return std::sqrt(norm);
  };
  for (const double* v : constraints)
  {
    double r[Dim];
    // Twice, so that the residual is orthogonal to rounding.
    double norm = orthogonalize(v, r, rank, basis);
    norm = orthogonalize(r, r, rank, basis);
    if (rank < Dim && norm > 1e-6 * scale)
    {
      for (int c = 0; c < Dim; ++c)
      {
        basis[rank][c] = r[c] / norm;
      }
      ++rank;
    }
  }
  if (rank < expected)
  {
    return 0;
  }
  // The complement: the axes with the constraints and earlier free directions removed.
  double all[Dim][Dim];
  for (int q = 0; q < rank; ++q)
  {
    std::copy(basis[q], basis[q] + Dim, all[q]);
  }
  int count = rank;
  for (int axis = 0; axis < Dim && count < Dim; ++axis)
  {
    double e[Dim] = {};
    e[axis] = 1.0;
    double r[Dim];
    double norm = orthogonalize(e, r, count, all);
    norm = orthogonalize(r, r, count, all);
    if (norm > 0.3)
    {
      for (int c = 0; c < Dim; ++c)
      {
        all[count][c] = r[c] / norm;
      }
      ++count;
    }
  }
  // Components at rounding level are made exact zeros, so that a point on an axis-aligned
  // interface keeps that coordinate bit for bit.
  for (int q = rank; q < count; ++q)
  {
    double norm = 0.0;
    for (int c = 0; c < Dim; ++c)
    {
      const double component = std::abs(all[q][c]) < 1e-12 ? 0.0 : all[q][c];
      directions[q - rank][c] = component;
      norm += component * component;
    }
    for (int c = 0; c < Dim; ++c)
    {
      directions[q - rank][c] /= std::sqrt(norm);
    }
  }
  return count - rank;
}

template <int Dim>
template <class IdType, class MaterialType, class Projector, class Executor>
Status BoundarySmoother<Dim>::Improve(const IdType* connectivity, const MaterialType* materials,
  Projector& projector, bool project, Executor& executor)
{
  const BoundarySmoothOptions& options = this->Options;
  if (Dim < 2 || Dim > 3 || options.NumberOfImprovementSweeps == 0)
  {
    return Status::Ok();
  }
  constexpr std::int64_t Corners = Dim + 1;
  // Pieces move the candidates they own and share the positions after every colour.
  SmoothingExchange* exchange = this->Exchanging ? options.Exchange : nullptr;
  auto isBad = [&](const Shape& shape)
  { return shape.Condition > options.MaxConditionNumber || shape.Cosine > this->OptionCosine; };
  // How far a cell is from the bounds: its worse ratio (1 at the bounds); an inverted cell is
  // infinitely bad.
  auto badness = [&](const SimplexCosines& shape)
  {
    if (!(shape.Determinant > 0.0))
    {
      return std::numeric_limits<double>::infinity();
    }
    double ratio = shape.Condition / options.MaxConditionNumber;
    if (options.MinDihedralAngle > 0.0)
    {
      const double angle = DihedralDegrees(shape.LargestDihedralCosine);
      ratio = std::max(ratio,
        angle > 0.0 ? options.MinDihedralAngle / angle : std::numeric_limits<double>::infinity());
    }
    return ratio;
  };
  struct ImproveKernel
  {
    using Scratch = typename BoundarySmoother::Scratch;
    BoundarySmoother* Self;
    const std::vector<std::int64_t>* Points;
    const IdType* Connectivity;
    const MaterialType* Materials;
    Projector* Project;
    bool UseProjector;
    const decltype(badness)* Badness;
    Executor* Exec;
    std::atomic<std::int64_t>* Improved;
    bool OffInterface;

    // The incident cells' worst badness with p at y, or infinity when a cell breaks the limits.
    double Evaluate(Scratch& scratch, std::int64_t p, const double* y, double conditionLimit,
      double cosineLimit) const
    {
      BoundarySmoother& self = *this->Self;
      scratch.Shapes.clear();
      double worst = 0.0;
      for (std::int64_t k = self.Incidence.Offsets[p]; k < self.Incidence.Offsets[p + 1]; ++k)
      {
        const std::int64_t cell = self.Incidence.Cells[k];
        const double* corners[Dim + 1];
        self.CellCorners(this->Connectivity + cell * Corners, cell, p, y, corners);
        const SimplexCosines shape = MeasureSimplexCosines<Dim>(corners);
        if (!(shape.Determinant > 0.0) || shape.Condition > conditionLimit ||
          shape.LargestDihedralCosine > cosineLimit)
        {
          return std::numeric_limits<double>::infinity();
        }
        worst = std::max(worst, (*this->Badness)(shape));
        scratch.Shapes.push_back({ shape.Condition, shape.LargestDihedralCosine });
      }
      return worst;
    }

    void operator()(Scratch& scratch, std::int64_t begin, std::int64_t end) const
    {
      BoundarySmoother& self = *this->Self;
      const BoundarySmoothOptions& options = self.Options;
      std::int64_t improved = 0;
      for (std::int64_t i = begin; i < end && !this->Exec->ShouldAbort(); ++i)
      {
        const std::int64_t p = (*this->Points)[i];
        double directions[Dim][Dim];
        const int count = self.FreeDirections(
          this->Connectivity, this->Materials, p, this->OffInterface, directions);
        if (count == 0)
        {
          continue;
        }
        double* x = self.Points + p * Dim;
        const std::int64_t first = self.Incidence.Offsets[p], last = self.Incidence.Offsets[p + 1];
        double oldWorst = 0.0, oldLargestCosine = -1.0, shortest = 0.0, longest = 0.0;
        for (std::int64_t k = first; k < last; ++k)
        {
          const std::int64_t cell = self.Incidence.Cells[k];
          oldWorst = std::max(oldWorst, self.Shapes[cell].Condition);
          oldLargestCosine = std::max(oldLargestCosine, self.Shapes[cell].Cosine);
          const IdType* ids = this->Connectivity + cell * Corners;
          for (int v = 0; v <= Dim; ++v)
          {
            const double* q = self.Points + static_cast<std::int64_t>(ids[v]) * Dim;
            double squared = 0.0;
            for (int c = 0; c < Dim; ++c)
            {
              squared += (q[c] - x[c]) * (q[c] - x[c]);
            }
            if (squared > 0.0 && (shortest == 0.0 || squared < shortest))
            {
              shortest = squared;
            }
            longest = std::max(longest, squared);
          }
        }
        shortest = std::sqrt(shortest);
        longest = std::sqrt(longest);
        const double conditionLimit = std::max(oldWorst, self.ConditionBound);
        const double cosineLimit = std::max(oldLargestCosine, self.CosineBound);
        double start[Dim];
        std::copy(x, x + Dim, start);
        double current = this->Evaluate(scratch, p, x, conditionLimit, cosineLimit);
        if (!std::isfinite(current))
        {
          continue; // a cell already outside the limits (a degenerate input cell)
        }
        // Compass search in the free directions, within 0.6 of the longest edge of the start,
        // from steps of a fifth of it down to 1/256 of the shortest: a needle needs its short
        // edge lengthened by more than its own length.
        const double reach = 0.6 * longest;
        double step = 0.2 * longest;
        std::vector<Shape> best;
        bool moved = false;
        // Until every cell around the point is within the bounds (badness at most 1).
        for (int iteration = 0; iteration < 80 && step > shortest / 256.0 && current > 1.0;
             ++iteration)
        {
          double bestBadness = current, bestPosition[Dim] = {};
          // Every combination of -1, 0, 1 times the free directions, normalised: the worst of
          // the cells is a maximum, whose descent often lies between two directions.
          int combinations = 1;
          for (int d = 0; d < count; ++d)
          {
            combinations *= 3;
          }
          for (int combination = 0; combination < combinations; ++combination)
          {
            {
              double move[Dim] = {};
              double length = 0.0;
              for (int d = 0, code = combination; d < count; ++d, code /= 3)
              {
                const int factor = code % 3 - 1;
                for (int c = 0; c < Dim; ++c)
                {
                  move[c] += factor * directions[d][c];
                }
                length += factor * factor;
              }
              if (length == 0.0)
              {
                continue;
              }
              double y[Dim];
              double squared = 0.0, fromOriginal = 0.0;
              for (int c = 0; c < Dim; ++c)
              {
                y[c] = x[c] + step / std::sqrt(length) * move[c];
              }
              if (this->UseProjector &&
                (self.Roles[p] == Surface || self.Roles[p] == KeptSurface) &&
                !(*this->Project)(p, static_cast<double*>(y)))
              {
                continue;
              }
              if (options.SinglePrecision)
              {
                for (int c = 0; c < Dim; ++c)
                {
                  y[c] = static_cast<double>(static_cast<float>(y[c]));
                }
              }
              for (int c = 0; c < Dim; ++c)
              {
                squared += (y[c] - start[c]) * (y[c] - start[c]);
                const double o = self.Original.empty() ? 0.0 : y[c] - self.Original[p * Dim + c];
                fromOriginal += o * o;
              }
              if (squared > reach * reach ||
                (options.MaxDisplacement > 0.0 &&
                  fromOriginal > options.MaxDisplacement * options.MaxDisplacement))
              {
                continue;
              }
              const double value = this->Evaluate(scratch, p, y, conditionLimit, cosineLimit);
              if (value < bestBadness)
              {
                bestBadness = value;
                std::copy(y, y + Dim, bestPosition);
                best = scratch.Shapes;
              }
            }
          }
          if (bestBadness < current)
          {
            current = bestBadness;
            self.Moved[p] |= !std::equal(bestPosition, bestPosition + Dim, x);
            std::copy(bestPosition, bestPosition + Dim, x);
            for (std::int64_t k = first; k < last; ++k)
            {
              self.Shapes[self.Incidence.Cells[k]] = best[k - first];
            }
            moved = true;
          }
          else
          {
            step *= 0.5;
          }
        }
        improved += moved;
      }
      *this->Improved += improved;
    }
  };

  std::vector<std::int32_t> colours(static_cast<std::size_t>(this->NumberOfPoints), -1);
  std::vector<std::int64_t> badCells, candidates;
  bool scanned = false;
  const int phases = options.ImprovementMovesInterfaces ? 2 : 1;
  // Phase 0 keeps the volumes; phase 1 (ImprovementMovesInterfaces) frees interface points.
  for (int phase = 0; phase < phases; ++phase)
  {
    for (int sweep = 0; sweep < options.NumberOfImprovementSweeps; ++sweep)
    {
      // The cells outside the bounds: every cell is scanned (in parallel, each range into its
      // own list) before the first sweep; after a sweep only the cells outside the bounds before
      // it and the cells around its candidates can be, since a move changes only the cells
      // around the moved point (AAL, 116 labels: 16 scans of 7.7 million cells took 0.3 s, most
      // of the improvement, for at most 1,500 candidates).
      if (!scanned)
      {
        constexpr std::int64_t Ranges = 64;
        const std::int64_t rangeCells = (this->NumberOfCells + Ranges - 1) / Ranges;
        std::vector<std::vector<std::int64_t>> rangeBad(static_cast<std::size_t>(Ranges));
        struct ScanKernel
        {
          using Scratch = NoScratch;
          const BoundarySmoother* Self;
          const decltype(isBad)* IsBad;
          std::int64_t RangeCells;
          std::vector<std::int64_t>* Lists;
          void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
          {
            for (std::int64_t r = begin; r < end; ++r)
            {
              const std::int64_t last =
                std::min(this->Self->NumberOfCells, (r + 1) * this->RangeCells);
              for (std::int64_t c = r * this->RangeCells; c < last; ++c)
              {
                if ((*this->IsBad)(this->Self->Shapes[c]))
                {
                  this->Lists[r].push_back(c);
                }
              }
            }
          }
        };
        ScanKernel scan{ this, &isBad, rangeCells, rangeBad.data() };
        executor.For(0, Ranges, 1, scan);
        if (this->StopAgreed(executor))
        {
          return Status::Aborted();
        }
        for (const std::vector<std::int64_t>& list : rangeBad)
        {
          badCells.insert(badCells.end(), list.begin(), list.end());
        }
        scanned = true;
      }
      else
      {
        for (const std::int64_t p : candidates)
        {
          for (std::int64_t k = this->Incidence.Offsets[p]; k < this->Incidence.Offsets[p + 1]; ++k)
          {
            badCells.push_back(static_cast<std::int64_t>(this->Incidence.Cells[k]));
          }
        }
        std::sort(badCells.begin(), badCells.end());
        badCells.erase(std::unique(badCells.begin(), badCells.end()), badCells.end());
        badCells.erase(std::remove_if(badCells.begin(), badCells.end(),
                         [&](std::int64_t c) { return !isBad(this->Shapes[c]); }),
          badCells.end());
      }
      // Their movable points (with an exchange, also those other pieces move: their cells'
      // shapes change).
      candidates.clear();
      for (const std::int64_t c : badCells)
      {
        const IdType* ids = connectivity + c * Corners;
        for (int v = 0; v <= Dim; ++v)
        {
          const auto id = static_cast<std::int64_t>(ids[v]);
          const std::uint8_t role = this->Roles[id];
          if (role == Surface || role == InteriorLayer || role == KeptSurface)
          {
            candidates.push_back(id);
          }
        }
      }
      std::sort(candidates.begin(), candidates.end());
      candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
      if (exchange ? exchange->Maximum(candidates.empty() ? 0.0 : 1.0) == 0.0 : candidates.empty())
      {
        return Status::Ok();
      }
      std::atomic<std::int64_t> improved{ 0 };
      std::vector<std::int64_t> changed; // the held points other pieces moved in this sweep
      if (options.CellRootColours)
      {
        // The root blocks of the candidates, a colour after the other, each block in ascending
        // order: the same moves in a whole mesh and in its pieces (the held candidates are
        // moved by the pieces that own their blocks).
        std::vector<std::int64_t> moving;
        for (const std::int64_t p : candidates)
        {
          if (!(exchange && options.HeldPoints[p]))
          {
            moving.push_back(p);
          }
        }
        PointBlocks blocks;
        this->MakeRootBlocks(connectivity, std::move(moving), blocks, executor);
        ImproveKernel kernel{ this, &blocks.Points, connectivity, materials, &projector, project,
          &badness, &executor, &improved, phase == 1 };
        for (const std::vector<std::int64_t>& colour : blocks.ByColour)
        {
          BlockKernel<ImproveKernel> byBlock{ &kernel, &blocks, &colour };
          executor.For(0, static_cast<std::int64_t>(colour.size()), 1, byBlock);
          if (this->StopAgreed(executor))
          {
            return Status::Aborted();
          }
          if (exchange)
          {
            const std::size_t before = changed.size();
            exchange->Share(
              this->Points, Dim, static_cast<int>(&colour - blocks.ByColour.data()), &changed);
            this->MeasureAround(
              connectivity, std::vector<std::int64_t>(changed.begin() + before, changed.end()));
          }
        }
      }
      else
      {
        const std::vector<std::vector<std::int64_t>> byColour = GreedyColouring(candidates, colours,
          [&](std::int64_t p, auto&& visit)
          {
            for (std::int64_t k = this->Incidence.Offsets[p]; k < this->Incidence.Offsets[p + 1];
                 ++k)
            {
              const IdType* ids = connectivity + this->Incidence.Cells[k] * Corners;
              for (int v = 0; v <= Dim; ++v)
              {
                visit(static_cast<std::int64_t>(ids[v]));
              }
            }
          });
        for (const std::int64_t p : candidates)
        {
          colours[p] = -1;
        }
        for (const auto& points : byColour)
        {
          ImproveKernel kernel{ this, &points, connectivity, materials, &projector, project,
            &badness, &executor, &improved, phase == 1 };
          executor.For(0, static_cast<std::int64_t>(points.size()), 16, kernel);
          if (this->StopAgreed(executor))
          {
            return Status::Aborted();
          }
        }
      }
      this->Stats.ImprovedPoints += improved;
      // The cells another piece's moves changed are candidates' cells of the next sweep too.
      candidates.insert(candidates.end(), changed.begin(), changed.end());
      if (exchange ? exchange->Maximum(static_cast<double>(improved)) == 0.0 : improved == 0)
      {
        break;
      }
    }
  }
  return Status::Ok();
}

template <int Dim>
template <class IdType, class MaterialType, class Projector, class Executor>
Status BoundarySmoother<Dim>::RestoreVolumes(const PointBlocks& surfaceBlocks,
  const IdType* connectivity, const MaterialType* materials, Projector& projector,
  Executor& executor)
{
  constexpr std::int64_t Corners = Dim + 1;
  constexpr std::int64_t Outside = std::numeric_limits<std::int64_t>::min();
  const std::map<std::int64_t, double>& targets = this->Stats.TargetVolumes;
  const double factorial = Factorial(Dim);
  // Pieces sum the volumes and the weights over all pieces, and share the moved points.
  SmoothingExchange* exchange = this->Exchanging ? this->Options.Exchange : nullptr;
  // Per-cell volumes in parallel, then summed per material in cell order (deterministic).
  std::vector<double> cellVolumes(static_cast<std::size_t>(this->NumberOfCells));
  struct VolumeKernel
  {
    using Scratch = NoScratch;
    const BoundarySmoother* Self;
    const IdType* Connectivity;
    double* Volumes;
    double Factorial;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t c = begin; c < end; ++c)
      {
        const double* corners[Dim + 1];
        this->Self->CellCorners(this->Connectivity + c * Corners, c, -1, nullptr, corners);
        double edges[Dim][Dim];
        for (int col = 0; col < Dim; ++col)
        {
          for (int r = 0; r < Dim; ++r)
          {
            edges[r][col] = corners[col + 1][r] - corners[0][r];
          }
        }
        this->Volumes[c] = Determinant<Dim>(edges) / this->Factorial;
      }
    }
  };
  auto largestError = [&](std::map<std::int64_t, double>& volumes)
  {
    VolumeKernel kernel{ this, connectivity, cellVolumes.data(), factorial };
    executor.For(0, this->NumberOfCells, 4096, kernel);
    volumes.clear();
    SumPerKey(
      this->NumberOfCells, [&](std::int64_t c) { return static_cast<std::int64_t>(materials[c]); },
      [&](std::int64_t c) { return cellVolumes[c]; }, volumes, this->Options.GhostCells, exchange);
    // Over the materials that have cells and a target (a target material the cut did not keep
    // is no interface's to restore).
    double largest = 0.0;
    for (const auto& target : targets)
    {
      const auto found = volumes.find(target.first);
      if (target.second > 0.0 && found != volumes.end())
      {
        largest = std::max(largest, std::abs(found->second - target.second) / target.second);
      }
    }
    return largest;
  };

  const std::vector<std::int64_t>& points = surfaceBlocks.Points;
  const auto count = static_cast<std::int64_t>(points.size());
  // Per surface point between exactly two materials (the outside counting as one): the pair,
  // with First a material of cells (the pairs do not change), and per round the gradient of
  // First's volume at the point.
  std::vector<std::int64_t> first(points.size()), second(points.size());
  std::vector<double> gradients(points.size() * Dim);
  struct PairKernel
  {
    using Scratch = NoScratch;
    const BoundarySmoother* Self;
    const MaterialType* Materials;
    const std::vector<std::int64_t>* Points;
    std::int64_t* First;
    std::int64_t* Second;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      const BoundarySmoother& self = *this->Self;
      for (std::int64_t i = begin; i < end; ++i)
      {
        const std::int64_t p = (*this->Points)[i];
        // Its materials, the outside counting as one.
        std::int64_t found[2] = { Outside, Outside };
        const bool outer = self.OnOuterBoundary[p] != 0;
        int count = outer ? 1 : 0;
        for (std::int64_t k = self.Incidence.Offsets[p]; k < self.Incidence.Offsets[p + 1]; ++k)
        {
          const std::int64_t cell = self.Incidence.Cells[k];
          const auto material = static_cast<std::int64_t>(this->Materials[cell]);
          if (self.Signs[cell] == 0)
          {
            count = 3; // a degenerate input cell: no move of its points is ever validated
            break;
          }
          if (material != found[0] && material != found[1])
          {
            if (count < 2)
            {
              found[outer ? 0 : count] = material;
            }
            ++count;
          }
        }
        // A junction, a degenerate neighbourhood or one material only: the point stays.
        const bool pair = count == 2;
        this->First[i] = pair ? found[0] : Outside;
        this->Second[i] = pair ? found[1] : Outside;
      }
    }
  };
  struct GradientKernel
  {
    using Scratch = NoScratch;
    const BoundarySmoother* Self;
    const IdType* Connectivity;
    const MaterialType* Materials;
    const std::vector<std::int64_t>* Points;
    const std::int64_t* First;
    double* Gradients;
    double Factorial;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      const BoundarySmoother& self = *this->Self;
      for (std::int64_t i = begin; i < end; ++i)
      {
        if (this->First[i] == Outside)
        {
          continue;
        }
        const std::int64_t p = (*this->Points)[i];
        double* gradient = this->Gradients + i * Dim;
        std::fill(gradient, gradient + Dim, 0.0);
        for (std::int64_t k = self.Incidence.Offsets[p]; k < self.Incidence.Offsets[p + 1]; ++k)
        {
          const std::int64_t cell = self.Incidence.Cells[k];
          if (static_cast<std::int64_t>(this->Materials[cell]) != this->First[i])
          {
            continue;
          }
          double cellGradient[Dim];
          self.CornerGradient(this->Connectivity + cell * Corners, cell, p, cellGradient);
          for (int c = 0; c < Dim; ++c)
          {
            gradient[c] += cellGradient[c] / this->Factorial;
          }
        }
      }
    }
  };
  PairKernel pairKernel{ this, materials, &points, first.data(), second.data() };
  executor.For(0, count, 1024, pairKernel);

  std::map<std::int64_t, double> volumes;
  this->Stats.LargestVolumeErrorBefore = largestError(volumes);
  this->Stats.LargestVolumeErrorAfter = this->Stats.LargestVolumeErrorBefore;
  for (int round = 0;
       round<this->Options.NumberOfVolumeRounds&& this->Stats.LargestVolumeErrorAfter> this->Options
         .VolumeTolerance;
       ++round)
  {
    GradientKernel gradientKernel{ this, connectivity, materials, &points, first.data(),
      gradients.data(), factorial };
    executor.For(0, count, 1024, gradientKernel);
    if (this->StopAgreed(executor))
    {
      return Status::Aborted();
    }
    // Moving the points of pair (a, b) by (lambda_a - lambda_b) g changes a's volume by
    // (lambda_a - lambda_b) |g|^2 (first order): a weighted graph Laplacian in the lambdas of
    // the materials with a target, the background and the outside held at 0.
    std::map<std::int64_t, int> unknown;
    std::map<std::pair<std::int64_t, std::int64_t>, double> weights;
    {
      std::map<std::pair<std::int64_t, std::int64_t>, ExactSum> exact;
      for (std::int64_t i = 0; i < count; ++i)
      {
        if (first[i] == Outside)
        {
          continue;
        }
        double squared = 0.0;
        for (int c = 0; c < Dim; ++c)
        {
          squared += gradients[i * Dim + c] * gradients[i * Dim + c];
        }
        exact[{ std::min(first[i], second[i]), std::max(first[i], second[i]) }].Add(squared);
      }
      SumOverPieces(exact, exchange);
      for (const auto& entry : exact)
      {
        weights.emplace(entry.first, entry.second.Value());
      }
    }
    auto free = [&](std::int64_t material)
    {
      return material != Outside && material != this->Options.BackgroundMaterial &&
        targets.count(material) > 0;
    };
    for (const auto& weight : weights)
    {
      for (const std::int64_t material : { weight.first.first, weight.first.second })
      {
        if (free(material) && !unknown.count(material))
        {
          const int index = static_cast<int>(unknown.size());
          unknown[material] = index;
        }
      }
    }
    const std::size_t n = unknown.size();
    if (n == 0)
    {
      break;
    }
    std::vector<double> diagonal(n, 0.0), residual(n, 0.0), lambdas(n, 0.0);
    std::vector<std::tuple<int, int, double>> couplings;
    for (const auto& weight : weights)
    {
      const auto a = unknown.find(weight.first.first), b = unknown.find(weight.first.second);
      if (a != unknown.end())
      {
        diagonal[a->second] += weight.second;
      }
      if (b != unknown.end())
      {
        diagonal[b->second] += weight.second;
      }
      if (a != unknown.end() && b != unknown.end())
      {
        couplings.emplace_back(a->second, b->second, weight.second);
      }
    }
    double norm = 0.0;
    for (const auto& entry : unknown)
    {
      residual[entry.second] = targets.at(entry.first) - volumes[entry.first];
      norm += residual[entry.second] * residual[entry.second];
    }
    // Conjugate gradients (the matrix is symmetric, and positive definite when every group
    // of materials touches the background or the outside; the others get a tiny shift).
    double largestDiagonal = *std::max_element(diagonal.begin(), diagonal.end());
    for (double& d : diagonal)
    {
      d += 1e-12 * largestDiagonal;
    }
    auto multiply = [&](const std::vector<double>& v, std::vector<double>& out)
    {
      for (std::size_t k = 0; k < n; ++k)
      {
        out[k] = diagonal[k] * v[k];
      }
      for (const auto& coupling : couplings)
      {
        out[std::get<0>(coupling)] -= std::get<2>(coupling) * v[std::get<1>(coupling)];
        out[std::get<1>(coupling)] -= std::get<2>(coupling) * v[std::get<0>(coupling)];
      }
    };
    std::vector<double> direction(residual), product(n);
    double rr = norm;
    for (std::size_t iteration = 0; iteration < 10 * n + 10 && rr > 1e-24 * norm; ++iteration)
    {
      multiply(direction, product);
      double curvature = 0.0;
      for (std::size_t k = 0; k < n; ++k)
      {
        curvature += direction[k] * product[k];
      }
      if (!(curvature > 0.0))
      {
        break;
      }
      const double step = rr / curvature;
      double next = 0.0;
      for (std::size_t k = 0; k < n; ++k)
      {
        lambdas[k] += step * direction[k];
        residual[k] -= step * product[k];
        next += residual[k] * residual[k];
      }
      for (std::size_t k = 0; k < n; ++k)
      {
        direction[k] = residual[k] + next / rr * direction[k];
      }
      rr = next;
    }
    auto lambdaOf = [&](std::int64_t material)
    {
      const auto found = unknown.find(material);
      return found == unknown.end() ? 0.0 : lambdas[found->second];
    };
    // The targets of the moves, validated like the smoothing's.
    for (std::int64_t i = 0; i < count; ++i)
    {
      if (first[i] == Outside || this->Roles[points[i]] == Fixed)
      {
        continue;
      }
      const double factor = lambdaOf(first[i]) - lambdaOf(second[i]);
      for (int c = 0; c < Dim; ++c)
      {
        this->Targets[points[i] * Dim + c] =
          this->Points[points[i] * Dim + c] + factor * gradients[i * Dim + c];
      }
    }
    const Status status =
      this->Step(surfaceBlocks, true, 0.0, 0.0, connectivity, projector, false, executor, true);
    if (!status.IsOk())
    {
      return status;
    }
    this->Stats.LargestVolumeErrorAfter = largestError(volumes);
  }
  return Status::Ok();
}

} // namespace stm

#endif
