// SPDX-License-Identifier: BSD-3-Clause
// Vertex snapping: hand-made triangles and tetrahedra with exact expectations (the intersection
// point, f exactly the iso-value, Alpha 0 and 0.5, the refusals, the conflict rule, the
// projector), and random fields on adaptive meshes in 1D to 4D (positive cells, no new all-zero
// cell, a valid mesh, fewer cut cells, thread independence, quality-driven never worse).

#include "CoreTestUtilities.h"
#include "MemoryPieces.h"

#include "Check/MeshInvariants.h"
#include "Check/SimplexQuality.h"
#include "Common/Determinant.h"
#include "Cut/MarchingSimplices.h"
#include "Cut/SeparatingFunction.h"
#include "Cut/VertexSnap.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <set>
#include <thread>
#include <vector>

namespace
{
using namespace stmtest;

template <int D>
struct SnapRun
{
  stm::Status Result;
  std::vector<double> Points;
  std::vector<double> Values;
  std::vector<std::uint8_t> Moved;
  std::vector<std::uint8_t> Refused;
  std::vector<std::uint8_t> Nudged;
  stm::VertexSnapCounts Counts;
};

template <int D, class Executor, class Projector = stm::NoSnapProjection>
SnapRun<D> Snap(std::vector<double> points, std::vector<double> values,
  const std::vector<std::int64_t>& cells, const stm::VertexSnapOptions& options, Executor& executor,
  Projector projector = Projector())
{
  SnapRun<D> run;
  stm::VertexSnap<D> snap;
  run.Result = snap.Snap(points.data(), values.data(), static_cast<std::int64_t>(values.size()),
    cells.data(), static_cast<std::int64_t>(cells.size()) / (D + 1), options, projector, executor);
  run.Points = std::move(points);
  run.Values = std::move(values);
  run.Moved = snap.GetMovedFlags();
  run.Refused = snap.GetRefusedFlags();
  run.Nudged = snap.GetNudgedFlags();
  run.Counts = snap.GetCounts();
  return run;
}

template <int D>
SnapRun<D> Snap(const std::vector<double>& points, const std::vector<double>& values,
  const std::vector<std::int64_t>& cells, double alpha,
  stm::SnapRule rule = stm::SnapRule::Threshold)
{
  stm::VertexSnapOptions options;
  options.Alpha = alpha;
  options.Rule = rule;
  stm::SequentialExecutor executor;
  return Snap<D>(points, values, cells, options, executor);
}

/// The cut MarchingSimplices makes, with the snap's zero tolerance.
template <int D>
CutResult<D> Cut(const std::vector<double>& points, const std::vector<double>& values,
  const std::vector<std::int64_t>& cells)
{
  stm::MarchingSimplicesOptions options;
  options.ZeroTolerance = stm::VertexSnapOptions().ZeroTolerance;
  stm::SequentialExecutor executor;
  CutResult<D> result = stmtest::Cut<D>(
    points, values, cells, options, executor, [](std::int64_t) { return stm::CutSide::Inside; });
  EXPECT_TRUE(result.Result.IsOk());
  return result;
}

template <int D>
double WorstCondition(const CutResult<D>& mesh)
{
  double worst = 0.0;
  for (std::size_t cell = 0; cell < mesh.Connectivity.size() / (D + 1); ++cell)
  {
    const double* corners[D + 1];
    for (int k = 0; k <= D; ++k)
    {
      corners[k] = mesh.Coordinates.data() + mesh.Connectivity[cell * (D + 1) + k] * D;
    }
    worst = std::max(worst, stm::MeasureSimplex<D>(corners).Condition);
  }
  return worst;
}

const double Third = 1.0 / 3.0;

// The unit right triangle with f = (-1, 3, 3): both edges from vertex 0 are cut at t = 1/4; the
// tie goes to the smaller other end, so vertex 0 lands exactly on (1/4, 0) with f exactly 0.
TEST(VertexSnap, TriangleSnapsToTheExactIntersection)
{
  const std::vector<double> points{ 0, 0, 1, 0, 0, 1 };
  const std::vector<double> values{ -1, 3, 3 };
  const std::vector<std::int64_t> cells{ 0, 1, 2 };
  const SnapRun<2> run = Snap<2>(points, values, cells, Third);
  ASSERT_TRUE(run.Result.IsOk()) << run.Result.GetMessage();
  EXPECT_EQ(run.Points, (std::vector<double>{ 0.25, 0, 1, 0, 0, 1 }));
  EXPECT_EQ(run.Values, (std::vector<double>{ 0, 3, 3 }));
  EXPECT_EQ(run.Moved, (std::vector<std::uint8_t>{ 1, 0, 0 }));
  EXPECT_EQ(run.Counts.Snapped, 1);
  EXPECT_EQ(run.Counts.Refused(), 0);
  EXPECT_EQ(Cut<2>(run.Points, run.Values, cells).CutEdges, 0);

  // Alpha 0 never snaps; 1/4 is not below 0.2.
  for (double alpha : { 0.0, 0.2, 0.25 })
  {
    const SnapRun<2> none = Snap<2>(points, values, cells, alpha);
    ASSERT_TRUE(none.Result.IsOk());
    EXPECT_EQ(none.Points, points) << "alpha " << alpha;
    EXPECT_EQ(none.Values, values) << "alpha " << alpha;
    EXPECT_EQ(none.Counts.Snapped, 0) << "alpha " << alpha;
  }
}

TEST(VertexSnap, TetrahedronSnapsToTheExactIntersection)
{
  const std::vector<double> points{ 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1 };
  const std::vector<std::int64_t> cells{ 0, 1, 2, 3 };
  // Vertex 3 is nearest: f = (7, 7, 7, -1) cuts its edges at 1/8 of their length from it.
  const SnapRun<3> run = Snap<3>(points, { 7, 7, 7, -1 }, cells, Third);
  ASSERT_TRUE(run.Result.IsOk());
  EXPECT_EQ(run.Points, (std::vector<double>{ 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0.875 }));
  EXPECT_EQ(run.Values, (std::vector<double>{ 7, 7, 7, 0 }));
  EXPECT_EQ(run.Moved, (std::vector<std::uint8_t>{ 0, 0, 0, 1 }));
  EXPECT_GT(ScaledVolume<3>(run.Points, cells.data()), 0.0);
  const CutResult<3> cut = Cut<3>(run.Points, run.Values, cells);
  EXPECT_EQ(cut.CutEdges, 0);
  EXPECT_EQ(cut.Connectivity.size(), 4u);

  // A positive vertex snaps too, towards the negative end (t measured from there: 1 - 1/5).
  const SnapRun<3> positive = Snap<3>(points, { -4, -4, 1, -4 }, cells, Third);
  ASSERT_TRUE(positive.Result.IsOk());
  EXPECT_EQ(positive.Moved, (std::vector<std::uint8_t>{ 0, 0, 1, 0 }));
  EXPECT_EQ(positive.Values[2], 0.0);
  EXPECT_EQ(positive.Points[6], 0.0);
  EXPECT_NEAR(positive.Points[7], 0.8, 1e-15); // towards vertex 0, the smallest other end
  EXPECT_EQ(positive.Points[8], 0.0);
}

/// The distance of the cut of edge (v, w) from v, as VertexSnap measures it.
double CutDistance(const std::vector<double>& values, std::int64_t v, std::int64_t w)
{
  const bool negative = values[v] < 0;
  const double fNegative = negative ? values[v] : values[w];
  const double fPositive = negative ? values[w] : values[v];
  const double t = -fNegative / (fPositive - fNegative);
  return negative ? t : 1.0 - t;
}

// Vertex 2 would close triangle (0, 2, 3), whose other vertices are zero: refused, nothing moved.
// It is nudged instead (the values used to stay): f(2) grows from 1 to (about) 1.5, so that the
// cut of edge 2-3 lies 1/3 of the edge from it rather than 1/4; the point stays.
TEST(VertexSnap, RefusesToPutAWholeCellOnTheSurface)
{
  const std::vector<double> points{ 0, 0, 1, 0, 0, 1, 1, 1 };
  const std::vector<std::int64_t> cells{ 0, 1, 2, 1, 3, 2 };
  const std::vector<double> values{ 0, 0, 1, -3 }; // edge 2-3 cut 1/4 from vertex 2
  const SnapRun<2> run = Snap<2>(points, values, cells, Third);
  ASSERT_TRUE(run.Result.IsOk());
  EXPECT_EQ(run.Points, points);
  EXPECT_EQ(run.Values[0], 0.0);
  EXPECT_EQ(run.Values[1], 0.0);
  EXPECT_EQ(run.Values[3], -3.0);
  EXPECT_NEAR(run.Values[2], 1.5, 1e-12);
  EXPECT_GE(CutDistance(run.Values, 2, 3), Third);
  EXPECT_EQ(run.Counts.Snapped, 0);
  EXPECT_EQ(run.Counts.RefusedAllZero, 1);
  EXPECT_EQ(run.Counts.Nudged, 1);
  EXPECT_EQ(run.Refused, (std::vector<std::uint8_t>{ 0, 0, 1, 0 }));
  EXPECT_EQ(run.Nudged, (std::vector<std::uint8_t>{ 0, 0, 1, 0 }));
  // Already at least Alpha from every cut: no nudge.
  const SnapRun<2> far = Snap<2>(points, { 0, 0, 1, -1.5 }, cells, Third);
  EXPECT_EQ(far.Counts.Nudged, 0);
  EXPECT_EQ(far.Values[2], 1.0);
}

// A refused tetrahedron vertex (all three others of one cell on the surface) is nudged: with
// Alpha 1/3 every cut on its edges ends at least 1/3 from it, and a neighbour whose cut the nudge
// brings closer than Alpha then claims and snaps.
TEST(VertexSnap, NudgesARefusedTetrahedronVertex)
{
  // Tetrahedron (0, 1, 2, 3) with 1, 2, 3 on the surface, and (0, 2, 1, 4) below it.
  const std::vector<double> points{ 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1 };
  const std::vector<std::int64_t> cells{ 0, 1, 2, 3, 0, 2, 1, 4 };
  ASSERT_GT(ScaledVolume<3>(points, cells.data()), 0.0);
  ASSERT_GT(ScaledVolume<3>(points, cells.data() + 4), 0.0);
  // Edge 0-4 cut 1/10 from vertex 0: refused (cell 0 would be all zero), nudged to 0.5 * 9.
  const SnapRun<3> run = Snap<3>(points, { 1, 0, 0, 0, -9 }, cells, Third);
  ASSERT_TRUE(run.Result.IsOk());
  EXPECT_EQ(run.Counts.RefusedAllZero, 1);
  EXPECT_EQ(run.Counts.Nudged, 1);
  EXPECT_EQ(run.Points, points);
  EXPECT_NEAR(run.Values[0], 4.5, 1e-12);
  EXPECT_GE(CutDistance(run.Values, 0, 4), Third);
  // The nudge cut 0-4 at exactly 1/3 from 0, i.e. 2/3 from vertex 4: no new claim.
  EXPECT_EQ(run.Counts.Snapped, 0);
  // At Alpha 0.45 the nudge cuts 0-4 at 0.45 from 0; vertex 4 (0.55) does not claim either.
  const SnapRun<3> wide = Snap<3>(points, { 1, 0, 0, 0, -9 }, cells, 0.45);
  EXPECT_GE(CutDistance(wide.Values, 0, 4), 0.45);
  EXPECT_LT(CutDistance(wide.Values, 0, 4), 0.45 + 1e-12);
  // Alpha 0 nudges nothing (and snaps nothing).
  EXPECT_EQ(Snap<3>(points, { 1, 0, 0, 0, -9 }, cells, 0.0).Counts.Nudged, 0);
}

// A fan around v = (0, 0) with a reflex neighbour d: moving v 1/5 of the way to w = (1, 0)
// inverts triangle (v, d, a), so the snap is undone.
TEST(VertexSnap, RefusesToInvertACell)
{
  //                               v     w     d           a     e      c       b
  const std::vector<double> points{ 0, 0, 1, 0, 0.1, 0.05, 1, 1, -1, 1, -1, -1, 1, -1 };
  const std::vector<std::int64_t> cells{ 0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5, 0, 5, 6, 0, 6, 1 };
  for (std::size_t c = 0; c < cells.size() / 3; ++c)
  {
    ASSERT_GT(ScaledVolume<2>(points, cells.data() + 3 * c), 0.0) << "cell " << c;
  }
  const std::vector<double> values{ -1, 4, 2, 2, 2, 2, 2 };
  const SnapRun<2> run = Snap<2>(points, values, cells, Third);
  ASSERT_TRUE(run.Result.IsOk());
  EXPECT_EQ(run.Points, points);
  // Nudged (the values used to stay): f(v) from -1 to -2, so edge v-w is cut 1/3 from v.
  EXPECT_NEAR(run.Values[0], -2.0, 1e-12);
  EXPECT_EQ(std::vector<double>(run.Values.begin() + 1, run.Values.end()),
    std::vector<double>(values.begin() + 1, values.end()));
  EXPECT_EQ(run.Counts.Snapped, 0);
  EXPECT_EQ(run.Counts.RefusedNonPositive, 1);
  EXPECT_EQ(run.Counts.Nudged, 1);
  EXPECT_EQ(run.Refused[0], 1);

  // Without the reflex neighbour the same move is fine.
  std::vector<double> convex = points;
  convex[4] = 0.5;
  convex[5] = 0.3;
  const SnapRun<2> accepted = Snap<2>(convex, values, cells, Third);
  EXPECT_EQ(accepted.Counts.Snapped, 1);
  EXPECT_EQ(accepted.Points[0], 0.2);
}

// The case FuzzCorePipeline found (Testing/Fuzz/regressions/core/threshold-snap-flat-cell):
// d's snap along d-e (1/5 of the edge) lands exactly on the plane of a, b and c, which rounding
// puts at a determinant of +4.4e-16, not 0. The old sign test let it through and the cut of the
// flat cell gave pieces of no volume; the snap is now refused, d nudged.
TEST(VertexSnap, RefusesToFlattenACellWhoseDeterminantRoundsPositive)
{
  //                                a             b        c        d        e        g
  const std::vector<double> points{ 4, 3.5, 2.5, 6, 3, 2, 6, 4, 2, 7, 4, 2, 6, 4, 1, 7, 3, 1 };
  const std::vector<std::int64_t> cells{ 0, 1, 2, 3, 2, 3, 5, 4 };
  for (std::size_t c = 0; c < cells.size() / 4; ++c)
  {
    ASSERT_GT(ScaledVolume<3>(points, cells.data() + 4 * c), 0.0) << "cell " << c;
  }
  const std::vector<double> values{ 1, 0.5, -0.5, 0.25, -1, 1 };
  const SnapRun<3> run = Snap<3>(points, values, cells, Third);
  ASSERT_TRUE(run.Result.IsOk()) << run.Result.GetMessage();
  EXPECT_EQ(run.Points, points);
  EXPECT_EQ(run.Counts.Snapped, 0);
  EXPECT_EQ(run.Counts.RefusedNonPositive, 1);
  EXPECT_EQ(run.Refused[3], 1);
  // Nudged: f(d) from 0.25 to 0.5, so that edge d-e is cut 1/3 of the way from d.
  EXPECT_NEAR(run.Values[3], 0.5, 1e-12);

  const CutResult<3> cut = Cut<3>(run.Points, run.Values, cells);
  const std::vector<std::int64_t> labels(cut.Connectivity.size() / 4, 1);
  const stm::MeshInvariantReport report =
    stm::CheckSimplicialMesh<3>(cut.Coordinates, cut.Connectivity, &labels);
  EXPECT_EQ(report.NonPositiveCells, 0) << report.Summary();
  EXPECT_GT(report.MinimumVolume, 1e-3);
}

// Vertices 0 and 2 both claim and share triangle (0, 2, 3) whose vertex 3 is zero: only one of
// them may snap. The smaller distance wins; on equal distances, the smaller point id.
TEST(VertexSnap, ConflictsGoToTheSmallerDistanceThenTheSmallerId)
{
  const std::vector<double> points{ 0, 0, 1, 0, 0, 1, -1, 0 };
  const std::vector<std::int64_t> cells{ 0, 1, 2, 0, 2, 3 };
  // Equal distances 1/5 (edges 0-1 and 2-1): vertex 0 wins, vertex 2 is refused.
  const SnapRun<2> tie = Snap<2>(points, { -1, 4, -1, 0 }, cells, Third);
  ASSERT_TRUE(tie.Result.IsOk());
  EXPECT_EQ(tie.Moved, (std::vector<std::uint8_t>{ 1, 0, 0, 0 }));
  EXPECT_EQ(tie.Refused, (std::vector<std::uint8_t>{ 0, 0, 1, 0 }));
  EXPECT_EQ(tie.Counts.RefusedAllZero, 1);
  EXPECT_EQ(tie.Counts.Rounds, 2);
  EXPECT_EQ(tie.Points[0], 0.2);
  // Vertex 2 nearer (1/9): it wins and moves to (1/9, 8/9).
  const SnapRun<2> nearer = Snap<2>(points, { -1, 4, -0.5, 0 }, cells, Third);
  ASSERT_TRUE(nearer.Result.IsOk());
  EXPECT_EQ(nearer.Moved, (std::vector<std::uint8_t>{ 0, 0, 1, 0 }));
  EXPECT_EQ(nearer.Refused, (std::vector<std::uint8_t>{ 1, 0, 0, 0 }));
  EXPECT_NEAR(nearer.Points[4], 1.0 / 9.0, 1e-15);
  EXPECT_NEAR(nearer.Points[5], 8.0 / 9.0, 1e-15);
}

// Alpha 0.5 snaps an end of every cut edge: with f = (-1, 1, 1, 1) every edge from vertex 0 is
// cut at t = 1/2, both ends claim, the smallest id (vertex 0, towards vertex 1) moves, and then
// no edge is cut. Just below 0.5 nothing snaps there; a cut at 1/4 still snaps.
TEST(VertexSnap, AlphaHalfLeavesNoCutEdge)
{
  const std::vector<double> points{ 0, 0, 1, 0, 0, 1, 1, 1 };
  const std::vector<std::int64_t> cells{ 0, 1, 2, 1, 3, 2 };
  const SnapRun<2> run = Snap<2>(points, { -1, 1, 1, 1 }, cells, 0.5);
  ASSERT_TRUE(run.Result.IsOk());
  EXPECT_EQ(run.Moved, (std::vector<std::uint8_t>{ 1, 0, 0, 0 }));
  EXPECT_EQ(run.Points, (std::vector<double>{ 0.5, 0, 1, 0, 0, 1, 1, 1 }));
  EXPECT_EQ(run.Counts.Refused(), 0);
  EXPECT_EQ(Cut<2>(run.Points, run.Values, cells).CutEdges, 0);
  EXPECT_EQ(Snap<2>(points, { -1, 1, 1, 1 }, cells, 0.4999).Counts.Snapped, 0);
  const SnapRun<2> quarter = Snap<2>(points, { -1, 1, 3, 5 }, cells, 0.4999);
  EXPECT_EQ(quarter.Counts.Snapped, 1);
  EXPECT_EQ(quarter.Points[0], 0.0);
  EXPECT_EQ(quarter.Points[1], 0.25); // along edge 0-2, where 0-1 is cut at 1/2
  EXPECT_EQ(Cut<2>(quarter.Points, quarter.Values, cells).CutEdges, 0);
}

TEST(VertexSnap, ProjectorPlacesTheVertexWithinItsEdgeLength)
{
  // The second triangle is not around vertex 0: the box of 0's cells leaves out (2, 2).
  const std::vector<double> points{ 0, 0, 1, 0, 0, 1, 2, 2 };
  const std::vector<double> values{ -1, 3, 3, 3 };
  const std::vector<std::int64_t> cells{ 0, 1, 2, 1, 3, 2 };
  stm::SequentialExecutor executor;
  stm::VertexSnapOptions options;
  std::vector<std::int64_t> asked;
  auto near = [&](std::int64_t point, const double* current, const double* target,
                const double* starBox, double* result)
  {
    asked.push_back(point);
    EXPECT_EQ(current[0], 0.0);
    EXPECT_EQ(target[0], 0.25);
    EXPECT_EQ(std::vector<double>(starBox, starBox + 4), (std::vector<double>{ 0, 0, 1, 1 }));
    result[0] = 0.2;
    result[1] = 0.1;
    return true;
  };
  const SnapRun<2> projected = Snap<2>(points, values, cells, options, executor, near);
  EXPECT_EQ(asked, (std::vector<std::int64_t>{ 0 }));
  EXPECT_EQ(projected.Points[0], 0.2);
  EXPECT_EQ(projected.Points[1], 0.1);
  EXPECT_EQ(projected.Values[0], 0.0);
  // Farther than the edge (length 1) from the vertex, or declined: the edge's intersection.
  auto far = [](std::int64_t, const double*, const double*, const double*, double* result)
  {
    result[0] = 0.9;
    result[1] = 0.9;
    return true;
  };
  EXPECT_EQ(Snap<2>(points, values, cells, options, executor, far).Points[0], 0.25);
  auto declined = [](std::int64_t, const double*, const double*, const double*, double*)
  { return false; };
  EXPECT_EQ(Snap<2>(points, values, cells, options, executor, declined).Points[0], 0.25);
}

TEST(VertexSnap, RejectsBadOptionsValuesAndIds)
{
  const std::vector<double> points{ 0, 0, 1, 0, 0, 1 };
  const std::vector<std::int64_t> cells{ 0, 1, 2 };
  for (double alpha : { -0.1, 0.51, std::nan("") })
  {
    EXPECT_EQ(Snap<2>(points, { -1, 3, 3 }, cells, alpha).Result.GetCode(),
      stm::Status::Code::InvalidArgument);
  }
  const SnapRun<2> nan = Snap<2>(points, { -1, std::nan(""), 3 }, cells, Third);
  EXPECT_EQ(nan.Result.GetCode(), stm::Status::Code::InvalidArgument);
  EXPECT_NE(nan.Result.GetMessage().find("NaN"), std::string::npos);
  EXPECT_EQ(Snap<2>(points, { -1, 3, 3 }, { 0, 1, 3 }, Third).Result.GetCode(),
    stm::Status::Code::InvalidArgument);
  {
    stm::SequentialExecutor executor;
    stm::VertexSnapOptions options;
    options.QualityBound = -1.0;
    EXPECT_EQ(Snap<2>(points, { -1, 3, 3 }, cells, options, executor).Result.GetCode(),
      stm::Status::Code::InvalidArgument);
  }
  stm::SequentialExecutor aborted;
  aborted.RequestAbort();
  EXPECT_EQ(
    Snap<2>(points, { -1, 3, 3 }, cells, stm::VertexSnapOptions(), aborted).Result.GetCode(),
    stm::Status::Code::Aborted);
}

template <int D>
SimplicialMesh<D> AdaptiveMesh(unsigned seed, std::int64_t extent)
{
  const LabelImage<D> image = MakeRandomImage<D>(UniformExtents<D>(extent), seed, 2, 3, 20);
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  EXPECT_TRUE(BuildTree<D>(image, 4, 1, false, executor, tree).IsOk());
  stm::SpacetreeTessellationOptions options;
  options.IncludeBackground = true;
  if (D == 1 || D == 4)
  {
    options.Template = stm::CellTemplate::Kuhn;
  }
  SimplicialMesh<D> mesh;
  EXPECT_TRUE(TessellateTree<D>(tree, options, executor, mesh).IsOk());
  return mesh;
}

/// A smooth field (a ball) plus noise, so that cuts fall anywhere along the edges.
template <int D>
std::vector<double> RandomField(const std::vector<double>& points, double extent, unsigned seed)
{
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> noise(-0.5, 0.5);
  std::vector<double> values(points.size() / D);
  for (std::size_t p = 0; p < values.size(); ++p)
  {
    double r2 = 0.0;
    for (int c = 0; c < D; ++c)
    {
      const double x = points[p * D + c] - 0.5 * extent - 0.1 * c;
      r2 += x * x;
    }
    values[p] = std::sqrt(r2) - 0.3 * extent + noise(random);
  }
  return values;
}

template <int D>
std::int64_t CountAllZeroCells(
  const std::vector<double>& values, const std::vector<std::int64_t>& cells)
{
  std::int64_t count = 0;
  for (std::size_t cell = 0; cell < cells.size() / (D + 1); ++cell)
  {
    bool allZero = true;
    for (int k = 0; k <= D; ++k)
    {
      allZero = allZero && std::abs(values[cells[cell * (D + 1) + k]]) <= 1e-9;
    }
    count += allZero ? 1 : 0;
  }
  return count;
}

template <class T>
class VertexSnapMeshTest : public ::testing::Test
{
};
using MeshDimensions = ::testing::Types<Dim<2>, Dim<3>>;
TYPED_TEST_SUITE(VertexSnapMeshTest, MeshDimensions);

TYPED_TEST(VertexSnapMeshTest, RandomFieldsGiveValidMeshesWithFewerCells)
{
  constexpr int D = TypeParam::value;
  const std::int64_t extent = D == 2 ? 24 : 10;
  for (unsigned seed = 1; seed <= 3; ++seed)
  {
    const SimplicialMesh<D> mesh = AdaptiveMesh<D>(seed, extent);
    const std::vector<double> points = mesh.Coordinates();
    const std::vector<double> values = RandomField<D>(points, static_cast<double>(extent), seed);
    const CutResult<D> unsnapped = Cut<D>(points, values, mesh.Connectivity);
    const double unsnappedWorst = WorstCondition<D>(unsnapped);
    ASSERT_GT(unsnapped.CutEdges, 0);
    const std::int64_t allZeroBefore = CountAllZeroCells<D>(values, mesh.Connectivity);

    struct Case
    {
      double Alpha;
      stm::SnapRule Rule;
      double Bound;
    };
    for (const Case& snapCase :
      { Case{ Third, stm::SnapRule::Threshold, 0.0 }, Case{ 0.5, stm::SnapRule::Threshold, 0.0 },
        Case{ 0.0, stm::SnapRule::QualityDriven, 0.0 },
        Case{ 0.45, stm::SnapRule::Threshold, 3.0 } })
    {
      SCOPED_TRACE(::testing::Message()
        << "seed " << seed << ", alpha " << snapCase.Alpha << ", rule "
        << static_cast<int>(snapCase.Rule) << ", bound " << snapCase.Bound);
      stm::VertexSnapOptions options;
      options.Alpha = snapCase.Alpha;
      options.Rule = snapCase.Rule;
      options.QualityBound = snapCase.Bound;
      stm::SequentialExecutor sequential;
      const SnapRun<D> run = Snap<D>(points, values, mesh.Connectivity, options, sequential);
      ASSERT_TRUE(run.Result.IsOk()) << run.Result.GetMessage();
      EXPECT_GT(run.Counts.Snapped, 0);
      EXPECT_EQ(std::count(run.Moved.begin(), run.Moved.end(), 1), run.Counts.Snapped);

      // Every cell positive, no new all-zero cell, a valid mesh; snapped points exactly zero.
      std::int64_t nonPositive = 0;
      for (std::int64_t cell = 0; cell < mesh.GetNumberOfSimplices(); ++cell)
      {
        nonPositive +=
          ScaledVolume<D>(run.Points, mesh.Connectivity.data() + cell * (D + 1)) > 0 ? 0 : 1;
      }
      EXPECT_EQ(nonPositive, 0);
      EXPECT_EQ(CountAllZeroCells<D>(run.Values, mesh.Connectivity), allZeroBefore);
      const stm::MeshInvariantReport report =
        stm::CheckSimplicialMesh<D>(run.Points, mesh.Connectivity, nullptr);
      EXPECT_TRUE(report.IsValid()) << report.Summary();
      EXPECT_EQ(std::count(run.Nudged.begin(), run.Nudged.end(), 1), run.Counts.Nudged);
      for (std::size_t p = 0; p < run.Moved.size(); ++p)
      {
        if (run.Moved[p])
        {
          ASSERT_EQ(run.Values[p], 0.0);
        }
        else
        {
          if (run.Nudged[p])
          {
            // Nudged points keep their sign and place, and only move away from the surface.
            ASSERT_TRUE(run.Refused[p]);
            ASSERT_GT(std::abs(run.Values[p]), std::abs(values[p]));
            ASSERT_EQ(run.Values[p] < 0, values[p] < 0);
          }
          else
          {
            ASSERT_EQ(run.Values[p], values[p]);
          }
          for (int c = 0; c < D; ++c)
          {
            ASSERT_EQ(run.Points[p * D + c], points[p * D + c]);
          }
        }
      }

      // The cut makes no more cells than without snapping.
      const CutResult<D> snapped = Cut<D>(run.Points, run.Values, mesh.Connectivity);
      EXPECT_LE(snapped.Connectivity.size(), unsnapped.Connectivity.size());
      EXPECT_LT(snapped.CutEdges, unsnapped.CutEdges);
      const stm::MeshInvariantReport cutReport =
        stm::CheckSimplicialMesh<D>(snapped.Coordinates, snapped.Connectivity, nullptr);
      EXPECT_TRUE(cutReport.IsValid()) << cutReport.Summary();

      if (snapCase.Alpha == 0.5)
      {
        // Every edge still cut has a refused end.
        std::int64_t unexplained = 0;
        for (std::size_t cell = 0; cell < mesh.Connectivity.size() / (D + 1); ++cell)
        {
          const std::int64_t* ids = mesh.Connectivity.data() + cell * (D + 1);
          for (int a = 0; a <= D; ++a)
          {
            for (int b = a + 1; b <= D; ++b)
            {
              const double fa = run.Values[ids[a]], fb = run.Values[ids[b]];
              const bool cut = (fa < -1e-9 && fb > 1e-9) || (fa > 1e-9 && fb < -1e-9);
              unexplained += cut && !run.Refused[ids[a]] && !run.Refused[ids[b]] ? 1 : 0;
            }
          }
        }
        EXPECT_EQ(unexplained, 0);
      }
      if (snapCase.Bound > 0)
      {
        // The bound refuses snaps the plain rule makes: more refusals for quality, and the worst
        // element no worse than the plain rule's at the same Alpha on these fields.
        stm::VertexSnapOptions plain = options;
        plain.QualityBound = 0.0;
        const SnapRun<D> unbounded = Snap<D>(points, values, mesh.Connectivity, plain, sequential);
        EXPECT_EQ(unbounded.Counts.RefusedQuality, 0);
        EXPECT_LE(WorstCondition<D>(snapped),
          WorstCondition<D>(Cut<D>(unbounded.Points, unbounded.Values, mesh.Connectivity)));
        std::cout << D << "D seed " << seed << ": Alpha 0.45, bound 3: refused for quality "
                  << run.Counts.RefusedQuality << ", worst condition " << WorstCondition<D>(snapped)
                  << " (unbounded "
                  << WorstCondition<D>(
                       Cut<D>(unbounded.Points, unbounded.Values, mesh.Connectivity))
                  << ")\n";
      }
      if (snapCase.Rule == stm::SnapRule::QualityDriven)
      {
        EXPECT_LE(WorstCondition<D>(snapped), unsnappedWorst);
        std::cout << D << "D seed " << seed << ": quality-driven snapped " << run.Counts.Snapped
                  << ", refused for quality " << run.Counts.RefusedQuality << ", worst condition "
                  << WorstCondition<D>(snapped) << " (cut only " << unsnappedWorst << ")\n";
      }

      // The same bytes on four threads.
      stm::ThreadPoolExecutor threads(4);
      const SnapRun<D> threaded = Snap<D>(points, values, mesh.Connectivity, options, threads);
      ASSERT_TRUE(threaded.Result.IsOk());
      EXPECT_EQ(
        std::memcmp(threaded.Points.data(), run.Points.data(), run.Points.size() * sizeof(double)),
        0);
      EXPECT_EQ(
        std::memcmp(threaded.Values.data(), run.Values.data(), run.Values.size() * sizeof(double)),
        0);
      EXPECT_EQ(threaded.Moved, run.Moved);
      EXPECT_EQ(threaded.Refused, run.Refused);
      EXPECT_EQ(threaded.Nudged, run.Nudged);
      EXPECT_EQ(threaded.Counts.Snapped, run.Counts.Snapped);
      EXPECT_EQ(threaded.Counts.Nudged, run.Counts.Nudged);
      EXPECT_EQ(threaded.Counts.Rounds, run.Counts.Rounds);
      EXPECT_EQ(threaded.Counts.Revised, run.Counts.Revised);
    }
  }
}

// The paper's ball (Table 2) on a uniform n^d grid of checkerboard simplices: quality-driven
// snapping revisits the decisions that later neighbours made worse, which keeps every cut
// element of the ball (and of the disc in 2D) within the revisit threshold 2.5, below the
// paper's threshold rule and ours at Alpha = 1/3.
TYPED_TEST(VertexSnapMeshTest, QualityDrivenKeepsTheBallWithinTheRevisitThreshold)
{
  constexpr int D = TypeParam::value;
  for (const std::int64_t extent : { std::int64_t{ 20 }, std::int64_t{ D == 2 ? 120 : 40 } })
  {
    SCOPED_TRACE(::testing::Message() << "n = " << extent);
    LabelImage<D> image(UniformExtents<D>(extent));
    std::fill(image.GetValues().begin(), image.GetValues().end(), 1);
    stm::SequentialExecutor executor;
    stm::Spacetree<D> tree;
    ASSERT_TRUE(BuildTree<D>(image, 1, 1, false, executor, tree).IsOk());
    SimplicialMesh<D> mesh;
    ASSERT_TRUE(
      TessellateTree<D>(tree, stm::SpacetreeTessellationOptions(), executor, mesh).IsOk());
    const std::vector<double> points = mesh.Coordinates();
    double low = points[0], high = points[0];
    for (double coordinate : points)
    {
      low = std::min(low, coordinate);
      high = std::max(high, coordinate);
    }
    const double centre = 0.5 * (low + high);
    const double radius = 0.2525 * (high - low);
    std::vector<double> values(points.size() / D);
    for (std::size_t p = 0; p < values.size(); ++p)
    {
      double r2 = 0.0;
      for (int c = 0; c < D; ++c)
      {
        r2 += (points[p * D + c] - centre) * (points[p * D + c] - centre);
      }
      values[p] = r2 - radius * radius;
    }
    stm::VertexSnapOptions options;
    options.Rule = stm::SnapRule::QualityDriven;
    const SnapRun<D> run = Snap<D>(points, values, mesh.Connectivity, options, executor);
    ASSERT_TRUE(run.Result.IsOk()) << run.Result.GetMessage();
    const double worst = WorstCondition<D>(Cut<D>(run.Points, run.Values, mesh.Connectivity));
    const SnapRun<D> threshold = Snap<D>(points, values, mesh.Connectivity, Third);
    const double thresholdWorst =
      WorstCondition<D>(Cut<D>(threshold.Points, threshold.Values, mesh.Connectivity));
    std::cout << D << "D ball, n = " << extent << ": quality-driven worst " << worst << " (revised "
              << run.Counts.Revised << " in " << run.Counts.RevisionRounds
              << " rounds), threshold 1/3 worst " << thresholdWorst << "\n";
    EXPECT_LE(worst, 2.5);
    EXPECT_LE(worst, thresholdWorst);
    // Only on the 3D ball at n = 40 do the first decisions leave a cell above 2.5.
    EXPECT_EQ(run.Counts.Revised > 0, D == 3 && extent == 40);
    EXPECT_EQ(std::count(run.Moved.begin(), run.Moved.end(), 1), run.Counts.Snapped);
    EXPECT_EQ(std::count(run.Nudged.begin(), run.Nudged.end(), 1), run.Counts.Nudged);
    EXPECT_EQ(std::count(run.Refused.begin(), run.Refused.end(), 1), run.Counts.Refused());

    stm::ThreadPoolExecutor threads(2);
    const SnapRun<D> threaded = Snap<D>(points, values, mesh.Connectivity, options, threads);
    EXPECT_EQ(threaded.Points, run.Points);
    EXPECT_EQ(threaded.Values, run.Values);
    EXPECT_EQ(threaded.Counts.Revised, run.Counts.Revised);
  }
}

// Pieces of a distributed mesh (VertexSnapOptions::Exchange), each on its own thread with an
// exchange in memory: every piece cuts out its own cells (by the cells' centres along x) and
// three rings of ghost cells around them, and names points by their ids in the whole mesh.

template <int D>
struct MeshPiece
{
  std::vector<double> Points;
  std::vector<double> Values;
  std::vector<std::int64_t> Cells;
  std::vector<std::int64_t> GlobalIds; // per point of the piece
  std::vector<std::uint8_t> OwnPoints; // 1 on an own cell
};

/// Piece `piece` of `pieces` slabs along x: the cells whose centres lie in the slab, and
/// `rings` rings of ghost cells (cells that share a point with the previous ring).
template <int D>
MeshPiece<D> CutOutPiece(const std::vector<double>& points, const std::vector<double>& values,
  const std::vector<std::int64_t>& cells, int piece, int pieces, int rings)
{
  const std::size_t cellCount = cells.size() / (D + 1);
  std::vector<std::uint8_t> own, kept;
  CutOutSlab<D>(points, cells, piece, pieces, rings, own, kept);
  MeshPiece<D> result;
  std::vector<std::int64_t> local(values.size(), -1);
  std::vector<std::uint8_t> ownPoint(values.size(), 0);
  for (std::size_t c = 0; c < cellCount; ++c)
  {
    for (int k = 0; k <= D && kept[c]; ++k)
    {
      local[cells[c * (D + 1) + k]] = 0;
      ownPoint[cells[c * (D + 1) + k]] |= own[c];
    }
  }
  for (std::size_t p = 0; p < values.size(); ++p)
  {
    if (local[p] == 0) // in the whole mesh's order, which the ties by point id need
    {
      local[p] = static_cast<std::int64_t>(result.GlobalIds.size());
      result.GlobalIds.push_back(static_cast<std::int64_t>(p));
      result.OwnPoints.push_back(ownPoint[p]);
      result.Values.push_back(values[p]);
      result.Points.insert(
        result.Points.end(), points.begin() + p * D, points.begin() + (p + 1) * D);
    }
  }
  for (std::size_t c = 0; c < cellCount; ++c)
  {
    for (int k = 0; k <= D && kept[c]; ++k)
    {
      result.Cells.push_back(local[cells[c * (D + 1) + k]]);
    }
  }
  return result;
}

/// Snaps `pieces` pieces side by side (with or without exchanging) and counts the points of their
/// own cells whose place, value or flags differ from the whole mesh's run.
template <int D>
std::int64_t CountPieceDifferences(const std::vector<double>& points,
  const std::vector<double>& values, const std::vector<std::int64_t>& cells,
  const stm::VertexSnapOptions& options, int pieces, bool exchange, std::int64_t& unmatched)
{
  stm::SequentialExecutor executor;
  const SnapRun<D> whole = Snap<D>(points, values, cells, options, executor);
  EXPECT_TRUE(whole.Result.IsOk());
  std::vector<MeshPiece<D>> parts;
  for (int piece = 0; piece < pieces; ++piece)
  {
    parts.push_back(CutOutPiece<D>(points, values, cells, piece, pieces, 3));
  }
  PieceHub hub(pieces);
  std::vector<SnapRun<D>> runs(static_cast<std::size_t>(pieces));
  std::vector<std::int64_t> unmatchedPerPiece(runs.size(), 0);
  std::vector<std::thread> threads;
  for (int piece = 0; piece < pieces; ++piece)
  {
    threads.emplace_back(
      [&, piece]()
      {
        const MeshPiece<D>& part = parts[piece];
        MemoryExchange memory(hub, piece,
          std::vector<double>(part.GlobalIds.begin(), part.GlobalIds.end()), 1, part.OwnPoints);
        stm::VertexSnapOptions pieceOptions = options;
        pieceOptions.Exchange = exchange ? &memory : nullptr;
        stm::SequentialExecutor pieceExecutor;
        runs[piece] = Snap<D>(part.Points, part.Values, part.Cells, pieceOptions, pieceExecutor);
        unmatchedPerPiece[piece] = memory.Unmatched;
      });
  }
  for (std::thread& thread : threads)
  {
    thread.join();
  }
  std::int64_t differing = 0;
  unmatched = 0;
  for (int piece = 0; piece < pieces; ++piece)
  {
    EXPECT_TRUE(runs[piece].Result.IsOk()) << runs[piece].Result.GetMessage();
    unmatched += unmatchedPerPiece[piece];
    const MeshPiece<D>& part = parts[piece];
    for (std::size_t p = 0; p < part.GlobalIds.size(); ++p)
    {
      const auto g = static_cast<std::size_t>(part.GlobalIds[p]);
      if (!part.OwnPoints[p])
      {
        continue;
      }
      const bool same = std::equal(runs[piece].Points.begin() + p * D,
                          runs[piece].Points.begin() + (p + 1) * D, whole.Points.begin() + g * D) &&
        runs[piece].Values[p] == whole.Values[g] && runs[piece].Moved[p] == whole.Moved[g] &&
        runs[piece].Nudged[p] == whole.Nudged[g] && runs[piece].Refused[p] == whole.Refused[g];
      differing += same ? 0 : 1;
    }
  }
  return differing;
}

// Pieces with three rings of ghost cells that exchange their states after every round decide the
// points of their own cells as the whole mesh does, bit for bit, with both rules, 2 and 3 pieces
// (a point then lies on own cells of one, two or three pieces). Without the exchange they do not
// on a plane between lattice planes, flat or with a wave, whose equal cut distances leave the
// conflicts to the point ids: those decisions chain further than three rings.
TYPED_TEST(VertexSnapMeshTest, PiecesThatExchangeDecideAsTheWholeMesh)
{
  constexpr int D = TypeParam::value;
  const std::int64_t extent = D == 2 ? 32 : 12;
  std::int64_t differingWithout = 0;
  for (unsigned seed = 1; seed <= 3; ++seed)
  {
    const SimplicialMesh<D> mesh = AdaptiveMesh<D>(seed, extent);
    const std::vector<double> points = mesh.Coordinates();
    std::vector<double> values = RandomField<D>(points, static_cast<double>(extent), seed);
    for (std::size_t p = 0; p < values.size() && seed < 3; ++p)
    {
      values[p] = points[p * D + D - 1] - (0.5 * static_cast<double>(extent) + 0.25) +
        (seed == 2 ? 0.1 * std::sin(1.7 * points[p * D + 1]) : 0.0);
    }
    for (stm::SnapRule rule : { stm::SnapRule::Threshold, stm::SnapRule::QualityDriven })
    {
      for (int pieces : { 2, 3 })
      {
        SCOPED_TRACE(::testing::Message()
          << "seed " << seed << ", rule " << static_cast<int>(rule) << ", pieces " << pieces);
        stm::VertexSnapOptions options;
        options.Rule = rule;
        std::int64_t unmatched = 0;
        EXPECT_EQ(CountPieceDifferences<D>(
                    points, values, mesh.Connectivity, options, pieces, true, unmatched),
          0);
        EXPECT_EQ(unmatched, 0);
        differingWithout += CountPieceDifferences<D>(
          points, values, mesh.Connectivity, options, pieces, false, unmatched);
      }
    }
  }
  std::cout << D << "D: " << differingWithout
            << " own points of the pieces differ from the whole mesh's without the exchange\n";
  EXPECT_GT(differingWithout, 0);
}

template <class T>
class VertexSnapSmokeTest : public ::testing::Test
{
};
using SmokeDimensions = ::testing::Types<Dim<1>, Dim<4>>;
TYPED_TEST_SUITE(VertexSnapSmokeTest, SmokeDimensions);

// 1D and 4D: snapping works, keeps every cell positive, and is thread independent.
TYPED_TEST(VertexSnapSmokeTest, SnapsAndKeepsCellsPositive)
{
  constexpr int D = TypeParam::value;
  const std::int64_t extent = D == 1 ? 40 : 4;
  const SimplicialMesh<D> mesh = AdaptiveMesh<D>(2, extent);
  const std::vector<double> points = mesh.Coordinates();
  const std::vector<double> values = RandomField<D>(points, static_cast<double>(extent), 9);
  for (stm::SnapRule rule : { stm::SnapRule::Threshold, stm::SnapRule::QualityDriven })
  {
    stm::VertexSnapOptions options;
    options.Rule = rule;
    stm::SequentialExecutor sequential;
    const SnapRun<D> run = Snap<D>(points, values, mesh.Connectivity, options, sequential);
    ASSERT_TRUE(run.Result.IsOk());
    EXPECT_GT(run.Counts.Snapped, 0);
    for (std::int64_t cell = 0; cell < mesh.GetNumberOfSimplices(); ++cell)
    {
      ASSERT_GT(ScaledVolume<D>(run.Points, mesh.Connectivity.data() + cell * (D + 1)), 0.0);
    }
    const CutResult<D> snapped = Cut<D>(run.Points, run.Values, mesh.Connectivity);
    EXPECT_LE(
      snapped.Connectivity.size(), Cut<D>(points, values, mesh.Connectivity).Connectivity.size());
    stm::ThreadPoolExecutor threads(4);
    const SnapRun<D> threaded = Snap<D>(points, values, mesh.Connectivity, options, threads);
    EXPECT_EQ(threaded.Points, run.Points);
    EXPECT_EQ(threaded.Moved, run.Moved);
  }
}

// The gradient the gray-image projection follows: the d-linear interpolant's, equal to central
// differences inside a dual cell, and the value equal to Sample's.
TEST(VertexSnap, DualGridGradientMatchesDifferences)
{
  const double voxels[2 * 3 * 2] = { 0.5, -1, 2, 3, -4, 0.25, 1, 7, -2, 0, 5, -3 };
  const stm::VoxelField<3, double> field{ { 2, 3, 2 }, voxels, 9.0 };
  std::mt19937 random(4);
  std::uniform_real_distribution<double> coordinate(-0.7, 3.7);
  for (int trial = 0; trial < 200; ++trial)
  {
    double x[3] = { coordinate(random), coordinate(random), coordinate(random) };
    double gradient[3];
    EXPECT_EQ(field.SampleWithGradient(x, gradient), field.Sample(x));
    for (int axis = 0; axis < 3; ++axis)
    {
      const double h = 1e-6;
      double forward[3] = { x[0], x[1], x[2] }, backward[3] = { x[0], x[1], x[2] };
      forward[axis] += h;
      backward[axis] -= h;
      if (std::floor(forward[axis] - 0.5) != std::floor(backward[axis] - 0.5))
      {
        continue; // across a dual cell face the interpolant has a kink
      }
      EXPECT_NEAR(gradient[axis], (field.Sample(forward) - field.Sample(backward)) / (2 * h), 1e-6);
    }
  }
}

// A gray image's field closed at the image's boundary (stm::ClosedVoxelField): beyond the
// image the nearest voxel's magnitude, so an inside voxel at the boundary puts the zero set on
// it; and a box that holds the voxels within one voxel of every sampled point gives the whole
// image's values bit for bit (a piece's sub-extent read), NaN where it does not.
template <int D>
void CheckClosedVoxelField()
{
  std::mt19937 random(7 + D);
  stm::LatticeIndex<D> dimensions;
  std::int64_t count = 1;
  for (int axis = 0; axis < D; ++axis)
  {
    dimensions[axis] = 4 + axis;
    count *= dimensions[axis];
  }
  std::uniform_real_distribution<double> value(-3.0, 3.0);
  std::vector<double> voxels(static_cast<std::size_t>(count));
  for (double& v : voxels)
  {
    v = value(random);
  }
  const auto flat = [&](const stm::LatticeIndex<D>& voxel)
  {
    std::int64_t index = 0;
    for (int axis = D - 1; axis >= 0; --axis)
    {
      index = index * dimensions[axis] + voxel[axis];
    }
    return index;
  };
  stm::ClosedVoxelField<D, double> whole;
  whole.Dimensions = dimensions;
  whole.BoxDimensions = dimensions;
  whole.Values = voxels.data();
  // Beyond the image: the nearest voxel's magnitude.
  std::uniform_int_distribution<int> offset(-3, 3);
  for (int trial = 0; trial < 300; ++trial)
  {
    stm::LatticeIndex<D> voxel, nearest;
    bool beyond = false;
    for (int axis = 0; axis < D; ++axis)
    {
      voxel[axis] = offset(random) + (trial % 2 ? dimensions[axis] - 1 : 0);
      nearest[axis] =
        std::min<std::int64_t>(std::max<std::int64_t>(voxel[axis], 0), dimensions[axis] - 1);
      beyond = beyond || nearest[axis] != voxel[axis];
    }
    const double expected = voxels[static_cast<std::size_t>(flat(nearest))];
    EXPECT_EQ(whole.At(voxel), beyond ? std::abs(expected) : expected);
  }
  // An inside voxel at the boundary: f = 0 on the boundary facet's centre.
  stm::LatticeIndex<D> first{};
  voxels[static_cast<std::size_t>(flat(first))] = -2.5;
  double facet[D];
  for (int axis = 0; axis < D; ++axis)
  {
    facet[axis] = 0.5;
  }
  facet[0] = 0.0;
  EXPECT_EQ(whole.Sample(facet), 0.0);
  // A box of the image: the whole image's values wherever the box holds the voxels within one
  // voxel of the point (clamped into the image), NaN where it misses one.
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial)
  {
    stm::ClosedVoxelField<D, double> box;
    box.Dimensions = dimensions;
    std::int64_t boxCount = 1;
    for (int axis = 0; axis < D; ++axis)
    {
      std::uniform_int_distribution<std::int64_t> start(0, dimensions[axis] - 2);
      box.BoxFirst[axis] = start(random);
      std::uniform_int_distribution<std::int64_t> size(2, dimensions[axis] - box.BoxFirst[axis]);
      box.BoxDimensions[axis] = size(random);
      boxCount *= box.BoxDimensions[axis];
    }
    std::vector<double> held;
    ForEachIndex<D>(box.BoxDimensions,
      [&](const stm::LatticeIndex<D>& local)
      {
        stm::LatticeIndex<D> voxel;
        for (int axis = 0; axis < D; ++axis)
        {
          voxel[axis] = local[axis] + box.BoxFirst[axis];
        }
        held.push_back(voxels[static_cast<std::size_t>(flat(voxel))]);
      });
    ASSERT_EQ(static_cast<std::int64_t>(held.size()), boxCount);
    box.Values = held.data();
    int inside = 0;
    int missed = 0;
    for (int sample = 0; sample < 100; ++sample)
    {
      double position[D];
      bool covered = true;
      for (int axis = 0; axis < D; ++axis)
      {
        // Voxel units, from 1.5 voxels before the image to 1.5 beyond it.
        position[axis] = -1.5 + unit(random) * (static_cast<double>(dimensions[axis]) + 3.0);
        const auto lower = static_cast<std::int64_t>(std::floor(position[axis] - 0.5));
        for (std::int64_t v = lower; v <= lower + 1; ++v)
        {
          const std::int64_t nearest =
            std::min<std::int64_t>(std::max<std::int64_t>(v, 0), dimensions[axis] - 1);
          covered = covered && nearest >= box.BoxFirst[axis] &&
            nearest < box.BoxFirst[axis] + box.BoxDimensions[axis];
        }
      }
      double gradient[D], boxGradient[D];
      const double expected = whole.SampleWithGradient(position, gradient);
      const double got = box.SampleWithGradient(position, boxGradient);
      if (covered)
      {
        ++inside;
        EXPECT_EQ(got, expected);
        EXPECT_EQ(box.Sample(position), whole.Sample(position));
        for (int axis = 0; axis < D; ++axis)
        {
          EXPECT_EQ(boxGradient[axis], gradient[axis]);
        }
      }
      else
      {
        ++missed;
        EXPECT_TRUE(std::isnan(got));
      }
    }
    EXPECT_GT(inside + missed, 0);
  }
}

TEST(VertexSnap, ClosedVoxelField2D)
{
  CheckClosedVoxelField<2>();
}

TEST(VertexSnap, ClosedVoxelField3D)
{
  CheckClosedVoxelField<3>();
}

TEST(VertexSnap, ClosedVoxelField4D)
{
  CheckClosedVoxelField<4>();
}

} // namespace
