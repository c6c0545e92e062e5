// SPDX-License-Identifier: BSD-3-Clause
// Splitting edges inside one material (InteriorEdgeSplit) in 2D and 3D: the star of a long
// interior edge (two flat triangles; six needle tetrahedra around a hexagon) is split at its
// midpoint, which the symmetric search keeps, into a conforming mesh of less bad cells with the
// same volume per material; an edge between two materials, on the outer boundary or with a held
// end is never split, and bad options are refused. The pieces of a distributed mesh, run side
// by side in threads with an exchange, split the edges the whole mesh's run splits.

#include "CoreTestUtilities.h"

#include "Check/MeshInvariants.h"
#include "Check/SimplexQuality.h"
#include "Common/Execution.h"
#include "Smooth/InteriorEdgeSplit.h"
#include "Smooth/SmoothingExchange.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

namespace
{
template <int D>
struct StarMesh
{
  std::vector<double> Points;
  std::vector<std::int64_t> Cells;
  std::vector<std::int64_t> Materials;
};

/// Orders each cell's corners so that it has VTK's (positive) orientation.
template <int D>
void Orient(StarMesh<D>& mesh)
{
  for (std::size_t c = 0; c < mesh.Materials.size(); ++c)
  {
    const double* corners[D + 1];
    for (int v = 0; v <= D; ++v)
    {
      corners[v] = mesh.Points.data() + mesh.Cells[c * (D + 1) + v] * D;
    }
    if (stm::MeasureSimplex<D>(corners).Determinant < 0.0)
    {
      std::swap(mesh.Cells[c * (D + 1)], mesh.Cells[c * (D + 1) + 1]);
    }
  }
}

/// 2D: the edge from (-1, 0) to (1, 0) (points 0, 1) between the triangles to (0, 0.3) and
/// (0, -0.3): smallest angle 16.7 degrees, condition number 2.97. 3D: the edge from (0, 0, -1)
/// to (0, 0, 1) inside six tetrahedra around a hexagon of radius 0.35 in z = 0 (2.57).
template <int D>
StarMesh<D> Star()
{
  StarMesh<D> mesh;
  if constexpr (D == 2)
  {
    mesh.Points = { -1.0, 0.0, 1.0, 0.0, 0.0, 0.3, 0.0, -0.3 };
    mesh.Cells = { 0, 1, 2, 0, 1, 3 };
  }
  else
  {
    mesh.Points = { 0.0, 0.0, -1.0, 0.0, 0.0, 1.0 };
    for (int k = 0; k < 6; ++k)
    {
      const double angle = k * 3.14159265358979323846 / 3.0;
      mesh.Points.insert(
        mesh.Points.end(), { 0.35 * std::cos(angle), 0.35 * std::sin(angle), 0.0 });
      mesh.Cells.insert(mesh.Cells.end(), { 0, 1, 2 + k, 2 + (k + 1) % 6 });
    }
  }
  mesh.Materials.assign(mesh.Cells.size() / (D + 1), 1);
  Orient<D>(mesh);
  return mesh;
}

/// The mesh with the edits applied.
template <int D>
StarMesh<D> Apply(const StarMesh<D>& mesh, const stm::InteriorEdgeSplit<D>& split)
{
  StarMesh<D> out = mesh;
  for (const auto& point : split.GetNewPoints())
  {
    out.Points.insert(out.Points.end(), point.Position.begin(), point.Position.end());
  }
  for (const auto& changed : split.GetChangedCells())
  {
    std::copy(
      changed.second.begin(), changed.second.end(), out.Cells.begin() + changed.first * (D + 1));
  }
  for (std::size_t c = 0; c < split.GetAppendedCells().size(); ++c)
  {
    const auto& ids = split.GetAppendedCells()[c];
    out.Cells.insert(out.Cells.end(), ids.begin(), ids.end());
    out.Materials.push_back(mesh.Materials[split.GetAppendedParents()[c]]);
  }
  return out;
}

template <int D>
stm::Status RunSplit(const StarMesh<D>& mesh, const stm::InteriorEdgeSplitOptions& options,
  stm::InteriorEdgeSplit<D>& split)
{
  stm::SequentialExecutor executor;
  return split.Split(mesh.Points.data(), static_cast<std::int64_t>(mesh.Points.size() / D),
    mesh.Cells.data(), static_cast<std::int64_t>(mesh.Materials.size()), mesh.Materials.data(),
    options, executor);
}

template <class T>
class InteriorEdgeSplitTest : public ::testing::Test
{
};
using SplitDimensions =
  ::testing::Types<std::integral_constant<int, 2>, std::integral_constant<int, 3>>;
TYPED_TEST_SUITE(InteriorEdgeSplitTest, SplitDimensions);

// The star's edge is split once at its midpoint: every cell of the star becomes two (the first
// keeps its slot), the mesh stays conforming with the same volume and outer boundary, and the
// worst condition number falls below the bound of 2 (2D: 2.97 -> 2.10, 3D: 2.57 -> 1.86).
TYPED_TEST(InteriorEdgeSplitTest, LongInteriorEdgeIsSplitAtItsMidpoint)
{
  constexpr int D = TypeParam::value;
  const StarMesh<D> mesh = Star<D>();
  const std::int64_t cells = static_cast<std::int64_t>(mesh.Materials.size());
  stm::InteriorEdgeSplitOptions options;
  options.MaxConditionNumber = 2.0;
  const double before = stmtest::WorstSimplexCondition<D>(mesh.Points, mesh.Cells);
  EXPECT_GT(before, options.MaxConditionNumber);
  stm::InteriorEdgeSplit<D> split;
  ASSERT_TRUE(RunSplit<D>(mesh, options, split).IsOk());
  EXPECT_EQ(split.GetNumberOfCandidates(), cells);
  ASSERT_EQ(split.GetNewPoints().size(), 1u);
  EXPECT_EQ(split.GetNewPoints()[0].A + split.GetNewPoints()[0].B, 1); // the edge (0, 1)
  for (int c = 0; c < D; ++c)
  {
    EXPECT_EQ(split.GetNewPoints()[0].Position[c], 0.0);
  }
  EXPECT_EQ(static_cast<std::int64_t>(split.GetChangedCells().size()), cells);
  EXPECT_EQ(static_cast<std::int64_t>(split.GetAppendedCells().size()), cells);
  const StarMesh<D> out = Apply<D>(mesh, split);
  const stm::MeshInvariantReport report =
    stm::CheckSimplicialMesh<D>(out.Points, out.Cells, &out.Materials);
  EXPECT_TRUE(report.IsValid());
  EXPECT_EQ(report.NumberOfCells, 2 * cells);
  const stm::MeshInvariantReport input =
    stm::CheckSimplicialMesh<D>(mesh.Points, mesh.Cells, &mesh.Materials);
  EXPECT_NEAR(report.VolumePerMaterial.at(1), input.VolumePerMaterial.at(1), 1e-14);
  EXPECT_EQ(report.BoundaryFacets, input.BoundaryFacets);
  const double after = stmtest::WorstSimplexCondition<D>(out.Points, out.Cells);
  EXPECT_LT(after, before);
  EXPECT_NEAR(before, D == 2 ? 2.97335 : 2.57477, 1e-5);
  EXPECT_NEAR(after, D == 2 ? 2.09771 : 1.86476, 1e-5);
  EXPECT_LT(split.GetWorstBadnessAfter(), split.GetWorstBadnessBefore());
}

// An edge between two materials, or on the outer boundary (one cell of the 3D star removed; in
// 2D one triangle), is never split; cells within the bounds are no candidates.
TYPED_TEST(InteriorEdgeSplitTest, EdgesOnInterfacesOrTheBoundaryStay)
{
  constexpr int D = TypeParam::value;
  stm::InteriorEdgeSplitOptions options;
  options.MaxConditionNumber = 2.0;
  StarMesh<D> mixed = Star<D>();
  mixed.Materials[0] = 2;
  stm::InteriorEdgeSplit<D> split;
  ASSERT_TRUE(RunSplit<D>(mixed, options, split).IsOk());
  EXPECT_GT(split.GetNumberOfCandidates(), 0);
  EXPECT_TRUE(split.GetNewPoints().empty());
  EXPECT_TRUE(split.GetChangedCells().empty());
  EXPECT_TRUE(split.GetAppendedCells().empty());

  StarMesh<D> open = Star<D>();
  open.Cells.resize(open.Cells.size() - (D + 1));
  open.Materials.pop_back();
  ASSERT_TRUE(RunSplit<D>(open, options, split).IsOk());
  EXPECT_GT(split.GetNumberOfCandidates(), 0);
  EXPECT_TRUE(split.GetNewPoints().empty());

  options.MaxConditionNumber = 10.0;
  options.MinDihedralAngle = 1.0;
  ASSERT_TRUE(RunSplit<D>(Star<D>(), options, split).IsOk());
  EXPECT_EQ(split.GetNumberOfCandidates(), 0);
  EXPECT_TRUE(split.GetNewPoints().empty());
}

// In a piece of a larger mesh the points of its ghost cells are held: an edge with a held end
// is never split, and holding a point off the edge leaves the split as it was.
TYPED_TEST(InteriorEdgeSplitTest, EdgesWithAHeldEndStay)
{
  constexpr int D = TypeParam::value;
  const StarMesh<D> mesh = Star<D>();
  stm::InteriorEdgeSplitOptions options;
  options.MaxConditionNumber = 2.0;
  std::vector<std::uint8_t> held(mesh.Points.size() / D, 0);
  options.HeldPoints = held.data();
  for (const int end : { 0, 1 })
  {
    std::fill(held.begin(), held.end(), 0);
    held[end] = 1;
    stm::InteriorEdgeSplit<D> split;
    ASSERT_TRUE(RunSplit<D>(mesh, options, split).IsOk());
    EXPECT_GT(split.GetNumberOfCandidates(), 0);
    EXPECT_TRUE(split.GetNewPoints().empty()) << "end " << end;
    EXPECT_TRUE(split.GetChangedCells().empty());
    EXPECT_TRUE(split.GetAppendedCells().empty());
  }
  std::fill(held.begin(), held.end(), 0);
  held[2] = 1; // a corner of the star off the edge
  stm::InteriorEdgeSplit<D> split;
  ASSERT_TRUE(RunSplit<D>(mesh, options, split).IsOk());
  ASSERT_EQ(split.GetNewPoints().size(), 1u);
  EXPECT_EQ(split.GetNewPoints()[0].A + split.GetNewPoints()[0].B, 1); // the edge (0, 1)
  EXPECT_EQ(split.GetAppendedCells().size(), mesh.Materials.size());
}

/// The exchange of pieces that run side by side in threads of one process: Gather waits for
/// every piece's values of the same call.
class ThreadExchange
{
public:
  explicit ThreadExchange(int pieces)
    : Pieces(pieces)
  {
  }
  class Piece : public stm::SmoothingExchange
  {
  public:
    Piece(ThreadExchange& all, int rank)
      : All(all)
      , Rank(rank)
    {
    }
    bool AllReady(bool ready) override { return this->Maximum(ready ? 0.0 : 1.0) == 0.0; }
    void Share(double*, int, int, std::vector<std::int64_t>*) override
    {
      ADD_FAILURE() << "the edge splits share no point values";
    }
    double Maximum(double value) override
    {
      const std::vector<double> all = this->Gather({ value });
      return *std::max_element(all.begin(), all.end());
    }
    std::vector<double> Gather(const std::vector<double>& values) override
    {
      return this->All.Gather(this->Rank, this->Calls++, values);
    }

  private:
    ThreadExchange& All;
    int Rank;
    int Calls = 0;
  };

private:
  std::vector<double> Gather(int rank, int call, const std::vector<double>& values)
  {
    std::unique_lock<std::mutex> lock(this->Mutex);
    auto& round = this->Rounds[call];
    round.resize(static_cast<std::size_t>(this->Pieces));
    round[static_cast<std::size_t>(rank)] = values;
    ++this->Arrived[call];
    this->Changed.notify_all();
    this->Changed.wait(lock, [&] { return this->Arrived[call] == this->Pieces; });
    std::vector<double> all;
    for (const auto& piece : round)
    {
      all.insert(all.end(), piece.begin(), piece.end());
    }
    return all;
  }

  int Pieces;
  std::mutex Mutex;
  std::condition_variable Changed;
  std::map<int, std::vector<std::vector<double>>> Rounds;
  std::map<int, int> Arrived;
};

/// A Kuhn grid of n^D unit cubes with its inner points moved by up to 0.35 (a fixed hash, not a
/// library random generator, so that every platform has the same mesh) and two materials
/// (below and above the middle of axis 1): many cells beyond the default bounds, with interior
/// edges near the planes x = const that cut it into pieces.
template <int D>
StarMesh<D> JitteredGrid(int n)
{
  StarMesh<D> mesh;
  std::int64_t points = 0;
  mesh.Cells = stmtest::KuhnGrid<D>(n, points);
  for (std::int64_t p = 0; p < points; ++p)
  {
    std::uint64_t hash = static_cast<std::uint64_t>(p) * 0x9E3779B97F4A7C15ull + 12345u;
    for (int d = 0, rest = static_cast<int>(p); d < D; ++d, rest /= n + 1)
    {
      const int x = rest % (n + 1);
      hash ^= hash >> 29;
      hash *= 0xBF58476D1CE4E5B9ull;
      const double jitter = (static_cast<double>(hash >> 40) / (1u << 24) - 0.5) * 0.7;
      mesh.Points.push_back(x + (x > 0 && x < n ? jitter : 0.0));
    }
  }
  const std::size_t cells = mesh.Cells.size() / (D + 1);
  for (std::size_t c = 0; c < cells; ++c)
  {
    double middle = 0.0;
    for (int v = 0; v <= D; ++v)
    {
      middle += mesh.Points[mesh.Cells[c * (D + 1) + v] * D + 1] / (D + 1);
    }
    mesh.Materials.push_back(middle < 0.5 * n ? 1 : 2);
  }
  Orient<D>(mesh);
  return mesh;
}

/// A cell as its material and its corners' coordinates, sorted: the same in any numbering.
template <int D>
using CellByPlace = std::pair<std::int64_t, std::array<std::array<double, D>, D + 1>>;
template <int D>
CellByPlace<D> PlaceOf(const StarMesh<D>& mesh, std::size_t cell)
{
  CellByPlace<D> place;
  place.first = mesh.Materials[cell];
  for (int v = 0; v <= D; ++v)
  {
    std::copy_n(mesh.Points.begin() + mesh.Cells[cell * (D + 1) + v] * D, D,
      place.second[static_cast<std::size_t>(v)].begin());
  }
  std::sort(place.second.begin(), place.second.end());
  return place;
}

/// A piece of `mesh`: the cells whose first corner lies in the slab [x0, x1) of axis 0 as its
/// own, the cells at their points as ghosts, numbered backwards (another numbering than the
/// whole mesh's).
template <int D>
StarMesh<D> PieceOf(
  const StarMesh<D>& mesh, double x0, double x1, std::vector<std::uint8_t>& ghosts)
{
  const std::size_t cells = mesh.Materials.size();
  std::vector<std::uint8_t> own(cells, 0), atOwnPoint(mesh.Points.size() / D, 0);
  for (std::size_t c = 0; c < cells; ++c)
  {
    const double x = mesh.Points[mesh.Cells[c * (D + 1)] * D];
    own[c] = x >= x0 && x < x1;
    for (int v = 0; v <= D && own[c]; ++v)
    {
      atOwnPoint[mesh.Cells[c * (D + 1) + v]] = 1;
    }
  }
  StarMesh<D> piece;
  ghosts.clear();
  std::map<std::int64_t, std::int64_t> local;
  std::vector<std::int64_t> kept;
  for (std::size_t c = cells; c-- > 0;)
  {
    bool near = false;
    for (int v = 0; v <= D; ++v)
    {
      near = near || atOwnPoint[mesh.Cells[c * (D + 1) + v]];
    }
    if (!near)
    {
      continue;
    }
    for (int v = D; v >= 0; --v)
    {
      local.emplace(-mesh.Cells[c * (D + 1) + v], 0);
    }
    kept.push_back(static_cast<std::int64_t>(c));
  }
  std::int64_t next = 0;
  for (auto& point : local)
  {
    point.second = next++;
    std::copy_n(mesh.Points.begin() + (-point.first) * D, D, std::back_inserter(piece.Points));
  }
  for (const std::int64_t c : kept)
  {
    for (int v = 0; v <= D; ++v)
    {
      piece.Cells.push_back(local.at(-mesh.Cells[c * (D + 1) + v]));
    }
    piece.Materials.push_back(mesh.Materials[c]);
    ghosts.push_back(own[c] ? 0 : 1);
  }
  return piece;
}

// P = 2 and 3 pieces (slabs of axis 0, numbered otherwise than the whole mesh) split the edges
// the whole mesh's run splits: the pieces' own cells together are the whole result's cells by
// place, and every ghost cell of a piece is one of them too (the pieces agree where they
// overlap); some split edges have cells in two pieces. Every piece reports the whole mesh's
// candidates and worst badness.
TYPED_TEST(InteriorEdgeSplitTest, PiecesSplitTheEdgesTheWholeMeshSplits)
{
  constexpr int D = TypeParam::value;
  const int n = D == 2 ? 12 : 6;
  const StarMesh<D> mesh = JitteredGrid<D>(n);
  const stm::InteriorEdgeSplitOptions options;
  stm::InteriorEdgeSplit<D> whole;
  ASSERT_TRUE(RunSplit<D>(mesh, options, whole).IsOk());
  const StarMesh<D> wholeOut = Apply<D>(mesh, whole);
  ASSERT_TRUE(
    stm::CheckSimplicialMesh<D>(wholeOut.Points, wholeOut.Cells, &wholeOut.Materials).IsValid());
  // 2D: 14 edges for 14 candidates; 3D: 52 for 61.
  EXPECT_EQ(whole.GetNewPoints().size(), D == 2 ? 14u : 52u);
  EXPECT_EQ(whole.GetNumberOfCandidates(), D == 2 ? 14 : 61);
  std::multiset<CellByPlace<D>> expected;
  for (std::size_t c = 0; c < wholeOut.Materials.size(); ++c)
  {
    expected.insert(PlaceOf<D>(wholeOut, c));
  }

  for (const int pieces : { 2, 3 })
  {
    std::vector<StarMesh<D>> inputs(static_cast<std::size_t>(pieces));
    std::vector<std::vector<std::uint8_t>> ghosts(inputs.size());
    std::vector<stm::InteriorEdgeSplit<D>> splits(inputs.size());
    std::vector<stm::Status> statuses(inputs.size());
    ThreadExchange exchange(pieces);
    std::vector<std::thread> threads;
    for (int rank = 0; rank < pieces; ++rank)
    {
      const double x0 = rank == 0 ? -1.0 : rank * double(n) / pieces;
      const double x1 = rank == pieces - 1 ? n + 1.0 : (rank + 1) * double(n) / pieces;
      inputs[rank] = PieceOf<D>(mesh, x0, x1, ghosts[rank]);
      threads.emplace_back(
        [&, rank]
        {
          ThreadExchange::Piece link(exchange, rank);
          stm::InteriorEdgeSplitOptions pieceOptions;
          pieceOptions.Exchange = &link;
          pieceOptions.GhostCells = ghosts[rank].data();
          statuses[rank] = RunSplit<D>(inputs[rank], pieceOptions, splits[rank]);
        });
    }
    for (auto& thread : threads)
    {
      thread.join();
    }
    std::multiset<CellByPlace<D>> owned;
    std::map<std::array<double, D>, int> newPointPieces;
    for (int rank = 0; rank < pieces; ++rank)
    {
      ASSERT_TRUE(statuses[rank].IsOk()) << statuses[rank].GetMessage();
      EXPECT_EQ(splits[rank].GetNumberOfCandidates(), whole.GetNumberOfCandidates());
      EXPECT_EQ(splits[rank].GetWorstBadnessBefore(), whole.GetWorstBadnessBefore());
      EXPECT_EQ(splits[rank].GetWorstBadnessAfter(), whole.GetWorstBadnessAfter());
      const StarMesh<D> out = Apply<D>(inputs[rank], splits[rank]);
      const std::size_t inputCells = inputs[rank].Materials.size();
      for (std::size_t c = 0; c < out.Materials.size(); ++c)
      {
        const std::size_t parent =
          c < inputCells ? c : splits[rank].GetAppendedParents()[c - inputCells];
        const CellByPlace<D> place = PlaceOf<D>(out, c);
        EXPECT_EQ(expected.count(place), 1u) << pieces << " pieces, rank " << rank;
        if (!ghosts[rank][parent])
        {
          owned.insert(place);
        }
      }
      for (const auto& point : splits[rank].GetNewPoints())
      {
        ++newPointPieces[point.Position];
      }
    }
    EXPECT_TRUE(owned == expected) << pieces << " pieces";
    EXPECT_EQ(newPointPieces.size(), whole.GetNewPoints().size());
    EXPECT_TRUE(std::any_of(newPointPieces.begin(), newPointPieces.end(),
      [](const auto& point) { return point.second > 1; }))
      << "no split edge has cells in two pieces";
  }
}

TEST(InteriorEdgeSplit, RejectsBadOptionsAndIds)
{
  StarMesh<3> mesh = Star<3>();
  stm::InteriorEdgeSplit<3> split;
  stm::InteriorEdgeSplitOptions options;
  options.MaxConditionNumber = 0.5;
  EXPECT_EQ(RunSplit<3>(mesh, options, split).GetCode(), stm::Status::Code::InvalidArgument);
  options = stm::InteriorEdgeSplitOptions();
  options.MinDihedralAngle = 180.0;
  EXPECT_EQ(RunSplit<3>(mesh, options, split).GetCode(), stm::Status::Code::InvalidArgument);
  mesh.Cells[3] = 8;
  EXPECT_EQ(RunSplit<3>(mesh, stm::InteriorEdgeSplitOptions(), split).GetCode(),
    stm::Status::Code::InvalidArgument);
}
} // namespace
