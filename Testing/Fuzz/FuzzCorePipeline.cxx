// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the whole VTK-free core: the fuzz input is decoded into a small 2D or 3D
// label image, a refinement pattern, a balance level and the stage parameters; every stage runs
// (build, balance, tessellate, the multi-material cut with its snap, the binary cut of the labels
// function after VertexSnap, boundary smoothing) and the mesh invariants are checked after each
// one. A stage may refuse its input with an error status; it may not crash, hang, or return an
// invalid mesh. Any broken invariant aborts with a description, which libFuzzer reports.
//
// The same file is built without libFuzzer by FuzzReplayMain.cxx, so the seed corpus replays as
// an ordinary test in every build.

#include "Balance/SpacetreeBalance.h"
#include "Check/MeshInvariants.h"
#include "Common/Execution.h"
#include "Common/Status.h"
#include "Cut/MarchingSimplices.h"
#include "Cut/MultiMaterialCut.h"
#include "Cut/SeparatingFunction.h"
#include "Cut/VertexSnap.h"
#include "Smooth/BoundarySmooth.h"
#include "Spacetree/Spacetree.h"
#include "Spacetree/SpacetreeBuild.h"
#include "Spacetree/SpacetreeValidate.h"
#include "Spacetree/ThinParts.h"
#include "Tessellate/SpacetreeTessellation.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace
{

/// Reads the fuzz input as a stream of bytes; past its end every byte is 0, so that any input,
/// even an empty one, decodes to a case.
class ByteStream
{
public:
  ByteStream(const std::uint8_t* data, std::size_t size)
    : Data(data)
    , Size(size)
  {
  }

  std::uint8_t Next() { return this->Position < this->Size ? this->Data[this->Position++] : 0; }
  /// A value in [low, high].
  int Range(int low, int high) { return low + this->Next() % (high - low + 1); }

private:
  const std::uint8_t* Data;
  std::size_t Size;
  std::size_t Position = 0;
};

[[noreturn]] void Fail(const std::string& what)
{
  std::fprintf(stderr, "FuzzCorePipeline: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

void Require(bool condition, const std::string& what)
{
  if (!condition)
  {
    Fail(what);
  }
}

/// The parameters of one case, all decoded from the input.
template <int D>
struct Case
{
  stm::LatticeIndex<D> Dimensions{};
  std::vector<stm::MaterialIndex> Labels; // per voxel, axis 0 fastest
  stm::RefinementPlanOptions<D> Plan;
  int BalanceLevel = 0;
  bool FaceBalanceOnly = false;
  stm::SpacetreeTessellationOptions Tessellation;
  bool Snap = false;
  /// The binary cut's VertexSnap rule: QualityDriven (the default of stmVertexSnap and stmesh)
  /// or Threshold (the paper's, Alpha 1/3).
  stm::SnapRule SnapRule = stm::SnapRule::QualityDriven;
  int SmoothIterations = 0;
  int ImprovementSweeps = 0;
  int NumberOfMaterials = 1;
  /// Refine the thin parts to half a voxel, as stmImageToSpacetree's ThinParts does: 0 no,
  /// 1 of every material (the multi-material cut then keeps every label), 2 of the body.
  int ThinParts = 0;
};

template <int D>
Case<D> Decode(ByteStream& bytes)
{
  Case<D> c;
  std::int64_t voxels = 1;
  for (int axis = 0; axis < D; ++axis)
  {
    c.Dimensions[axis] = bytes.Range(1, D == 2 ? 12 : 7);
    voxels *= c.Dimensions[axis];
  }
  // The pattern: 1, 2 or 3 parts per axis, not 1 on every axis (that would refine nothing).
  stm::SplitCounts<D> counts;
  bool refines = false;
  for (int axis = 0; axis < D; ++axis)
  {
    counts[axis] = bytes.Range(1, 3);
    refines = refines || counts[axis] > 1;
  }
  if (!refines)
  {
    counts[0] = 2;
  }
  c.Plan.Pattern = { counts };
  c.Plan.MaxCellSize = bytes.Range(1, 16);
  const std::uint8_t flags = bytes.Next();
  c.FaceBalanceOnly = (flags & 1) != 0;
  c.Tessellation.IncludeBackground = (flags & 2) != 0;
  c.Tessellation.Template = (flags & 4) ? stm::CellTemplate::Kuhn : stm::CellTemplate::Checkerboard;
  c.Tessellation.Output =
    (flags & 8) ? stm::TessellationOutput::Hybrid : stm::TessellationOutput::Simplices;
  c.Tessellation.Templates = static_cast<stm::TemplateRule>((flags >> 4) % 3);
  c.Snap = (flags & 64) != 0;
  c.BalanceLevel = bytes.Range(0, 3);
  const std::uint8_t smoothing = bytes.Next();
  c.SmoothIterations = smoothing % 5;
  // The quality sweeps dominate a run under coverage instrumentation: a few exercise them.
  c.ImprovementSweeps = (smoothing / 5) % 3;
  c.SnapRule = (smoothing / 15) % 2 ? stm::SnapRule::Threshold : stm::SnapRule::QualityDriven;
  c.NumberOfMaterials = bytes.Range(1, 5);
  c.ThinParts = (flags & 128) ? 1 + bytes.Next() % 2 : 0;
  c.Labels.resize(static_cast<std::size_t>(voxels));
  for (auto& label : c.Labels)
  {
    label = static_cast<stm::MaterialIndex>(bytes.Next() % (c.NumberOfMaterials + 1));
  }
  return c;
}

/// Label values of the materials: deliberately far from the indices, as atlases' are.
std::vector<std::int64_t> MaterialLabels(int count)
{
  std::vector<std::int64_t> labels;
  for (int material = 0; material < count; ++material)
  {
    labels.push_back(material == 0 ? 0 : 1000 * material + 7);
  }
  return labels;
}

std::string Context(const std::string& stage, const stm::MeshInvariantReport& report)
{
  return stage + " gave an invalid mesh: " + report.Summary();
}

/// Exact volume of each label's voxels (voxel edge 1).
template <int D>
std::map<std::int64_t, double> VoxelVolumes(
  const Case<D>& c, const std::vector<std::int64_t>& labels, bool background)
{
  std::map<std::int64_t, double> volumes;
  for (const stm::MaterialIndex material : c.Labels)
  {
    if (material != stm::BackgroundMaterial || background)
    {
      volumes[labels[material]] += 1.0;
    }
  }
  return volumes;
}

/// The tessellation: its cells, points in lattice units, and per cell the label value.
template <int D>
struct Tessellation
{
  std::vector<std::int64_t> Connectivity;
  std::vector<std::uint8_t> Shapes;
  std::vector<stm::MaterialIndex> Materials;
  std::vector<double> Points;
  std::vector<std::int64_t> CellLabels;

  std::int64_t NumberOfPoints() const { return static_cast<std::int64_t>(this->Points.size()) / D; }
};

template <int D>
bool Tessellate(const stm::Spacetree<D>& tree, const stm::SpacetreeTessellationOptions& options,
  const std::vector<std::int64_t>& labels, stm::SequentialExecutor& executor, Tessellation<D>& out)
{
  stm::SpacetreeTessellator<D> tessellator;
  if (!tessellator.Prepare(tree, options, executor).IsOk())
  {
    return false;
  }
  const std::int64_t cells = tessellator.GetNumberOfCells();
  out.Connectivity.assign(static_cast<std::size_t>(tessellator.GetConnectivitySize()), -1);
  out.Shapes.assign(static_cast<std::size_t>(cells), 0xFF);
  out.Materials.assign(static_cast<std::size_t>(cells), 0xFFFF);
  Require(tessellator
            .WriteCells(out.Connectivity.data(), out.Shapes.data(), out.Materials.data(), executor)
            .IsOk(),
    "WriteCells failed after Prepare succeeded");
  const std::int64_t points = tessellator.GetNumberOfPoints();
  out.Points.assign(static_cast<std::size_t>(points * D), -1.0);
  std::vector<int> visits(static_cast<std::size_t>(points), 0);
  auto visit = [&](std::int64_t id, const stm::LatticeIndex<D>& halfUnits)
  {
    Require(id >= 0 && id < points, "VisitPoints gave an id out of range");
    ++visits[id];
    for (int axis = 0; axis < D; ++axis)
    {
      out.Points[id * D + axis] = 0.5 * static_cast<double>(halfUnits[axis]);
    }
  };
  Require(tessellator.VisitPoints(visit, executor).IsOk(), "VisitPoints failed");
  Require(std::all_of(visits.begin(), visits.end(), [](int n) { return n == 1; }),
    "VisitPoints did not report every point exactly once");
  for (const stm::MaterialIndex material : out.Materials)
  {
    Require(material < labels.size(), "a cell has a material index beyond the labels");
    out.CellLabels.push_back(labels[material]);
  }
  return true;
}

/// The cut pieces of a simplicial mesh, with the cut vertices placed on their edges.
template <int D>
struct CutPieces
{
  std::vector<double> Points;
  std::vector<std::int64_t> Cells;
  std::vector<std::int64_t> Labels;
};

/// Binary path: the labels function (the body indicator interpolated d-linearly), VertexSnap,
/// then MarchingSimplices keeping both sides, inside labelled 1 and outside 0.
template <int D>
void CheckBinaryCut(const Case<D>& c, const stm::Spacetree<D>& tree,
  const stm::LatticeIndex<D>& voxelSubdivision, const Tessellation<D>& mesh,
  stm::SequentialExecutor& executor)
{
  std::vector<std::int8_t> indicator;
  Require(stm::BodyIndicator<D>(tree, indicator, executor).IsOk(), "BodyIndicator failed");
  stm::VoxelField<D, std::int8_t> field;
  field.Dimensions = c.Dimensions;
  field.Values = indicator.data();
  std::vector<double> points = mesh.Points;
  std::vector<double> values(static_cast<std::size_t>(mesh.NumberOfPoints()));
  for (std::int64_t p = 0; p < mesh.NumberOfPoints(); ++p)
  {
    double voxelUnits[D];
    for (int axis = 0; axis < D; ++axis)
    {
      voxelUnits[axis] = points[p * D + axis] / static_cast<double>(voxelSubdivision[axis]);
    }
    values[p] = field.Sample(voxelUnits);
  }
  const auto cells = static_cast<std::int64_t>(mesh.Connectivity.size()) / (D + 1);
  if (c.Snap)
  {
    stm::VertexSnap<D> snap;
    stm::VertexSnapOptions options = stm::MultiMaterialCutOptions::QualityDrivenSnap();
    if (c.SnapRule == stm::SnapRule::Threshold)
    {
      options = stm::VertexSnapOptions();
      options.Rule = stm::SnapRule::Threshold;
    }
    Require(snap
              .Snap(points.data(), values.data(), mesh.NumberOfPoints(), mesh.Connectivity.data(),
                cells, options, executor)
              .IsOk(),
      "VertexSnap failed on a valid mesh");
  }
  stm::MarchingSimplices<D> cutter;
  stm::MarchingSimplicesOptions options;
  auto allZeroSide = [&](std::int64_t cell)
  {
    return mesh.Materials[cell] == stm::BackgroundMaterial ? stm::CutSide::Outside
                                                           : stm::CutSide::Inside;
  };
  Require(cutter
            .Classify(values.data(), mesh.NumberOfPoints(), mesh.Connectivity.data(), cells,
              options, allZeroSide, executor)
            .IsOk(),
    "MarchingSimplices::Classify failed on a valid mesh");
  const std::int64_t outputCells = cutter.GetNumberOfCells();
  CutPieces<D> cut;
  cut.Cells.assign(static_cast<std::size_t>(outputCells * (D + 1)), -1);
  std::vector<std::int64_t> parents(static_cast<std::size_t>(outputCells), -1);
  std::vector<std::uint8_t> sides(static_cast<std::size_t>(outputCells), 0xFF);
  Require(cutter
            .WriteCells(
              mesh.Connectivity.data(), cut.Cells.data(), parents.data(), sides.data(), executor)
            .IsOk(),
    "MarchingSimplices::WriteCells failed");
  cut.Points = points;
  for (const stm::CutEdge& edge : cutter.GetCutEdges())
  {
    for (int axis = 0; axis < D; ++axis)
    {
      cut.Points.push_back(
        (1.0 - edge.T) * points[edge.A * D + axis] + edge.T * points[edge.B * D + axis]);
    }
  }
  for (const std::uint8_t side : sides)
  {
    cut.Labels.push_back(side == static_cast<std::uint8_t>(stm::CutSide::Inside) ? 1 : 0);
  }
  if (outputCells == 0)
  {
    return;
  }
  const stm::MeshInvariantReport report =
    stm::CheckSimplicialMesh<D>(cut.Points, cut.Cells, &cut.Labels);
  Require(report.IsValid(), Context("the binary cut", report));
  const bool body = std::any_of(c.Labels.begin(), c.Labels.end(),
    [](stm::MaterialIndex m) { return m != stm::BackgroundMaterial; });
  Require(c.ThinParts != 2 || !body || report.VolumePerMaterial.count(1) != 0,
    "the binary cut lost the body of refined thin parts");
}

/// Multi-material path: corner fractions, the cut (with its quality-driven snap when asked),
/// then boundary smoothing. Every label of the tessellation stays present.
template <int D>
void CheckMultiMaterialCut(const Case<D>& c, const Tessellation<D>& mesh,
  const std::vector<std::int64_t>& labels, stm::SequentialExecutor& executor)
{
  // Peeling order: body labels ascending, the background last.
  std::vector<std::int64_t> order;
  std::set<std::int64_t> present(mesh.CellLabels.begin(), mesh.CellLabels.end());
  for (const std::int64_t label : present)
  {
    if (label != labels[stm::BackgroundMaterial])
    {
      order.push_back(label);
    }
  }
  // As stmMultiMaterialCut has it: the background is always the last material, and the angle
  // beyond the mesh is the background's, as the voxels beyond the image are.
  order.push_back(labels[stm::BackgroundMaterial]);
  const auto materials = static_cast<int>(order.size());
  std::vector<std::int32_t> cellMaterials;
  for (const std::int64_t label : mesh.CellLabels)
  {
    cellMaterials.push_back(
      static_cast<std::int32_t>(std::find(order.begin(), order.end(), label) - order.begin()));
  }
  std::vector<double> points3;
  for (std::int64_t p = 0; p < mesh.NumberOfPoints(); ++p)
  {
    for (int axis = 0; axis < 3; ++axis)
    {
      points3.push_back(axis < D ? mesh.Points[p * D + axis] : 0.0);
    }
  }
  const auto cells = static_cast<std::int64_t>(mesh.Connectivity.size()) / (D + 1);
  stm::MaterialFractions fractions;
  Require(stm::CornerFractions<D>(points3.data(), mesh.NumberOfPoints(), mesh.Connectivity.data(),
            cells, cellMaterials.data(), materials, materials - 1, fractions, executor)
            .IsOk(),
    "CornerFractions failed on a valid mesh");
  stm::MultiMaterialCut<D> cut;
  stm::MultiMaterialCutOptions options;
  options.SnapVertices = c.Snap;
  Require(
    cut
      .Run(mesh.NumberOfPoints(), c.Snap ? mesh.Points.data() : nullptr, mesh.Connectivity.data(),
        cells, cellMaterials.data(), materials, std::move(fractions), options, executor)
      .IsOk(),
    "MultiMaterialCut failed on a valid mesh");
  CutPieces<D> pieces;
  pieces.Points = mesh.Points;
  for (const stm::CutEdge& edge : cut.GetAddedPoints())
  {
    Require(edge.A >= 0 && edge.B >= 0 &&
        edge.A < static_cast<std::int64_t>(pieces.Points.size() / D) &&
        edge.B < static_cast<std::int64_t>(pieces.Points.size() / D),
      "a cut point lies on an edge of points not placed yet");
    for (int axis = 0; axis < D; ++axis)
    {
      pieces.Points.push_back((1.0 - edge.T) * pieces.Points[edge.A * D + axis] +
        edge.T * pieces.Points[edge.B * D + axis]);
    }
  }
  if (c.Snap)
  {
    pieces.Points = cut.GetPoints();
  }
  pieces.Cells = cut.GetCells();
  for (const std::int32_t material : cut.GetCellMaterials())
  {
    Require(material >= 0 && material < materials, "a cut cell has a material out of range");
    pieces.Labels.push_back(order[material]);
  }
  stm::MeshInvariantReport report =
    stm::CheckSimplicialMesh<D>(pieces.Points, pieces.Cells, &pieces.Labels);
  Require(report.IsValid(), Context("the multi-material cut", report));
  for (std::size_t m = 0; c.ThinParts == 1 && m + 1 < order.size(); ++m)
  {
    Require(report.VolumePerMaterial.count(order[m]) != 0,
      "the multi-material cut lost label " + std::to_string(order[m]) + " of refined thin parts");
  }
  if (c.SmoothIterations == 0)
  {
    return;
  }
  stm::BoundarySmoother<D> smoother;
  stm::BoundarySmoothOptions smoothOptions;
  smoothOptions.NumberOfIterations = c.SmoothIterations;
  smoothOptions.NumberOfImprovementSweeps = c.ImprovementSweeps;
  smoothOptions.BackgroundMaterial = labels[stm::BackgroundMaterial];
  const auto points = static_cast<std::int64_t>(pieces.Points.size()) / D;
  const auto cutCells = static_cast<std::int64_t>(pieces.Cells.size()) / (D + 1);
  Require(smoother
            .Smooth(pieces.Points.data(), points, pieces.Cells.data(), cutCells,
              pieces.Labels.data(), smoothOptions, executor)
            .IsOk(),
    "BoundarySmooth failed on a valid mesh");
  report = stm::CheckSimplicialMesh<D>(pieces.Points, pieces.Cells, &pieces.Labels);
  Require(report.IsValid(), Context("boundary smoothing", report));
}

template <int D>
void RunCase(ByteStream& bytes)
{
  const Case<D> c = Decode<D>(bytes);
  const std::vector<std::int64_t> labels = MaterialLabels(c.NumberOfMaterials + 1);
  stm::SequentialExecutor executor;
  stm::Spacetree<D> tree;
  const stm::MaterialImage<D> image{ c.Dimensions, c.Labels.data() };
  std::vector<std::uint8_t> thin;
  if (c.ThinParts != 0)
  {
    Require(stm::ThinPartVoxels<D>(image, c.ThinParts == 2, thin, executor).IsOk(),
      "ThinPartVoxels failed on a valid image");
    Require(thin.size() == c.Labels.size(), "ThinPartVoxels gave a flag per voxel");
  }
  // As stmImageToSpacetree: voxels at minority corners get leaves of one voxel.
  std::vector<std::uint8_t> minorityCorners;
  if (c.ThinParts != 0)
  {
    Require(stm::MinorityCornerVoxels<D>(image, c.ThinParts == 2, minorityCorners, executor).IsOk(),
      "MinorityCornerVoxels failed on a valid image");
    Require(
      minorityCorners.size() == c.Labels.size(), "MinorityCornerVoxels gave a flag per voxel");
  }
  const bool refineThin = std::find(thin.begin(), thin.end(), 1) != thin.end();
  stm::RefinementPlanOptions<D> planOptions = c.Plan;
  planOptions.FinestSize = refineThin ? 0.5 : 0.0;
  stm::RefinementPlan<D> plan;
  const stm::Status planned = stm::PlanRefinement<D>(c.Dimensions, planOptions, plan);
  if (!planned.IsOk())
  {
    Require(!planned.GetMessage().empty(), "the plan refused its input without a message");
    return;
  }
  std::vector<std::uint8_t> minimumLevels;
  if (c.ThinParts != 0)
  {
    const std::vector<double> voxelEdges =
      plan.LargestEdges(stm::RefinementPlanOptions<D>::UnitSpacing());
    const int thinLevel = refineThin ? plan.CoarsestLevelWithin(0.5, voxelEdges) : 0;
    const int voxelLevel = plan.CoarsestLevelWithin(1.0, voxelEdges);
    for (std::size_t v = 0; v < c.Labels.size(); ++v)
    {
      const int level =
        std::max(refineThin && thin[v] ? thinLevel : 0, minorityCorners[v] ? voxelLevel : 0);
      minimumLevels.push_back(static_cast<std::uint8_t>(level));
    }
  }
  const stm::Status built = stm::SpacetreeBuilder<D>().Build(
    image, labels, plan, minimumLevels.empty() ? nullptr : minimumLevels.data(), tree, executor);
  if (!built.IsOk())
  {
    Require(!built.GetMessage().empty(), "the build refused its input without a message");
    return;
  }
  // Mesh points are in lattice units: a voxel is VoxelSubdivision lattice cells on each axis.
  double voxelVolume = 1.0;
  for (int axis = 0; axis < D; ++axis)
  {
    voxelVolume *= static_cast<double>(plan.VoxelSubdivision[axis]);
  }
  Require(stm::ValidateSpacetree<D>(tree).IsOk(), "the built spacetree is invalid");
  if (c.BalanceLevel > 0)
  {
    stm::SpacetreeBalanceOptions balance;
    balance.BalanceLevel = c.BalanceLevel;
    balance.FaceBalanceOnly = c.FaceBalanceOnly;
    Require(stm::SpacetreeBalancer<D>().Balance(tree, balance, executor).IsOk(),
      "balancing failed on a valid tree");
    Require(stm::ValidateSpacetree<D>(tree).IsOk(), "the balanced spacetree is invalid");
    Require(stm::MaximumLevelDifference<D>(tree, c.FaceBalanceOnly, executor) <= c.BalanceLevel,
      "the balanced tree has neighbours more than the balance level apart");
  }
  Tessellation<D> mesh;
  if (!Tessellate<D>(tree, c.Tessellation, labels, executor, mesh))
  {
    return;
  }
  if (mesh.Shapes.empty())
  {
    // Only an image without body voxels, meshed without the background, has no cells.
    Require(!c.Tessellation.IncludeBackground &&
        std::all_of(c.Labels.begin(), c.Labels.end(),
          [](stm::MaterialIndex m) { return m == stm::BackgroundMaterial; }),
      "the tessellation of a non-empty body has no cells");
    return;
  }
  const stm::MeshInvariantReport report =
    stm::CheckCellMesh<D>(mesh.Points, mesh.Connectivity, mesh.Shapes, &mesh.CellLabels);
  Require(report.IsValid(), Context("the tessellation", report));
  // Before cutting, the leaves cover the voxels exactly; the background (with the padding of
  // the root grid) is at least as large as its voxels.
  for (const auto& [label, volume] : VoxelVolumes<D>(c, labels, false))
  {
    Require(report.VolumePerMaterial.count(label) != 0 &&
        report.VolumePerMaterial.at(label) == volume * voxelVolume,
      "the tessellation's volume of label " + std::to_string(label) + " is not its voxels'");
  }
  if (c.Tessellation.Output != stm::TessellationOutput::Simplices)
  {
    return;
  }
  CheckBinaryCut<D>(c, tree, plan.VoxelSubdivision, mesh, executor);
  CheckMultiMaterialCut<D>(c, mesh, labels, executor);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  ByteStream bytes(data, size);
  if (bytes.Next() % 2 == 0)
  {
    RunCase<2>(bytes);
  }
  else
  {
    RunCase<3>(bytes);
  }
  return 0;
}
