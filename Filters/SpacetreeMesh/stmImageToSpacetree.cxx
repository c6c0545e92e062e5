// SPDX-License-Identifier: BSD-3-Clause
#include "stmImageToSpacetree.h"

#include "stmPieces.h"
#include "stmSMPExecutor.h"
#include "stmSpacetreeData.h"
#include "stmThinPartExchange.h"

#include "Balance/SpacetreeGrading.h"
#include "Spacetree/RefinementPlan.h"
#include "Spacetree/RootPieces.h"
#include "Spacetree/SpacetreeBuild.h"
#include "Spacetree/ThinParts.h"

#include "vtkArrayDispatch.h"
#include "vtkCellData.h"
#include "vtkDataArrayRange.h"
#include "vtkDataObject.h"
#include "vtkDataSetAttributes.h"
#include "vtkImageData.h"
#include "vtkImplicitFunction.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMatrix3x3.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkSMPTools.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <iterator>
#include <limits>
#include <vector>

vtkStandardNewMacro(stmImageToSpacetree);

namespace
{
// Label ranges up to this size get a direct lookup table; wider ones use binary search.
constexpr long long LookupTableLimit = 1 << 24;

/// Distinct label values of an integer array, sorted; fails for labels outside int32.
struct CollectLabels
{
  std::vector<long long> Labels;
  bool OutOfRange = false;

  template <typename ArrayT>
  void operator()(ArrayT* array)
  {
    const auto values = vtk::DataArrayValueRange<1>(array);
    if (values.size() == 0)
    {
      return;
    }
    long long lo = std::numeric_limits<long long>::max();
    long long hi = std::numeric_limits<long long>::lowest();
    for (const auto value : values)
    {
      lo = std::min<long long>(lo, static_cast<long long>(value));
      hi = std::max<long long>(hi, static_cast<long long>(value));
    }
    if (lo < std::numeric_limits<int>::min() || hi > std::numeric_limits<int>::max())
    {
      this->OutOfRange = true;
      return;
    }
    if (hi - lo < LookupTableLimit)
    {
      std::vector<char> present(static_cast<std::size_t>(hi - lo + 1), 0);
      for (const auto value : values)
      {
        present[static_cast<long long>(value) - lo] = 1;
      }
      for (long long i = 0; i <= hi - lo; ++i)
      {
        if (present[i])
        {
          this->Labels.push_back(lo + i);
        }
      }
      return;
    }
    this->Labels.assign(values.begin(), values.end());
    std::sort(this->Labels.begin(), this->Labels.end());
    this->Labels.erase(std::unique(this->Labels.begin(), this->Labels.end()), this->Labels.end());
  }
};

/// Writes the material index of every voxel: position in the sorted body labels + 1, or 0.
struct MapToMaterials
{
  const std::vector<long long>* SortedBody;
  std::vector<stm::MaterialIndex>* Materials;

  template <typename ArrayT>
  void operator()(ArrayT* array)
  {
    const auto values = vtk::DataArrayValueRange<1>(array);
    const std::vector<long long>& body = *this->SortedBody;
    stm::MaterialIndex* out = this->Materials->data();
    const long long lo = body.front();
    const long long hi = body.back();
    if (hi - lo < LookupTableLimit)
    {
      std::vector<stm::MaterialIndex> table(static_cast<std::size_t>(hi - lo + 1), 0);
      for (std::size_t i = 0; i < body.size(); ++i)
      {
        table[body[i] - lo] = static_cast<stm::MaterialIndex>(i + 1);
      }
      vtkSMPTools::For(0, values.size(),
        [&](vtkIdType begin, vtkIdType end)
        {
          for (vtkIdType v = begin; v < end; ++v)
          {
            const long long label = static_cast<long long>(values[v]);
            out[v] = (label < lo || label > hi) ? stm::BackgroundMaterial : table[label - lo];
          }
        });
      return;
    }
    vtkSMPTools::For(0, values.size(),
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType v = begin; v < end; ++v)
        {
          const long long label = static_cast<long long>(values[v]);
          const auto it = std::lower_bound(body.begin(), body.end(), label);
          out[v] = (it != body.end() && *it == label)
            ? static_cast<stm::MaterialIndex>(it - body.begin() + 1)
            : stm::BackgroundMaterial;
        }
      });
  }
};

/// The distinct labels of an integer label array (CollectLabels), by the integer types' fast
/// path or the generic vtkDataArray one.
CollectLabels LabelsOf(vtkDataArray* labels)
{
  CollectLabels collect;
  if (!vtkArrayDispatch::DispatchByValueType<vtkArrayDispatch::Integrals>::Execute(labels, collect))
  {
    collect(labels);
  }
  return collect;
}

/// The body of interest's labels, sorted and distinct: `bodyLabels` when given, else every
/// label present (sorted, distinct) but the background.
std::vector<long long> BodyOf(const std::vector<int>& bodyLabels, int backgroundLabel,
  const std::vector<long long>& presentLabels)
{
  std::vector<long long> body;
  if (bodyLabels.empty())
  {
    std::copy_if(presentLabels.begin(), presentLabels.end(), std::back_inserter(body),
      [backgroundLabel](long long label) { return label != backgroundLabel; });
    return body;
  }
  body.assign(bodyLabels.begin(), bodyLabels.end());
  std::sort(body.begin(), body.end());
  body.erase(std::unique(body.begin(), body.end()), body.end());
  return body;
}

/// Every voxel's material for the sorted body labels (MapToMaterials), by the same two paths.
std::vector<stm::MaterialIndex> MaterialsOf(
  vtkDataArray* labels, const std::vector<long long>& sortedBody)
{
  std::vector<stm::MaterialIndex> materials(static_cast<std::size_t>(labels->GetNumberOfTuples()));
  MapToMaterials map{ &sortedBody, &materials };
  if (!vtkArrayDispatch::DispatchByValueType<vtkArrayDispatch::Integrals>::Execute(labels, map))
  {
    map(labels);
  }
  return materials;
}

/// Everything the tree construction needs besides the material image.
struct RefinementRequest
{
  std::string Pattern;
  int RootCellSize[3];
  int MaxCellSize;
  /// Largest leaf edge in voxels per material index; 0 for none.
  std::vector<double> MaterialMaxCellSizes;
  /// Per voxel: inside the refinement region; empty without a region.
  std::vector<unsigned char> InRegion;
  double RegionMaxCellSize;
  /// Per voxel: the sizing field; empty without one.
  std::vector<double> Sizing;
  double Grading;
  /// stmImageToSpacetree::ThinPartModes.
  int ThinParts = 0;
  /// A piece's thin and minority-corner voxels (empty: none), classified on the whole image
  /// before the crop: a thin part is one by its whole component, which may reach beyond the
  /// piece's ghost box. WholeThinVoxels decides, as for the whole image, whether the plan
  /// reaches half a voxel, so that every piece has the whole image's lattice.
  bool VoxelClassesGiven = false;
  std::vector<std::uint8_t> ThinVoxels;
  std::vector<std::uint8_t> MinorityCornerVoxels;
  std::int64_t WholeThinVoxels = 0;
};

/// What BuildTree reports besides the tree.
struct BuildReport
{
  vtkIdType ThinVoxels = 0;
  vtkIdType MinorityCornerVoxels = 0;
  std::string Warning;
};

/// Largest number of lattice cells (voxels times their subdivision) the dense level maps of
/// the later stages are allowed to cover.
constexpr std::int64_t MaximumLatticeCells = std::int64_t{ 1 } << 30;

/// The level table's options from the request and the image's geometry and size.
template <int Dim>
bool MakePlanOptions(const RefinementRequest& request, const stmSpacetreeGeometry& geometry,
  stm::RefinementPlanOptions<Dim>& planOptions, std::string& error)
{
  for (int axis = 0; axis < Dim; ++axis)
  {
    const double* vector = geometry.AxisVectors[geometry.ImageAxes[axis]];
    planOptions.Spacing[axis] =
      std::sqrt(vector[0] * vector[0] + vector[1] * vector[1] + vector[2] * vector[2]);
  }

  // The pattern, per spacetree axis: three counts per image axis, or Dim counts.
  std::vector<std::vector<int>> entries;
  const bool perImageAxis = stm::ParseRefinementPattern(request.Pattern, 3, entries, error);
  if (!perImageAxis)
  {
    // A 2D image may also give only the counts of its two axes; report the 3-count error.
    std::string ignored;
    if (Dim == 3 || !stm::ParseRefinementPattern(request.Pattern, Dim, entries, ignored))
    {
      return false;
    }
    error.clear();
  }
  for (const auto& entry : entries)
  {
    stm::SplitCounts<Dim> counts;
    for (int axis = 0; axis < Dim; ++axis)
    {
      counts[axis] = entry[perImageAxis ? geometry.ImageAxes[axis] : axis];
    }
    planOptions.Pattern.push_back(counts);
  }
  bool rootGiven = false;
  for (int axis = 0; axis < Dim; ++axis)
  {
    planOptions.RootCellSize[axis] = request.RootCellSize[geometry.ImageAxes[axis]];
    rootGiven = rootGiven || planOptions.RootCellSize[axis] != 0;
  }
  for (int axis = 0; axis < Dim && rootGiven; ++axis)
  {
    if (planOptions.RootCellSize[axis] <= 0)
    {
      error = "RootCellSize must be positive on every axis the image spans (or 0 on all)";
      return false;
    }
  }
  planOptions.MaxCellSize = request.MaxCellSize;
  return true;
}

/// Where a piece lies (stmImageToSpacetree::SplitIntoPieces), per spacetree axis unless said:
/// its own root cells and the first of its ghost box, in the whole image's root grid, and the
/// voxels of the ghost box (clipped to the image), counted from the whole image's first voxel.
struct PieceLayout
{
  /// SplitIntoPieces is on and the request is for one of several pieces.
  bool Split = false;
  bool Empty = true;
  int WholeExtent[6] = { 0, -1, 0, -1, 0, -1 };
  /// Per image axis.
  int WholeVoxelDims[3] = { 1, 1, 1 };
  int Dimension = 0;
  int ImageAxes[3] = { 0, 1, 2 };
  long long RootVoxels[3] = { 1, 1, 1 };
  /// The whole image's root grid, per spacetree axis.
  long long RootGrid[3] = { 1, 1, 1 };
  long long OwnedLower[3] = { 0, 0, 0 };
  long long OwnedUpper[3] = { 0, 0, 0 };
  long long GhostLower[3] = { 0, 0, 0 };
  long long FirstVoxel[3] = { 0, 0, 0 };
  long long VoxelCount[3] = { 1, 1, 1 };
};

/// The material image of a voxel array, its axes in the image's order (2D images skip the
/// axis of one voxel).
template <int Dim>
stm::MaterialImage<Dim> ImageOfVoxels(const std::vector<stm::MaterialIndex>& materials,
  const int voxelDims[3], const stmSpacetreeGeometry& geometry)
{
  stm::MaterialImage<Dim> image;
  for (int axis = 0; axis < Dim; ++axis)
  {
    image.Dimensions[axis] = voxelDims[geometry.ImageAxes[axis]];
  }
  image.Values = materials.data();
  return image;
}

/// Where a piece's layout finds the costs of the root cells: nowhere (the boxes are halved by
/// root cells), the whole root grid's costs that the ranks summed over their slabs
/// (stmImageToSpacetree::RequestData's first pass), or the whole image's materials to estimate
/// them from (with an executor).
struct RootCellCostSource
{
  const std::vector<long long>* Summed = nullptr;
  const std::vector<stm::MaterialIndex>* WholeImage = nullptr;
  stmSMPExecutor* Executor = nullptr;
};

/// Lays out piece `piece` of `pieces` of an image of layout.WholeVoxelDims voxels, with the root
/// cells the whole image's plan gives; balanced by the cost of the root cells where `costs`
/// has them (stm::RootCellCosts).
template <int Dim>
bool LayOutPiece(const RefinementRequest& request, const stmSpacetreeGeometry& geometry, int pieces,
  int piece, const RootCellCostSource& costs, PieceLayout& layout, std::string& error)
{
  stm::RefinementPlanOptions<Dim> options;
  if (!MakePlanOptions<Dim>(request, geometry, options, error))
  {
    return false;
  }
  stm::LatticeIndex<Dim> dims;
  for (int axis = 0; axis < Dim; ++axis)
  {
    dims[axis] = layout.WholeVoxelDims[geometry.ImageAxes[axis]];
  }
  stm::RefinementPlan<Dim> plan;
  const stm::Status status = stm::PlanRefinement<Dim>(dims, options, plan);
  if (!status.IsOk())
  {
    error = status.GetMessage();
    return false;
  }
  for (int axis = 0; axis < Dim; ++axis)
  {
    layout.RootVoxels[axis] = plan.CellSizes[0][axis] / plan.VoxelSubdivision[axis];
  }
  const stm::LatticeIndex<Dim> rootDims = plan.RootGridDimensions(dims);
  for (int axis = 0; axis < Dim; ++axis)
  {
    layout.RootGrid[axis] = rootDims[axis];
  }
  stm::RootBox<Dim> owned;
  if (costs.Summed)
  {
    owned = stm::PieceRootBox<Dim>(rootDims, pieces, piece,
      std::vector<std::int64_t>(costs.Summed->begin(), costs.Summed->end()));
  }
  else if (costs.WholeImage && costs.Executor)
  {
    stm::LatticeIndex<Dim> rootVoxels;
    for (int axis = 0; axis < Dim; ++axis)
    {
      rootVoxels[axis] = layout.RootVoxels[axis];
    }
    const std::vector<std::int64_t> estimated = stm::RootCellCosts<Dim>(
      ImageOfVoxels<Dim>(*costs.WholeImage, layout.WholeVoxelDims, geometry), rootVoxels, rootDims,
      *costs.Executor);
    owned = stm::PieceRootBox<Dim>(rootDims, pieces, piece, estimated);
  }
  else
  {
    owned = stm::PieceRootBox<Dim>(rootDims, pieces, piece);
  }
  stm::LatticeIndex<Dim> rootVoxels;
  for (int axis = 0; axis < Dim; ++axis)
  {
    rootVoxels[axis] = layout.RootVoxels[axis];
  }
  const stm::RootBox<Dim> ghost =
    stm::GhostRootBox<Dim>(owned, rootDims, stm::GhostRootLayersFor<Dim>(rootVoxels));
  layout.Empty = owned.IsEmpty();
  for (int axis = 0; axis < Dim && !layout.Empty; ++axis)
  {
    layout.OwnedLower[axis] = owned.Lower[axis];
    layout.OwnedUpper[axis] = owned.Upper[axis];
    layout.GhostLower[axis] = ghost.Lower[axis];
    layout.FirstVoxel[axis] = ghost.Lower[axis] * layout.RootVoxels[axis];
    layout.VoxelCount[axis] =
      std::min<long long>(dims[axis], ghost.Upper[axis] * layout.RootVoxels[axis]) -
      layout.FirstVoxel[axis];
  }
  return true;
}

/// Voxels along an image axis of `points` points: one per point for point labels, one per cell
/// for cell labels.
int VoxelsAlong(int points, bool cellLabels)
{
  return cellLabels ? std::max(1, points - 1) : points;
}

/// The image geometry the plan sees: the spanned axes (more than one voxel) and the voxel
/// edges (spacing times the direction matrix's columns; identity without one).
stmSpacetreeGeometry ImageGeometry(
  const int voxelDims[3], const double spacing[3], const double* direction)
{
  stmSpacetreeGeometry geometry;
  geometry.Dimension = 0;
  for (int axis = 0; axis < 3; ++axis)
  {
    if (voxelDims[axis] > 1)
    {
      geometry.ImageAxes[geometry.Dimension++] = axis;
    }
    for (int c = 0; c < 3; ++c)
    {
      geometry.AxisVectors[axis][c] =
        (direction ? direction[3 * c + axis] : (c == axis ? 1.0 : 0.0)) * spacing[axis];
    }
  }
  return geometry;
}

/// Copies the block [first, first + count) (per image axis) of a voxel array of dims voxels.
template <class T>
std::vector<T> CropVoxels(
  const std::vector<T>& values, const int dims[3], const long long first[3], const int count[3])
{
  std::vector<T> block(static_cast<std::size_t>(count[0]) * count[1] * count[2]);
  vtkSMPTools::For(0, static_cast<vtkIdType>(count[1]) * count[2],
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType row = begin; row < end; ++row)
      {
        const long long y = first[1] + row % count[1];
        const long long z = first[2] + row / count[1];
        const auto* source = values.data() + (z * dims[1] + y) * dims[0] + first[0];
        std::copy(source, source + count[0], block.data() + row * count[0]);
      }
    });
  return block;
}

/// The voxels of a material image that are thin parts and those at minority corners (empty
/// vectors: none), for ThinParts other than NO_THIN_PARTS.
template <int Dim>
bool ClassifyVoxels(const stm::MaterialImage<Dim>& image, const RefinementRequest& request,
  stmSMPExecutor& executor, std::vector<std::uint8_t>& thin,
  std::vector<std::uint8_t>& minorityCorner, std::string& error)
{
  thin.clear();
  minorityCorner.clear();
  if (request.ThinParts == stmImageToSpacetree::NO_THIN_PARTS)
  {
    return true;
  }
  const bool bodyOnly = request.ThinParts == stmImageToSpacetree::THIN_BODY_PARTS;
  const stm::Status thinStatus = stm::ThinPartVoxels<Dim>(image, bodyOnly, thin, executor);
  if (!thinStatus.IsOk())
  {
    error = thinStatus.GetMessage();
    return false;
  }
  if (std::find(thin.begin(), thin.end(), std::uint8_t{ 1 }) == thin.end())
  {
    thin.clear();
  }
  // The voxel tests read the whole image: a quarter of the build on the AAL atlas.
  executor.ReportProgress(0.15);
  if (executor.ShouldAbort())
  {
    return false;
  }
  const stm::Status cornerStatus =
    stm::MinorityCornerVoxels<Dim>(image, bodyOnly, minorityCorner, executor);
  if (!cornerStatus.IsOk())
  {
    error = cornerStatus.GetMessage();
    return false;
  }
  if (std::find(minorityCorner.begin(), minorityCorner.end(), std::uint8_t{ 1 }) ==
    minorityCorner.end())
  {
    minorityCorner.clear();
  }
  executor.ReportProgress(0.3);
  return !executor.ShouldAbort();
}

template <int Dim>
bool BuildTree(const std::vector<stm::MaterialIndex>& materials, const int voxelDims[3],
  const PieceLayout* piece, stmSpacetreeGeometry geometry,
  const std::vector<long long>& materialLabels, const RefinementRequest& request,
  stmSMPExecutor& executor, vtkUnstructuredGrid* output, BuildReport& report, std::string& error)
{
  // A piece plans with the whole image's size, so that its root cells are the whole's.
  const int* planVoxelDims = piece ? piece->WholeVoxelDims : voxelDims;
  const stm::MaterialImage<Dim> image = ImageOfVoxels<Dim>(materials, voxelDims, geometry);
  stm::LatticeIndex<Dim> planDims;
  for (int axis = 0; axis < Dim; ++axis)
  {
    planDims[axis] = planVoxelDims[geometry.ImageAxes[axis]];
  }
  stm::RefinementPlanOptions<Dim> planOptions;
  if (!MakePlanOptions<Dim>(request, geometry, planOptions, error))
  {
    return false;
  }
  double finest = request.InRegion.empty() ? 0.0 : request.RegionMaxCellSize;
  for (double size : request.Sizing)
  {
    finest = finest > 0 ? std::min(finest, size) : size;
  }
  // Thin parts: refined to half a voxel on every axis, which the plan must reach.
  std::vector<std::uint8_t> thin;
  // Voxels at minority corners get leaves of one voxel, or a coarse leaf there could lose its
  // material near the corner, or whole (see stm::MinorityCornerVoxels).
  std::vector<std::uint8_t> minorityCorner;
  if (request.VoxelClassesGiven)
  {
    thin = request.ThinVoxels;
    minorityCorner = request.MinorityCornerVoxels;
  }
  else if (!ClassifyVoxels<Dim>(image, request, executor, thin, minorityCorner, error))
  {
    return false;
  }
  report.ThinVoxels = std::count(thin.begin(), thin.end(), std::uint8_t{ 1 });
  report.MinorityCornerVoxels =
    std::count(minorityCorner.begin(), minorityCorner.end(), std::uint8_t{ 1 });
  bool refinesThinParts =
    request.VoxelClassesGiven ? request.WholeThinVoxels > 0 : report.ThinVoxels > 0;
  if (request.ThinParts != stmImageToSpacetree::NO_THIN_PARTS)
  {
    executor.StartRemainingProgressAt(0.3);
  }
  auto planLevels = [&](stm::RefinementPlan<Dim>& result)
  {
    planOptions.FinestSize = finest;
    if (refinesThinParts)
    {
      const double half =
        0.5 * *std::min_element(planOptions.Spacing.begin(), planOptions.Spacing.end());
      planOptions.FinestSize = finest > 0 ? std::min(finest, half) : half;
    }
    return stm::PlanRefinement<Dim>(planDims, planOptions, result);
  };
  auto latticeCellsOf =
    [&](const stm::RefinementPlan<Dim>& result, const stm::LatticeIndex<Dim>& dims)
  {
    std::int64_t cells = 1;
    for (int axis = 0; axis < Dim; ++axis)
    {
      cells *= dims[axis] * result.VoxelSubdivision[axis];
    }
    return cells;
  };
  stm::RefinementPlan<Dim> plan;
  stm::Status status = planLevels(plan);
  // Decided on the whole image's size, so that every piece has the whole image's lattice.
  const std::int64_t wholeLatticeCells = status.IsOk() ? latticeCellsOf(plan, planDims) : 0;
  if (refinesThinParts && wholeLatticeCells > MaximumLatticeCells)
  {
    report.Warning = "the thin parts (" + std::to_string(report.ThinVoxels) +
      " voxels) are not refined: half-voxel cells would make the lattice too large (" +
      std::to_string(wholeLatticeCells) + " cells, at most " + std::to_string(MaximumLatticeCells) +
      "); a cut may lose them";
    thin.clear();
    report.ThinVoxels = 0;
    refinesThinParts = false;
    status = planLevels(plan);
  }
  if (!status.IsOk())
  {
    error = status.GetMessage();
    return false;
  }
  for (int axis = 0; axis < Dim && piece; ++axis)
  {
    if (plan.CellSizes[0][axis] / plan.VoxelSubdivision[axis] != piece->RootVoxels[axis])
    {
      error = "the piece's root cells differ from those its voxels were requested for";
      return false;
    }
  }
  const std::int64_t latticeCells = latticeCellsOf(plan, image.Dimensions);
  if (latticeCells > MaximumLatticeCells)
  {
    error = "refinement below the voxel size makes the lattice too large (" +
      std::to_string(latticeCells) + " cells, at most " + std::to_string(MaximumLatticeCells) +
      "); ask for a larger size or crop the image";
    return false;
  }

  // The size criteria, as the coarsest level allowed at each voxel.
  std::vector<std::uint8_t> minimumLevels;
  const bool labelSizes = std::any_of(request.MaterialMaxCellSizes.begin(),
    request.MaterialMaxCellSizes.end(), [](double size) { return size > 0; });
  if (labelSizes || !request.InRegion.empty() || !request.Sizing.empty() || !thin.empty() ||
    !minorityCorner.empty())
  {
    const std::vector<double> physicalEdges = plan.LargestEdges(planOptions.Spacing);
    const std::vector<double> voxelEdges =
      plan.LargestEdges(stm::RefinementPlanOptions<Dim>::UnitSpacing());
    std::vector<std::uint8_t> materialLevels(request.MaterialMaxCellSizes.size(), 0);
    for (std::size_t m = 0; m < materialLevels.size(); ++m)
    {
      const double size = request.MaterialMaxCellSizes[m];
      materialLevels[m] =
        static_cast<std::uint8_t>(size > 0 ? plan.CoarsestLevelWithin(size, voxelEdges) : 0);
    }
    const auto regionLevel = static_cast<std::uint8_t>(request.InRegion.empty()
        ? 0
        : plan.CoarsestLevelWithin(request.RegionMaxCellSize, physicalEdges));
    // Half a voxel on every axis: voxel and face centres become lattice points.
    const auto thinLevel =
      static_cast<std::uint8_t>(thin.empty() ? 0 : plan.CoarsestLevelWithin(0.5, voxelEdges));
    const auto voxelLevel = static_cast<std::uint8_t>(
      minorityCorner.empty() ? 0 : plan.CoarsestLevelWithin(1.0, voxelEdges));
    minimumLevels.resize(materials.size());
    vtkSMPTools::For(0, static_cast<vtkIdType>(materials.size()),
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType v = begin; v < end; ++v)
        {
          std::uint8_t level = materialLevels[materials[v]];
          if (!thin.empty() && thin[v])
          {
            level = std::max(level, thinLevel);
          }
          if (!minorityCorner.empty() && minorityCorner[v])
          {
            level = std::max(level, voxelLevel);
          }
          if (!request.InRegion.empty() && request.InRegion[v])
          {
            level = std::max(level, regionLevel);
          }
          if (!request.Sizing.empty())
          {
            level = std::max(level,
              static_cast<std::uint8_t>(
                plan.CoarsestLevelWithin(request.Sizing[v], physicalEdges)));
          }
          minimumLevels[v] = level;
        }
      });
  }

  stm::Spacetree<Dim> tree;
  const std::vector<std::int64_t> labels(materialLabels.begin(), materialLabels.end());
  status = stm::SpacetreeBuilder<Dim>().Build(
    image, labels, plan, minimumLevels.empty() ? nullptr : minimumLevels.data(), tree, executor);
  if (status.IsOk() && request.Grading > 0)
  {
    std::array<double, Dim> latticeSpacing;
    for (int axis = 0; axis < Dim; ++axis)
    {
      latticeSpacing[axis] = planOptions.Spacing[axis] / plan.VoxelSubdivision[axis];
    }
    status = stm::SpacetreeGrader<Dim>().Grade(tree, request.Grading, latticeSpacing, executor);
  }
  if (!status.IsOk())
  {
    error = status.GetMessage();
    return false;
  }
  // The lattice unit is a fraction of the voxel where cells were refined below it.
  for (int axis = 0; axis < Dim; ++axis)
  {
    geometry.LatticeOffset[axis] *= static_cast<double>(plan.VoxelSubdivision[axis]);
    for (int c = 0; c < 3; ++c)
    {
      geometry.AxisVectors[geometry.ImageAxes[axis]][c] /=
        static_cast<double>(plan.VoxelSubdivision[axis]);
    }
  }
  stmSpacetreeData::WriteSpacetree<Dim>(tree, geometry, output);
  return true;
}

/// Lays out the piece the output's request (outInfo) asks for, or piece `number` of as many,
/// from the image's information (inInfo); false with `error` when it cannot.
bool LayOutRequestedPiece(stmImageToSpacetree* filter, vtkInformation* outInfo,
  vtkInformation* inInfo, bool cellLabels, const double* direction, PieceLayout& piece,
  std::string& error, const RootCellCostSource& costs = RootCellCostSource(), int number = -1)
{
  using Pipeline = vtkStreamingDemandDrivenPipeline;
  piece = PieceLayout();
  const int pieces = stmPieces::RequestedNumberOfPieces(outInfo);
  if (!filter->GetSplitIntoPieces() || pieces <= 1)
  {
    return true;
  }
  if (!inInfo || !inInfo->Has(Pipeline::WHOLE_EXTENT()))
  {
    error = "Split Into Pieces needs the image's whole extent from upstream";
    return false;
  }
  piece.Split = true;
  inInfo->Get(Pipeline::WHOLE_EXTENT(), piece.WholeExtent);
  for (int axis = 0; axis < 3; ++axis)
  {
    piece.WholeVoxelDims[axis] =
      VoxelsAlong(piece.WholeExtent[2 * axis + 1] - piece.WholeExtent[2 * axis] + 1, cellLabels);
  }
  double spacing[3] = { 1, 1, 1 };
  if (inInfo->Has(vtkDataObject::SPACING()))
  {
    inInfo->Get(vtkDataObject::SPACING(), spacing);
  }
  const stmSpacetreeGeometry geometry = ImageGeometry(piece.WholeVoxelDims, spacing, direction);
  if (geometry.Dimension < 2)
  {
    error = "Split Into Pieces needs a 2D or 3D image";
    return false;
  }
  RefinementRequest request;
  request.Pattern = filter->GetRefinementPattern();
  filter->GetRootCellSize(request.RootCellSize);
  request.MaxCellSize = filter->GetMaxCellSize();
  piece.Dimension = geometry.Dimension;
  std::copy(geometry.ImageAxes, geometry.ImageAxes + 3, piece.ImageAxes);
  if (number < 0)
  {
    number = stmPieces::RequestedPiece(outInfo);
  }
  return geometry.Dimension == 3
    ? LayOutPiece<3>(request, geometry, pieces, number, costs, piece, error)
    : LayOutPiece<2>(request, geometry, pieces, number, costs, piece, error);
}

/// Whether the label array selection names a cell array (known before the data arrive).
bool LabelsAreCellData(vtkAlgorithm* filter)
{
  vtkInformation* selection = filter->GetInputArrayInformation(0);
  return selection && selection->Has(vtkDataObject::FIELD_ASSOCIATION()) &&
    selection->Get(vtkDataObject::FIELD_ASSOCIATION()) == vtkDataObject::FIELD_ASSOCIATION_CELLS;
}

/// The selected label array, or where the selection is empty (as when ParaView sets the
/// property before the image has arrays) the active scalars, point data first.
vtkDataArray* LabelsOrScalars(vtkImageData* input, vtkDataArray* selected, int& association)
{
  if (selected)
  {
    return selected;
  }
  association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
  if (vtkDataArray* scalars = input->GetPointData()->GetScalars())
  {
    return scalars;
  }
  association = vtkDataObject::FIELD_ASSOCIATION_CELLS;
  return input->GetCellData()->GetScalars();
}

/// Rank `rank` of `ranks`'s slab for the root cells' costs: its share [firstLayer, endLayer)
/// of the root-cell layers along the last spacetree axis, and `extent`, the image's extent
/// that holds them, the whole image along the other axes and two points more along that one
/// (the next voxels of the last row, and the point cell labels need for them); an empty
/// extent for a rank without layers.
void SlabOfRank(const PieceLayout& piece, int rank, int ranks, long long& firstLayer,
  long long& endLayer, int extent[6])
{
  const int last = piece.Dimension - 1;
  const long long layers = piece.RootGrid[last];
  firstLayer = rank * layers / ranks;
  endLayer = (rank + 1) * layers / ranks;
  if (firstLayer >= endLayer)
  {
    const int empty[6] = { 0, -1, 0, -1, 0, -1 };
    std::copy(empty, empty + 6, extent);
    return;
  }
  std::copy(piece.WholeExtent, piece.WholeExtent + 6, extent);
  const int axis = piece.ImageAxes[last];
  const long long lower = piece.WholeExtent[2 * axis];
  extent[2 * axis] = static_cast<int>(lower + firstLayer * piece.RootVoxels[last]);
  extent[2 * axis + 1] = static_cast<int>(std::min<long long>(
    piece.WholeExtent[2 * axis + 1], lower + endLayer * piece.RootVoxels[last] + 1));
}

/// The costs of the root cells in layers [firstLayer, endLayer) (SlabOfRank), from the input's
/// materials (voxelDims voxels per image axis, its first voxel `inputFirst` voxels from the
/// whole image's), of the whole root grid; all zero where the input does not hold the slab.
/// The slab is the whole image along every axis but the last spanned one, after which the
/// image has one voxel only: a run of the input's rows, read in place.
template <int Dim>
std::vector<std::int64_t> SlabCosts(const PieceLayout& piece,
  const std::vector<stm::MaterialIndex>& materials, const int voxelDims[3],
  const long long inputFirst[3], long long firstLayer, long long endLayer, stmSMPExecutor& executor)
{
  stm::LatticeIndex<Dim> rootVoxels;
  stm::LatticeIndex<Dim> rootGrid;
  for (int axis = 0; axis < Dim; ++axis)
  {
    rootVoxels[axis] = piece.RootVoxels[axis];
    rootGrid[axis] = piece.RootGrid[axis];
  }
  std::vector<std::int64_t> none(
    static_cast<std::size_t>(stm::NumberOfLatticeCells<Dim>(rootGrid)), 0);
  stm::MaterialImage<Dim> slab;
  long long rowsBefore = 0; // of the input, along the last axis, before the slab's first
  long long rowSize = 1;
  for (int axis = 0; axis < Dim; ++axis)
  {
    const int imageAxis = piece.ImageAxes[axis];
    const long long whole = piece.WholeVoxelDims[imageAxis];
    if (axis < Dim - 1)
    {
      if (inputFirst[imageAxis] != 0 || voxelDims[imageAxis] != whole)
      {
        return none;
      }
      slab.Dimensions[axis] = whole;
      rowSize *= whole;
      continue;
    }
    const long long lower = firstLayer * rootVoxels[axis];
    const long long upper = std::min(whole, endLayer * rootVoxels[axis] + 1);
    rowsBefore = lower - inputFirst[imageAxis];
    if (lower >= upper || rowsBefore < 0 || rowsBefore + (upper - lower) > voxelDims[imageAxis])
    {
      return none;
    }
    slab.Dimensions[axis] = upper - lower;
  }
  slab.Values = materials.data() + rowsBefore * rowSize;
  return stm::RootCellCostsOfLayers<Dim>(
    slab, firstLayer, endLayer, rootVoxels, rootGrid, executor);
}

/// A piece's own voxels and those it reads for a classification in pieces (its ghost box grown by
/// one voxel), per spacetree axis, counted from the whole image's first voxel.
template <int Dim>
void PieceVoxelBoxes(const PieceLayout& piece, stm::VoxelBox<Dim>& owned, stm::VoxelBox<Dim>& read)
{
  owned = stm::VoxelBox<Dim>();
  read = stm::VoxelBox<Dim>();
  if (piece.Empty)
  {
    return;
  }
  stm::LatticeIndex<Dim> dims;
  stm::VoxelBox<Dim> ghost;
  for (int axis = 0; axis < Dim; ++axis)
  {
    dims[axis] = piece.WholeVoxelDims[piece.ImageAxes[axis]];
    owned.Lower[axis] = piece.OwnedLower[axis] * piece.RootVoxels[axis];
    owned.Upper[axis] =
      std::min<long long>(dims[axis], piece.OwnedUpper[axis] * piece.RootVoxels[axis]);
    ghost.Lower[axis] = piece.FirstVoxel[axis];
    ghost.Upper[axis] = piece.FirstVoxel[axis] + piece.VoxelCount[axis];
  }
  read = ghost.Grown(1, dims);
}

/// The thin and minority-corner voxels of a piece classified with the other ranks' pieces, none
/// of which has the whole image (stm::ThinPartPiece, stmThinPartExchange; collective, after a
/// vote that found every rank ready). materials: the input's voxels (voxelDims, per image axis),
/// whose first voxel is `inputFirst` voxels from the whole image's; thin and minorityCorner:
/// flags on those voxels, set within the box the piece reads (empty vectors: none); false with
/// `error` when this piece or another failed.
template <int Dim>
bool ClassifyVoxelsInPieces(vtkMultiProcessController* controller, stmImageToSpacetree* filter,
  vtkInformation* outInfo, vtkInformation* inInfo, bool cellLabels, const double* direction,
  const std::vector<stm::MaterialIndex>& materials, const int voxelDims[3],
  const long long inputFirst[3], bool bodyOnly, const RootCellCostSource& costs,
  stmSMPExecutor& executor, std::vector<std::uint8_t>& thin,
  std::vector<std::uint8_t>& minorityCorner, std::int64_t& wholeThinVoxels, std::string& error)
{
  const int ranks = controller->GetNumberOfProcesses();
  const int rank = controller->GetLocalProcessId();
  std::vector<stm::VoxelBox<Dim>> owned(static_cast<std::size_t>(ranks));
  std::vector<stm::VoxelBox<Dim>> read(owned.size());
  PieceLayout layout;
  bool ok = true;
  for (int r = 0; r < ranks && ok; ++r)
  {
    ok = LayOutRequestedPiece(filter, outInfo, inInfo, cellLabels, direction, layout, error,
      RootCellCostSource{ costs.Summed }, r);
    PieceVoxelBoxes<Dim>(layout, owned[r], read[r]);
  }
  stm::LatticeIndex<Dim> wholeDims;
  long long first[3] = { 0, 0, 0 };
  int count[3] = { 1, 1, 1 };
  for (int axis = 0; axis < Dim && ok; ++axis)
  {
    const int imageAxis = layout.ImageAxes[axis];
    wholeDims[axis] = layout.WholeVoxelDims[imageAxis];
    first[imageAxis] = read[rank].Lower[axis] - inputFirst[imageAxis];
    count[imageAxis] = static_cast<int>(read[rank].Upper[axis] - read[rank].Lower[axis]);
    ok = owned[rank].IsEmpty() ||
      (first[imageAxis] >= 0 && first[imageAxis] + count[imageAxis] <= voxelDims[imageAxis]);
    if (!ok)
    {
      error = "the image's extent does not hold the voxels the piece reads to classify its thin "
              "parts";
    }
  }
  stm::ThinPartPiece<Dim> piece;
  std::vector<stm::MaterialIndex> readMaterials;
  stm::MaterialImage<Dim> readImage;
  if (ok && !owned[rank].IsEmpty())
  {
    readMaterials = CropVoxels(materials, voxelDims, first, count);
    readImage.Dimensions = read[rank].GetDimensions();
    readImage.Values = readMaterials.data();
    const stm::Status classified =
      piece.Classify(readImage, read[rank], owned[rank], wholeDims, bodyOnly, rank, executor);
    if (!classified.IsOk())
    {
      error = classified.GetMessage();
      ok = false;
    }
  }
  if (!stmThinPartExchange::AllOk(controller, ok))
  {
    error = ok ? "another piece failed to classify its thin parts" : error;
    return false;
  }
  std::vector<std::uint8_t> readThin;
  const stm::Status exchanged = stmThinPartExchange::Exchange<Dim>(
    controller, piece, owned, read, readThin, wholeThinVoxels, executor);
  ok = exchanged.IsOk();
  if (!stmThinPartExchange::AllOk(controller, ok))
  {
    error = ok ? "another piece failed to classify its thin parts" : exchanged.GetMessage();
    return false;
  }
  thin.clear();
  minorityCorner.clear();
  if (owned[rank].IsEmpty())
  {
    return true;
  }
  std::vector<std::uint8_t> readCorners;
  const stm::Status cornered =
    stm::MinorityCornerVoxels<Dim>(readImage, bodyOnly, readCorners, executor);
  if (!cornered.IsOk())
  {
    error = cornered.GetMessage();
    return false;
  }
  // Back onto the input's voxels.
  const std::size_t voxels = static_cast<std::size_t>(voxelDims[0]) * voxelDims[1] * voxelDims[2];
  thin.assign(voxels, 0);
  minorityCorner.assign(voxels, 0);
  for (std::int64_t row = 0; row < static_cast<std::int64_t>(count[1]) * count[2]; ++row)
  {
    const long long y = first[1] + row % count[1];
    const long long z = first[2] + row / count[1];
    const std::size_t to =
      static_cast<std::size_t>((z * voxelDims[1] + y) * voxelDims[0] + first[0]);
    std::copy_n(readThin.begin() + row * count[0], count[0], thin.begin() + to);
    std::copy_n(readCorners.begin() + row * count[0], count[0], minorityCorner.begin() + to);
  }
  return !executor.ShouldAbort();
}

/// A rank's part in the classification in pieces when it has no voxels to classify (collective,
/// after the vote): it sends and receives nothing but the records and the sums.
void ClassifyNoVoxels(vtkMultiProcessController* controller, stmSMPExecutor& executor)
{
  stmThinPartExchange::AllOk(controller, true);
  stm::ThinPartPiece<3> piece;
  const std::vector<stm::VoxelBox<3>> none(
    static_cast<std::size_t>(controller->GetNumberOfProcesses()));
  std::vector<std::uint8_t> thin;
  std::int64_t wholeThinVoxels = 0;
  const stm::Status exchanged = stmThinPartExchange::Exchange<3>(
    controller, piece, none, none, thin, wholeThinVoxels, executor);
  stmThinPartExchange::AllOk(controller, exchanged.IsOk());
}

/// What ClassifyTogether did.
enum class Classification
{
  WholeImages, ///< every rank has the whole image: each classifies it alone
  Together,    ///< the ranks classified their pieces together
  Failed       ///< this rank or another failed (or aborted)
};

/// The vote of the ranks that mesh their own pieces with thin-part refinement and, unless every
/// rank has the whole image, ClassifyVoxelsInPieces (collective). The input's voxels
/// (`materials`, voxelDims) have the extent `extent` of the image whose piece `piece` is, laid
/// out by `costs`.
Classification ClassifyTogether(stmThinPartExchange::Vote& vote, stmImageToSpacetree* filter,
  vtkInformation* outInfo, vtkInformation* inInfo, bool cellLabels, const double* direction,
  const PieceLayout& piece, const RootCellCostSource& costs, const int extent[6],
  const int voxelDims[3], const std::vector<stm::MaterialIndex>& materials,
  stmSMPExecutor& executor, std::vector<std::uint8_t>& thin,
  std::vector<std::uint8_t>& minorityCorner, std::int64_t& wholeThinVoxels, std::string& error)
{
  bool whole = true;
  long long inputFirst[3];
  for (int axis = 0; axis < 3; ++axis)
  {
    inputFirst[axis] = extent[2 * axis] - piece.WholeExtent[2 * axis];
    whole = whole && voxelDims[axis] == piece.WholeVoxelDims[axis] && inputFirst[axis] == 0;
  }
  vote.Take(true, whole);
  if (vote.GetAllWhole())
  {
    return Classification::WholeImages;
  }
  if (!vote.GetAllReady())
  {
    error = "another piece failed before it classified its thin parts";
    return Classification::Failed;
  }
  const bool bodyOnly = filter->GetThinPartRefinement() == stmImageToSpacetree::THIN_BODY_PARTS;
  const bool classified = piece.Dimension == 3
    ? ClassifyVoxelsInPieces<3>(vote.GetController(), filter, outInfo, inInfo, cellLabels,
        direction, materials, voxelDims, inputFirst, bodyOnly, costs, executor, thin,
        minorityCorner, wholeThinVoxels, error)
    : ClassifyVoxelsInPieces<2>(vote.GetController(), filter, outInfo, inInfo, cellLabels,
        direction, materials, voxelDims, inputFirst, bodyOnly, costs, executor, thin,
        minorityCorner, wholeThinVoxels, error);
  return classified ? Classification::Together : Classification::Failed;
}
} // namespace

bool stmImageToSpacetree::IsLabelType(int dataType)
{
  switch (dataType)
  {
    case VTK_CHAR:
    case VTK_SIGNED_CHAR:
    case VTK_UNSIGNED_CHAR:
    case VTK_SHORT:
    case VTK_UNSIGNED_SHORT:
    case VTK_INT:
    case VTK_UNSIGNED_INT:
    case VTK_LONG:
    case VTK_UNSIGNED_LONG:
    case VTK_LONG_LONG:
    case VTK_UNSIGNED_LONG_LONG:
    case VTK_ID_TYPE:
      return true;
    default:
      return false;
  }
}

stmImageToSpacetree::stmImageToSpacetree()
{
  // Default label array: the active scalars, point data first.
  this->SetInputArrayToProcess(
    0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS_THEN_CELLS, vtkDataSetAttributes::SCALARS);
}

stmImageToSpacetree::~stmImageToSpacetree()
{
  this->SetRefinementRegion(nullptr);
}

vtkCxxSetObjectMacro(stmImageToSpacetree, RefinementRegion, vtkImplicitFunction);

vtkMTimeType stmImageToSpacetree::GetMTime()
{
  vtkMTimeType time = this->Superclass::GetMTime();
  if (this->RefinementRegion)
  {
    time = std::max(time, this->RefinementRegion->GetMTime());
  }
  return time;
}

void stmImageToSpacetree::SetLabelMaxCellSize(double label, double size)
{
  const int key = static_cast<int>(label);
  const auto found = this->LabelMaxCellSizes.find(key);
  if (found == this->LabelMaxCellSizes.end() || found->second != size)
  {
    this->LabelMaxCellSizes[key] = size;
    this->Modified();
  }
}

void stmImageToSpacetree::RemoveAllLabelMaxCellSizes()
{
  if (!this->LabelMaxCellSizes.empty())
  {
    this->LabelMaxCellSizes.clear();
    this->Modified();
  }
}

int stmImageToSpacetree::GetNumberOfLabelMaxCellSizes() const
{
  return static_cast<int>(this->LabelMaxCellSizes.size());
}

void stmImageToSpacetree::SetNumberOfBodyLabels(int count)
{
  count = std::max(0, count);
  if (static_cast<int>(this->BodyLabels.size()) != count)
  {
    this->BodyLabels.resize(static_cast<std::size_t>(count), 0);
    this->Modified();
  }
}

int stmImageToSpacetree::GetNumberOfBodyLabels() const
{
  return static_cast<int>(this->BodyLabels.size());
}

void stmImageToSpacetree::SetBodyLabel(int index, int label)
{
  if (index < 0)
  {
    vtkErrorMacro("SetBodyLabel: negative index " << index);
    return;
  }
  if (index >= static_cast<int>(this->BodyLabels.size()))
  {
    this->BodyLabels.resize(static_cast<std::size_t>(index) + 1, 0);
  }
  else if (this->BodyLabels[index] == label)
  {
    return;
  }
  this->BodyLabels[index] = label;
  this->Modified();
}

int stmImageToSpacetree::GetBodyLabel(int index) const
{
  return (index >= 0 && index < static_cast<int>(this->BodyLabels.size())) ? this->BodyLabels[index]
                                                                           : 0;
}

void stmImageToSpacetree::AddBodyLabel(int label)
{
  this->BodyLabels.push_back(label);
  this->Modified();
}

void stmImageToSpacetree::RemoveAllBodyLabels()
{
  if (!this->BodyLabels.empty())
  {
    this->BodyLabels.clear();
    this->Modified();
  }
}

void stmImageToSpacetree::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "BodyLabels:";
  if (this->BodyLabels.empty())
  {
    os << " (every label except BackgroundLabel)";
  }
  for (int label : this->BodyLabels)
  {
    os << " " << label;
  }
  os << "\n";
  os << indent << "BackgroundLabel: " << this->BackgroundLabel << "\n";
  os << indent << "MaxCellSize: " << this->MaxCellSize << "\n";
  os << indent << "RefinementPattern: " << this->RefinementPattern << "\n";
  os << indent << "RootCellSize: " << this->RootCellSize[0] << " " << this->RootCellSize[1] << " "
     << this->RootCellSize[2] << "\n";
  os << indent << "LabelMaxCellSizes:";
  for (const auto& entry : this->LabelMaxCellSizes)
  {
    os << " " << entry.first << ":" << entry.second;
  }
  os << (this->LabelMaxCellSizes.empty() ? " (none)\n" : "\n");
  os << indent << "RefinementRegion: " << (this->RefinementRegion ? "" : "(none)\n");
  if (this->RefinementRegion)
  {
    os << this->RefinementRegion->GetClassName() << "\n";
  }
  os << indent << "RegionMaxCellSize: " << this->RegionMaxCellSize << "\n";
  os << indent << "RegionBandWidth: " << this->RegionBandWidth << "\n";
  os << indent << "Grading: " << this->Grading << "\n";
  static const char* const thinPartModes[] = { "NoThinParts", "ThinBodyParts",
    "ThinMaterialParts" };
  os << indent << "ThinPartRefinement: " << thinPartModes[this->ThinPartRefinement] << "\n";
  os << indent << "NumberOfThinVoxels: " << this->NumberOfThinVoxels << "\n";
  os << indent << "NumberOfMinorityCornerVoxels: " << this->NumberOfMinorityCornerVoxels << "\n";
  os << indent << "UseSizingArray: " << (this->UseSizingArray ? "On" : "Off") << "\n";
  os << indent << "SplitIntoPieces: " << (this->SplitIntoPieces ? "On" : "Off") << "\n";
}

int stmImageToSpacetree::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

int stmImageToSpacetree::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  const bool cellLabels = LabelsAreCellData(this);
  const double* direction = inInfo && inInfo->Has(vtkDataObject::DIRECTION())
    ? inInfo->Get(vtkDataObject::DIRECTION())
    : nullptr;
  PieceLayout piece;
  std::string error;
  RootCellCostSource costs;
  costs.Summed = this->HasSummedRootCellCosts ? &this->SummedRootCellCosts : nullptr;
  if (!LayOutRequestedPiece(this, outInfo, inInfo, cellLabels, direction, piece, error, costs) ||
    !piece.Split)
  {
    // RequestData reports a failed layout.
    stmPieces::RequestWholeImageOnFirstPiece(outInfo, inInfo);
    return 1;
  }
  int extent[6] = { 0, -1, 0, -1, 0, -1 };
  vtkMultiProcessController* controller = stmPieces::ControllerOfPieces(outInfo);
  if (controller && !costs.Summed)
  {
    // The first of two passes: each rank reads its slab of the image, for the costs of the
    // root cells (SumRootCellCostsOverSlabs).
    long long firstLayer = 0;
    long long endLayer = 0;
    SlabOfRank(piece, controller->GetLocalProcessId(), controller->GetNumberOfProcesses(),
      firstLayer, endLayer, extent);
    stmPieces::RequestImageExtent(inInfo, extent);
    return 1;
  }
  if (!piece.Empty)
  {
    std::copy(piece.WholeExtent, piece.WholeExtent + 6, extent);
  }
  // Thin-part refinement needs more than the ghost box: a part is thin by its whole component,
  // which may reach beyond it, and whether any voxel of the image is thin decides the lattice.
  // When every rank meshes its own piece, the ranks classify the voxels together, each reading
  // its ghost box grown by one voxel (ClassifyVoxelsInPieces); a pipeline that asks one process
  // for several pieces gets the whole image, which RequestData classifies before it crops.
  const bool classifyTogether = this->ThinPartRefinement != NO_THIN_PARTS && controller != nullptr;
  if (!piece.Empty && (this->ThinPartRefinement == NO_THIN_PARTS || classifyTogether))
  {
    const int grown = classifyTogether ? 1 : 0;
    for (int i = 0; i < piece.Dimension; ++i)
    {
      const int axis = piece.ImageAxes[i];
      const int first = piece.WholeExtent[2 * axis] + static_cast<int>(piece.FirstVoxel[i]);
      extent[2 * axis] = std::max(piece.WholeExtent[2 * axis], first - grown);
      // One point more than point labels need: cell labels, which an unset array selection
      // may turn out to be, need it (RequestData crops the extra voxels away).
      extent[2 * axis + 1] = std::min(
        piece.WholeExtent[2 * axis + 1], first + static_cast<int>(piece.VoxelCount[i]) + grown);
    }
  }
  stmPieces::RequestImageExtent(inInfo, extent);
  return 1;
}

int stmImageToSpacetree::SumRootCellCostsOverSlabs(vtkInformation* request,
  vtkInformationVector** inputVector, vtkInformationVector* outputVector,
  vtkMultiProcessController* controller)
{
  vtkImageData* input = vtkImageData::GetData(inputVector[0], 0);
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  // This rank's slab's costs, left at zero where it cannot tell them (an unusable label array:
  // the second pass reports it); every rank takes part in the sums all the same.
  std::vector<std::int64_t> costs;
  PieceLayout piece;
  std::string error;
  int association = -1;
  vtkDataArray* labels = input
    ? LabelsOrScalars(input, this->GetInputArrayToProcess(0, inputVector, association), association)
    : nullptr;
  const bool cellLabels = association == vtkDataObject::FIELD_ASSOCIATION_CELLS;
  if (labels && labels->GetNumberOfComponents() == 1 && IsLabelType(labels->GetDataType()) &&
    LayOutRequestedPiece(
      this, outInfo, inInfo, cellLabels, input->GetDirectionMatrix()->GetData(), piece, error) &&
    piece.Split)
  {
    int pointDims[3];
    input->GetDimensions(pointDims);
    int extent[6];
    input->GetExtent(extent);
    int voxelDims[3];
    long long inputFirst[3];
    for (int axis = 0; axis < 3; ++axis)
    {
      voxelDims[axis] = VoxelsAlong(pointDims[axis], cellLabels);
      inputFirst[axis] = extent[2 * axis] - piece.WholeExtent[2 * axis];
    }
    const std::vector<long long> body = BodyOf(this->BodyLabels, this->BackgroundLabel,
      this->BodyLabels.empty() ? LabelsOf(labels).Labels : std::vector<long long>());
    const vtkIdType voxels = static_cast<vtkIdType>(voxelDims[0]) * voxelDims[1] * voxelDims[2];
    if (!body.empty() && body.size() <= 65535 && labels->GetNumberOfTuples() == voxels)
    {
      const std::vector<stm::MaterialIndex> materials = MaterialsOf(labels, body);
      long long firstLayer = 0;
      long long endLayer = 0;
      int slabExtent[6];
      SlabOfRank(piece, controller->GetLocalProcessId(), controller->GetNumberOfProcesses(),
        firstLayer, endLayer, slabExtent);
      stmSMPExecutor executor(this);
      costs = piece.Dimension == 3
        ? SlabCosts<3>(piece, materials, voxelDims, inputFirst, firstLayer, endLayer, executor)
        : SlabCosts<2>(piece, materials, voxelDims, inputFirst, firstLayer, endLayer, executor);
    }
  }
  long long size = static_cast<long long>(costs.size());
  long long largest = 0;
  controller->AllReduce(&size, &largest, 1, vtkCommunicator::MAX_OP);
  std::vector<long long> mine(static_cast<std::size_t>(largest), 0);
  if (size == largest)
  {
    std::copy(costs.begin(), costs.end(), mine.begin());
  }
  this->SummedRootCellCosts.assign(mine.size(), 0);
  controller->AllReduce(mine.data(), this->SummedRootCellCosts.data(),
    static_cast<vtkIdType>(largest), vtkCommunicator::SUM_OP);
  this->HasSummedRootCellCosts = true;
  // The executive calls RequestUpdateExtent again, which now lays the pieces out by the costs,
  // and then RequestData for the piece.
  request->Set(vtkStreamingDemandDrivenPipeline::CONTINUE_EXECUTING(), 1);
  if (vtkUnstructuredGrid* output = vtkUnstructuredGrid::GetData(outputVector, 0))
  {
    output->Initialize();
  }
  this->UpdateProgress(0.02);
  return 1;
}

int stmImageToSpacetree::RequestData(vtkInformation* pipelineRequest,
  vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkImageData* input = vtkImageData::GetData(inputVector[0], 0);
  vtkUnstructuredGrid* output = vtkUnstructuredGrid::GetData(outputVector, 0);
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  const bool splitting = this->SplitIntoPieces && stmPieces::RequestedNumberOfPieces(outInfo) > 1;
  if (output && !splitting && stmPieces::RequestedPiece(outInfo) > 0)
  {
    output->Initialize(); // piece 0 meshes the whole image
    return 1;
  }
  // When every rank meshes its own piece, a first pass sums the root cells' costs over slabs of
  // the image, so that the pieces are balanced by cost without any rank reading the whole
  // image; this second pass uses them, and forgets them when it returns.
  vtkMultiProcessController* controller =
    splitting ? stmPieces::ControllerOfPieces(outInfo) : nullptr;
  if (controller && !this->HasSummedRootCellCosts)
  {
    return this->SumRootCellCostsOverSlabs(pipelineRequest, inputVector, outputVector, controller);
  }
  struct ForgetSummedCosts
  {
    bool* Has;
    std::vector<long long>* Costs;
    vtkInformation* Request;
    ~ForgetSummedCosts()
    {
      *this->Has = false;
      this->Costs->clear();
      this->Request->Remove(vtkStreamingDemandDrivenPipeline::CONTINUE_EXECUTING());
    }
  } forget{ &this->HasSummedRootCellCosts, &this->SummedRootCellCosts, pipelineRequest };
  RootCellCostSource costs;
  costs.Summed = controller ? &this->SummedRootCellCosts : nullptr;
  if (!input || !output)
  {
    vtkErrorMacro("ImageToSpacetree needs a vtkImageData input.");
    return 0;
  }
  // With thin-part refinement every rank that meshes its own piece votes whether it can classify
  // its voxels with the others, also when it returns before (the vote's destructor).
  stmThinPartExchange::Vote vote(splitting && this->ThinPartRefinement != NO_THIN_PARTS
      ? stmPieces::ControllerOfPieces(outInfo)
      : nullptr);
  PieceLayout piece;
  const bool assumedCellLabels = LabelsAreCellData(this);
  if (splitting)
  {
    // As RequestUpdateExtent laid it out; a piece without root cells got no voxels.
    std::string error;
    if (!LayOutRequestedPiece(this, outInfo, inputVector[0]->GetInformationObject(0),
          assumedCellLabels, input->GetDirectionMatrix()->GetData(), piece, error, costs))
    {
      vtkErrorMacro("ImageToSpacetree failed: " << error);
      return 0;
    }
    if (piece.Empty)
    {
      if (vote.GetController())
      {
        vote.Take(true, true);
        if (vote.GetAllReady() && !vote.GetAllWhole())
        {
          stmSMPExecutor executor(this);
          ClassifyNoVoxels(vote.GetController(), executor);
        }
      }
      output->Initialize(); // more pieces than root cells
      return 1;
    }
  }

  // The label array.
  int association = -1;
  vtkDataArray* labels = this->GetInputArrayToProcess(0, inputVector, association);
  vtkInformation* selection = this->GetInputArrayInformation(0);
  const char* selectedName = selection->Has(vtkDataObject::FIELD_NAME())
    ? selection->Get(vtkDataObject::FIELD_NAME())
    : nullptr;
  if (!labels && selectedName && *selectedName)
  {
    vtkErrorMacro("The image has no array named \"" << selectedName << "\".");
    return 0;
  }
  labels = LabelsOrScalars(input, labels, association);
  if (!labels)
  {
    vtkErrorMacro("No label array: select an integer point or cell array of the image.");
    return 0;
  }
  if (labels->GetNumberOfComponents() != 1)
  {
    vtkErrorMacro("The label array \"" << (labels->GetName() ? labels->GetName() : "") << "\" has "
                                       << labels->GetNumberOfComponents()
                                       << " components; it must have one.");
    return 0;
  }
  const int type = labels->GetDataType();
  if (!stmImageToSpacetree::IsLabelType(type))
  {
    vtkErrorMacro("The label array \""
      << (labels->GetName() ? labels->GetName() : "") << "\" is of type "
      << labels->GetDataTypeAsString()
      << "; ImageToSpacetree needs integer labels (threshold a gray-value image first).");
    return 0;
  }

  // Voxels per axis: one per point for point data, one per cell for cell data.
  int pointDims[3];
  input->GetDimensions(pointDims);
  const bool cellLabels = association == vtkDataObject::FIELD_ASSOCIATION_CELLS;
  int voxelDims[3];
  for (int axis = 0; axis < 3; ++axis)
  {
    voxelDims[axis] = VoxelsAlong(pointDims[axis], cellLabels);
  }
  double spacing[3];
  input->GetSpacing(spacing);
  const double* direction = input->GetDirectionMatrix()->GetData();
  stmSpacetreeGeometry geometry = ImageGeometry(voxelDims, spacing, direction);
  if (labels->GetNumberOfTuples() !=
    static_cast<vtkIdType>(voxelDims[0]) * voxelDims[1] * voxelDims[2])
  {
    vtkErrorMacro("The label array does not have one value per voxel.");
    return 0;
  }
  if (geometry.Dimension < 2)
  {
    vtkErrorMacro("The image has " << voxelDims[0] << " x " << voxelDims[1] << " x " << voxelDims[2]
                                   << " voxels; ImageToSpacetree needs a 2D or 3D image.");
    return 0;
  }
  if (!(spacing[0] > 0 && spacing[1] > 0 && spacing[2] > 0) || !std::isfinite(spacing[0]) ||
    !std::isfinite(spacing[1]) || !std::isfinite(spacing[2]))
  {
    vtkErrorMacro("The image spacing (" << spacing[0] << ", " << spacing[1] << ", " << spacing[2]
                                        << ") must be positive and finite.");
    return 0;
  }
  input->GetOrigin(geometry.Origin);
  // The first voxel has the extent's first index, not 0, in an image that is part of a larger
  // one (ExtractSubset's VOI, a streamed piece): the lattice starts at that voxel. A piece's
  // lattice starts where the whole image's does, and its voxels are counted from there
  // (LatticeOffset), so that its points are the whole image's, bit for bit.
  int extent[6];
  input->GetExtent(extent);
  if (splitting)
  {
    // Again where the label array's association turned out other than the selection said.
    std::string error;
    if (cellLabels != assumedCellLabels &&
      !LayOutRequestedPiece(this, outInfo, inputVector[0]->GetInformationObject(0), cellLabels,
        direction, piece, error, costs))
    {
      vtkErrorMacro("ImageToSpacetree failed: " << error);
      return 0;
    }
    bool covered = !piece.Empty && piece.Dimension == geometry.Dimension;
    for (int i = 0; i < geometry.Dimension && covered; ++i)
    {
      const int axis = geometry.ImageAxes[i];
      const long long first = extent[2 * axis] - piece.WholeExtent[2 * axis];
      covered = piece.ImageAxes[i] == axis && first <= piece.FirstVoxel[i] &&
        first + voxelDims[axis] >= piece.FirstVoxel[i] + piece.VoxelCount[i];
      geometry.LatticeOffset[i] = static_cast<double>(first);
    }
    if (!covered)
    {
      vtkErrorMacro("ImageToSpacetree failed: the image's extent ("
        << extent[0] << " " << extent[1] << " " << extent[2] << " " << extent[3] << " " << extent[4]
        << " " << extent[5] << ") does not hold the voxels of piece "
        << stmPieces::RequestedPiece(outInfo)
        << " and its ghost layer (select the label array, so that its association is known "
           "when the voxels are requested).");
      return 0;
    }
  }
  for (int axis = 0; axis < 3; ++axis)
  {
    const int first = splitting ? piece.WholeExtent[2 * axis] : extent[2 * axis];
    for (int c = 0; c < 3; ++c)
    {
      geometry.Origin[c] += first * geometry.AxisVectors[axis][c];
    }
  }
  if (!cellLabels)
  {
    // A point-data voxel is centred on its point: the lattice starts half a voxel before it
    // along every axis the spacetree spans.
    for (int i = 0; i < geometry.Dimension; ++i)
    {
      for (int c = 0; c < 3; ++c)
      {
        geometry.Origin[c] -= 0.5 * geometry.AxisVectors[geometry.ImageAxes[i]][c];
      }
    }
  }
  this->UpdateProgress(0.05);

  // The body of interest.
  const CollectLabels collect = LabelsOf(labels);
  if (collect.OutOfRange)
  {
    vtkErrorMacro("The label array holds values outside the 32-bit integer range.");
    return 0;
  }
  const std::vector<long long> body =
    BodyOf(this->BodyLabels, this->BackgroundLabel, collect.Labels);
  if (this->BodyLabels.empty())
  {
    if (body.empty())
    {
      if (splitting)
      {
        if (vote.GetController())
        {
          // The other pieces may read this piece's background voxels to classify their own.
          const std::vector<stm::MaterialIndex> background(
            static_cast<std::size_t>(labels->GetNumberOfTuples()), stm::BackgroundMaterial);
          std::vector<std::uint8_t> thin, minorityCorner;
          std::int64_t wholeThinVoxels = 0;
          std::string error;
          stmSMPExecutor executor(this);
          if (ClassifyTogether(vote, this, outInfo, inputVector[0]->GetInformationObject(0),
                cellLabels, direction, piece, costs, extent, voxelDims, background, executor, thin,
                minorityCorner, wholeThinVoxels, error) == Classification::Failed &&
            !this->GetAbortExecute())
          {
            vtkErrorMacro("ImageToSpacetree failed: " << error);
            return 0;
          }
        }
        output->Initialize(); // the body lies in other pieces
        return 1;
      }
      vtkErrorMacro("The body of interest is empty: the image holds no label other than the "
                    "background label "
        << this->BackgroundLabel << ".");
      return 0;
    }
  }
  else
  {
    for (long long label : body)
    {
      if (label == this->BackgroundLabel)
      {
        vtkErrorMacro("Body label " << label
                                    << " equals the background label; choose another "
                                       "BackgroundLabel.");
        return 0;
      }
      if (!splitting && !std::binary_search(collect.Labels.begin(), collect.Labels.end(), label))
      {
        vtkErrorMacro("Body label " << label << " does not occur in the label array \""
                                    << (labels->GetName() ? labels->GetName() : "") << "\".");
        return 0;
      }
    }
  }
  if (body.size() > 65535)
  {
    vtkErrorMacro(
      "The body of interest has " << body.size() << " labels; at most 65535 are supported.");
    return 0;
  }
  std::vector<stm::MaterialIndex> materials = MaterialsOf(labels, body);
  std::vector<long long> materialLabels{ this->BackgroundLabel };
  materialLabels.insert(materialLabels.end(), body.begin(), body.end());
  this->UpdateProgress(0.2);
  if (this->CheckAbort())
  {
    return 1;
  }

  // The size criteria.
  RefinementRequest request;
  request.Pattern = this->RefinementPattern;
  std::copy(this->RootCellSize, this->RootCellSize + 3, request.RootCellSize);
  request.MaxCellSize = this->MaxCellSize;
  request.Grading = this->Grading;
  request.ThinParts = this->ThinPartRefinement;
  if (this->Grading != 0 && !(this->Grading >= 1.5))
  {
    vtkErrorMacro("Grading must be 0 (off) or at least 1.5, got " << this->Grading << ".");
    return 0;
  }
  if (this->Grading != 0 && splitting)
  {
    // Grading reaches further than the ghost layer: the pieces would not match.
    vtkErrorMacro("Grading is not supported with Split Into Pieces.");
    return 0;
  }
  request.MaterialMaxCellSizes.assign(materialLabels.size(), 0.0);
  for (const auto& entry : this->LabelMaxCellSizes)
  {
    const auto found = std::lower_bound(body.begin(), body.end(), entry.first);
    if (found == body.end() || *found != entry.first)
    {
      if (splitting)
      {
        continue; // a label of another piece
      }
      vtkErrorMacro("LabelMaxCellSizes names label " << entry.first
                                                     << ", which is not in the body of interest.");
      return 0;
    }
    if (!(entry.second >= 1) || !std::isfinite(entry.second))
    {
      vtkErrorMacro("The largest cell size of label "
        << entry.first << " must be at least 1 voxel, got " << entry.second
        << " (use a refinement region or a sizing array below the voxel size).");
      return 0;
    }
    request.MaterialMaxCellSizes[found - body.begin() + 1] = entry.second;
  }
  request.RegionMaxCellSize = this->RegionMaxCellSize;
  if (!(this->RegionMaxCellSize >= 0) || !std::isfinite(this->RegionMaxCellSize))
  {
    vtkErrorMacro("RegionMaxCellSize must be positive (or 0 to disable the region), got "
      << this->RegionMaxCellSize << ".");
    return 0;
  }
  if (this->RegionMaxCellSize > 0)
  {
    if (!this->RefinementRegion)
    {
      vtkErrorMacro("RegionMaxCellSize is set but there is no RefinementRegion.");
      return 0;
    }
    request.InRegion.assign(materials.size(), 0);
    vtkImplicitFunction* region = this->RefinementRegion;
    const double halfBand = 0.5 * this->RegionBandWidth;
    vtkSMPTools::For(0, static_cast<vtkIdType>(materials.size()),
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType v = begin; v < end; ++v)
        {
          double centre[3] = { 0, 0, 0 };
          vtkIdType rest = v;
          for (int axis = 0; axis < 3; ++axis)
          {
            centre[axis] = static_cast<double>(rest % voxelDims[axis]) + 0.5;
            rest /= voxelDims[axis];
          }
          double lattice[3];
          for (int i = 0; i < geometry.Dimension; ++i)
          {
            lattice[i] = centre[geometry.ImageAxes[i]];
          }
          double x[3];
          geometry.ToPhysical(lattice, x);
          const double value = region->FunctionValue(x);
          request.InRegion[v] = halfBand > 0 ? std::abs(value) <= halfBand : value <= 0;
        }
      });
    // A piece may lie away from the region.
    if (!splitting &&
      std::find(request.InRegion.begin(), request.InRegion.end(), 1) == request.InRegion.end())
    {
      vtkErrorMacro("The refinement region contains no voxel centre of the image: it lies "
                    "outside the image or is thinner than a voxel.");
      return 0;
    }
  }
  if (this->UseSizingArray)
  {
    int sizingAssociation = -1;
    vtkDataArray* sizing = this->GetInputArrayToProcess(1, inputVector, sizingAssociation);
    if (!sizing || sizing->GetNumberOfComponents() != 1 ||
      sizing->GetNumberOfTuples() != labels->GetNumberOfTuples() ||
      sizingAssociation != association)
    {
      vtkErrorMacro("UseSizingArray is on, but input array 1 is not a one-component array with "
                    "the label array's association (point or cell data).");
      return 0;
    }
    request.Sizing.resize(materials.size());
    std::atomic<bool> invalid{ false };
    vtkSMPTools::For(0, sizing->GetNumberOfTuples(),
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType v = begin; v < end; ++v)
        {
          const double value = sizing->GetComponent(v, 0);
          request.Sizing[v] = value;
          if (!(value > 0) || !std::isfinite(value))
          {
            invalid = true;
          }
        }
      });
    if (invalid)
    {
      vtkErrorMacro("The sizing array \"" << (sizing->GetName() ? sizing->GetName() : "")
                                          << "\" holds sizes that are not positive and finite.");
      return 0;
    }
  }
  this->UpdateProgress(0.25);
  if (this->CheckAbort())
  {
    return 1;
  }

  // A piece: its ghost box's voxels only (BuildTree plans it as the whole image).
  if (splitting)
  {
    geometry.IsPiece = true;
    std::vector<std::uint8_t> thin;
    std::vector<std::uint8_t> minorityCorner;
    Classification classification = Classification::WholeImages;
    if (vote.GetController())
    {
      stmSMPExecutor classifier(this);
      classifier.SetProgressRange(0.25, 0.4);
      std::string classifyError;
      classification =
        ClassifyTogether(vote, this, outInfo, inputVector[0]->GetInformationObject(0), cellLabels,
          direction, piece, costs, extent, voxelDims, materials, classifier, thin, minorityCorner,
          request.WholeThinVoxels, classifyError);
      if (classification == Classification::Failed)
      {
        if (!this->GetAbortExecute())
        {
          vtkErrorMacro("ImageToSpacetree failed: " << classifyError);
        }
        return this->GetAbortExecute() ? 1 : 0;
      }
      request.VoxelClassesGiven = classification == Classification::Together;
    }
    if (request.ThinParts != NO_THIN_PARTS && classification == Classification::WholeImages)
    {
      // A pipeline that asks one process for several pieces, or every rank given the whole image:
      // a thin part is one by its whole component.
      stmSMPExecutor classifier(this);
      classifier.SetProgressRange(0.25, 0.4);
      std::string classifyError;
      const bool classified = geometry.Dimension == 3
        ? ClassifyVoxels<3>(ImageOfVoxels<3>(materials, voxelDims, geometry), request, classifier,
            thin, minorityCorner, classifyError)
        : ClassifyVoxels<2>(ImageOfVoxels<2>(materials, voxelDims, geometry), request, classifier,
            thin, minorityCorner, classifyError);
      if (!classified)
      {
        if (!this->GetAbortExecute())
        {
          vtkErrorMacro("ImageToSpacetree failed: " << classifyError);
        }
        return this->GetAbortExecute() ? 1 : 0;
      }
      request.VoxelClassesGiven = true;
      request.WholeThinVoxels = std::count(thin.begin(), thin.end(), std::uint8_t{ 1 });
      // With the whole image here, the pieces are balanced by the cells their voxels will make
      // rather than by their root cells: a cut across the middle of the AAL atlas's longest
      // axis gave one of two ranks 55 % of the cells. Every rank estimates the same costs, so
      // the boxes still partition the root grid; the empty pieces are the same.
      bool whole = true;
      for (int axis = 0; axis < 3; ++axis)
      {
        whole = whole && voxelDims[axis] == piece.WholeVoxelDims[axis] &&
          extent[2 * axis] == piece.WholeExtent[2 * axis];
      }
      std::string layoutError;
      stmSMPExecutor estimator(this);
      RootCellCostSource wholeCosts = costs;
      if (!wholeCosts.Summed)
      {
        wholeCosts.WholeImage = &materials;
        wholeCosts.Executor = &estimator;
      }
      if (whole &&
        !LayOutRequestedPiece(this, outInfo, inputVector[0]->GetInformationObject(0), cellLabels,
          direction, piece, layoutError, wholeCosts))
      {
        vtkErrorMacro("ImageToSpacetree failed: " << layoutError);
        return 0;
      }
      if (piece.Empty)
      {
        output->Initialize();
        return 1;
      }
    }
    long long first[3] = { 0, 0, 0 };
    int count[3] = { voxelDims[0], voxelDims[1], voxelDims[2] };
    for (int i = 0; i < geometry.Dimension; ++i)
    {
      const int axis = geometry.ImageAxes[i];
      first[axis] = piece.FirstVoxel[i] - static_cast<long long>(geometry.LatticeOffset[i]);
      count[axis] = static_cast<int>(piece.VoxelCount[i]);
      geometry.LatticeOffset[i] = static_cast<double>(piece.FirstVoxel[i]);
      geometry.OwnedRootLower[i] = piece.OwnedLower[i] - piece.GhostLower[i];
      geometry.OwnedRootUpper[i] = piece.OwnedUpper[i] - piece.GhostLower[i];
    }
    if (!thin.empty())
    {
      request.ThinVoxels = CropVoxels(thin, voxelDims, first, count);
    }
    if (!minorityCorner.empty())
    {
      request.MinorityCornerVoxels = CropVoxels(minorityCorner, voxelDims, first, count);
    }
    materials = CropVoxels(materials, voxelDims, first, count);
    if (!request.InRegion.empty())
    {
      request.InRegion = CropVoxels(request.InRegion, voxelDims, first, count);
    }
    if (!request.Sizing.empty())
    {
      request.Sizing = CropVoxels(request.Sizing, voxelDims, first, count);
    }
    std::copy(count, count + 3, voxelDims);
    if (std::none_of(materials.begin(), materials.end(),
          [](stm::MaterialIndex m) { return m != stm::BackgroundMaterial; }))
    {
      // No body voxel in the piece's ghost box: the body, and the background cells
      // next to it, lie in other pieces (a small body on many ranks).
      output->Initialize();
      return 1;
    }
  }

  stmSMPExecutor executor(this);
  executor.SetProgressRange(0.25, 0.9);
  std::string error;
  BuildReport report;
  this->NumberOfThinVoxels = 0;
  this->NumberOfMinorityCornerVoxels = 0;
  const bool built = geometry.Dimension == 3
    ? BuildTree<3>(materials, voxelDims, splitting ? &piece : nullptr, geometry, materialLabels,
        request, executor, output, report, error)
    : BuildTree<2>(materials, voxelDims, splitting ? &piece : nullptr, geometry, materialLabels,
        request, executor, output, report, error);
  if (!report.Warning.empty())
  {
    vtkWarningMacro(<< report.Warning);
  }
  this->NumberOfThinVoxels = report.ThinVoxels;
  this->NumberOfMinorityCornerVoxels = report.MinorityCornerVoxels;
  if (!built)
  {
    if (!this->GetAbortExecute())
    {
      vtkErrorMacro("ImageToSpacetree failed: " << error);
      return 0;
    }
    output->Initialize();
    return 1;
  }
  this->UpdateProgress(1.0);
  return 1;
}
