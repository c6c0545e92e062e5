// SPDX-License-Identifier: BSD-3-Clause
#include "stmBoundarySmooth.h"

#include "stmCutInput.h"
#include "stmPieceBorder.h"
#include "stmPieceExchange.h"
#include "stmPieces.h"
#include "stmPlaneFrame.h"
#include "stmSMPExecutor.h"

#include "Common/ExactSum.h"
#include "Cut/LevelSetProjection.h"
#include "Smooth/BoundarySmooth.h"
#include "Smooth/InteriorEdgeSplit.h"
#include "Spacetree/RootPieces.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCellType.h"
#include "vtkDataArray.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkIdList.h"
#include "vtkImplicitFunction.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkLookupTable.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkSMPTools.h"
#include "vtkSmartPointer.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

vtkStandardNewMacro(stmBoundarySmooth);
vtkCxxSetObjectMacro(stmBoundarySmooth, ImplicitFunction, vtkImplicitFunction);

namespace
{
struct SmoothRequest
{
  stmBoundarySmooth* Filter;
  vtkUnstructuredGrid* Input;
  vtkUnstructuredGrid* Output;
  stm::BoundarySmoothOptions Options;
  vtkImplicitFunction* Function; // null: no projection
  stmPlaneFrame Coordinates;
  stm::BoundarySmoothStats Stats;
  vtkIdType SplitEdges = 0;
  // Pieces on the ranks of an MPI run (stmPieceBorder): the controller, whether this rank has
  // taken its part in the pass over the shared points, and what the pass did.
  vtkMultiProcessController* Controller = nullptr;
  bool BorderPassTaken = false;
  stmPieceBorder::Stats Border;
  // Whether this rank has taken its part in the agreement on exchanging during the steps
  // (stmPieceExchange).
  bool ExchangeAgreed = false;
};

/// This rank's part in stmPieceBorder's pass when it has no piece to smooth (`ready`: an empty
/// piece) or its smoothing failed (not `ready`: no rank then changes anything).
void TakePartWithNothing(SmoothRequest& request, bool ready)
{
  if (!request.Controller || request.BorderPassTaken)
  {
    return;
  }
  if (!request.ExchangeAgreed)
  {
    request.ExchangeAgreed = true;
    stmPieceExchange::AllAgree(request.Controller, false);
  }
  request.BorderPassTaken = true;
  stmSMPExecutor executor(request.Filter);
  stmPieceBorder::ImproveSharedPoints(
    request.Controller, ready, stmPieceBorder::Piece<3, vtkIdType>(), [](std::int64_t, double*) {},
    request.Options, stm::NoProjection(), executor, request.Border);
}

/// The cells with the edits of InteriorEdgeSplit, stored as Storage (32- or 64-bit ids).
template <class Storage, int Dim, class IdType>
vtkSmartPointer<vtkCellArray> SplitCellArray(
  const IdType* connectivity, vtkIdType cells, const stm::InteriorEdgeSplit<Dim>& split)
{
  using Value = typename Storage::ValueType;
  const auto& appended = split.GetAppendedCells();
  const vtkIdType total = cells + static_cast<vtkIdType>(appended.size());
  vtkNew<Storage> offsets, ids;
  offsets->SetNumberOfValues(total + 1);
  ids->SetNumberOfValues(total * (Dim + 1));
  Value* offsetValues = offsets->GetPointer(0);
  Value* idValues = ids->GetPointer(0);
  vtkSMPTools::For(0, total + 1,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType c = begin; c < end; ++c)
      {
        offsetValues[c] = static_cast<Value>(c * (Dim + 1));
        for (int k = 0; k <= Dim && c < cells; ++k)
        {
          idValues[c * (Dim + 1) + k] = static_cast<Value>(connectivity[c * (Dim + 1) + k]);
        }
      }
    });
  for (const auto& changed : split.GetChangedCells())
  {
    for (int k = 0; k <= Dim; ++k)
    {
      idValues[changed.first * (Dim + 1) + k] = static_cast<Value>(changed.second[k]);
    }
  }
  for (std::size_t c = 0; c < appended.size(); ++c)
  {
    for (int k = 0; k <= Dim; ++k)
    {
      idValues[(cells + static_cast<vtkIdType>(c)) * (Dim + 1) + k] =
        static_cast<Value>(appended[c][k]);
    }
  }
  vtkNew<vtkCellArray> cellArray;
  cellArray->SetData(offsets, ids);
  return cellArray;
}

/// A copy of `source` with room for `tuples` tuples (at least its own), allocated once: a deep
/// copy and a resize would hold the array twice at the peak. It keeps what DeepCopy keeps: the
/// name, the component names, the information and a data array's lookup table.
vtkSmartPointer<vtkAbstractArray> ExtendedCopy(vtkAbstractArray* source, vtkIdType tuples)
{
  vtkSmartPointer<vtkAbstractArray> copy = vtk::TakeSmartPointer(source->NewInstance());
  copy->SetName(source->GetName());
  copy->SetNumberOfComponents(source->GetNumberOfComponents());
  copy->CopyComponentNames(source);
  if (source->HasInformation())
  {
    copy->CopyInformation(source->GetInformation(), /*deep=*/1);
  }
  vtkDataArray* sourceData = vtkDataArray::SafeDownCast(source);
  if (sourceData && sourceData->GetLookupTable())
  {
    vtkSmartPointer<vtkLookupTable> table =
      vtk::TakeSmartPointer(sourceData->GetLookupTable()->NewInstance());
    table->DeepCopy(sourceData->GetLookupTable());
    vtkDataArray::SafeDownCast(copy)->SetLookupTable(table);
  }
  copy->SetNumberOfTuples(tuples);
  copy->InsertTuples(0, source->GetNumberOfTuples(), 0, source);
  return copy;
}

/// The output with the edits of InteriorEdgeSplit: new points appended (point data at the
/// edge's midpoint, zero displacement), cells changed in place and appended (cell data of the
/// cell each was split from). An edge may end at a point an earlier split added, so the ends are
/// read from the extended arrays, which hold every new point before the next one. A piece whose
/// smoothing was exchanged splits with the exchange the edges the whole mesh's run splits;
/// another piece splits only edges between its own points (not `heldPoints`).
template <int Dim, class IdType>
stm::Status SplitEdges(SmoothRequest& request, const IdType* connectivity,
  const std::vector<double>& local, const std::uint8_t* heldPoints,
  stm::SmoothingExchange* exchange, stmSMPExecutor& executor)
{
  // A 64-bit copy: InteriorEdgeSplit keeps 64-bit materials, and the smoother's records, the
  // peak of the stage, are freed by now.
  const std::vector<std::int64_t> materials = stmCutInput::CellMaterials(request.Input);
  vtkUnstructuredGrid* output = request.Output;
  const vtkIdType points = output->GetNumberOfPoints();
  const vtkIdType cells = output->GetNumberOfCells();
  stm::InteriorEdgeSplitOptions options;
  options.MaxConditionNumber = request.Options.MaxConditionNumber;
  options.MinDihedralAngle = request.Options.MinDihedralAngle;
  options.HeldPoints = exchange ? nullptr : heldPoints;
  options.Exchange = exchange;
  options.GhostCells = exchange ? stmPieces::GhostCellFlags(request.Input) : nullptr;
  stm::InteriorEdgeSplit<Dim> split;
  const stm::Status status = split.Split(local.data(), points, connectivity, cells,
    materials.empty() ? nullptr : materials.data(), options, executor);
  if (!status.IsOk() || split.GetNewPoints().empty())
  {
    return status;
  }
  request.SplitEdges = static_cast<vtkIdType>(split.GetNewPoints().size());

  // Bulk copies of the arrays (a copy per tuple through vtkPointData costs seconds on millions
  // of points), then the few new tuples.
  vtkPoints* smoothed = output->GetPoints();
  const vtkIdType added = request.SplitEdges;
  vtkNew<vtkPoints> allPoints;
  allPoints->SetDataType(smoothed->GetDataType());
  allPoints->SetNumberOfPoints(points + added);
  allPoints->GetData()->InsertTuples(0, points, 0, smoothed->GetData());
  vtkPointData* smoothedPD = output->GetPointData();
  vtkNew<vtkPointData> pointData;
  vtkNew<vtkIdList> ends;
  ends->SetNumberOfIds(2);
  double halves[2] = { 0.5, 0.5 };
  for (int a = 0; a < smoothedPD->GetNumberOfArrays(); ++a)
  {
    vtkAbstractArray* source = smoothedPD->GetAbstractArray(a);
    vtkSmartPointer<vtkAbstractArray> copy = ExtendedCopy(source, points + added);
    for (vtkIdType n = 0; n < added; ++n)
    {
      const auto& point = split.GetNewPoints()[static_cast<std::size_t>(n)];
      ends->SetId(0, point.A);
      ends->SetId(1, point.B);
      copy->InterpolateTuple(points + n, ends, copy, halves);
    }
    pointData->AddArray(copy);
  }
  for (int attribute = 0; attribute < vtkDataSetAttributes::NUM_ATTRIBUTES; ++attribute)
  {
    if (vtkAbstractArray* active = smoothedPD->GetAbstractAttribute(attribute))
    {
      pointData->SetActiveAttribute(active->GetName(), attribute);
    }
  }
  for (vtkIdType n = 0; n < added; ++n)
  {
    const auto& point = split.GetNewPoints()[static_cast<std::size_t>(n)];
    double a[3], b[3], base[3], x[3];
    allPoints->GetPoint(point.A, a);
    allPoints->GetPoint(point.B, b);
    for (int c = 0; c < 3; ++c)
    {
      base[c] = 0.5 * (a[c] + b[c]);
    }
    request.Coordinates.Lift<Dim>(point.Position.data(), base, x);
    allPoints->InsertPoint(points + n, x);
  }
  if (vtkDataArray* displacement = pointData->GetArray("SmoothingDisplacement"))
  {
    for (vtkIdType n = 0; n < added; ++n)
    {
      displacement->SetTuple3(points + n, 0.0, 0.0, 0.0);
    }
  }

  const auto& appended = split.GetAppendedCells();
  const vtkIdType total = cells + static_cast<vtkIdType>(appended.size());
  const bool fits32 = points + added < VTK_TYPE_INT32_MAX && total * (Dim + 1) < VTK_TYPE_INT32_MAX;
  vtkSmartPointer<vtkCellArray> cellArray = fits32
    ? SplitCellArray<vtkTypeInt32Array, Dim>(connectivity, cells, split)
    : SplitCellArray<vtkTypeInt64Array, Dim>(connectivity, cells, split);
  vtkCellData* smoothedCD = output->GetCellData();
  vtkNew<vtkCellData> cellData;
  for (int a = 0; a < smoothedCD->GetNumberOfArrays(); ++a)
  {
    vtkAbstractArray* source = smoothedCD->GetAbstractArray(a);
    vtkSmartPointer<vtkAbstractArray> copy = ExtendedCopy(source, total);
    for (vtkIdType c = cells; c < total; ++c)
    {
      copy->SetTuple(c, split.GetAppendedParents()[static_cast<std::size_t>(c - cells)], source);
    }
    cellData->AddArray(copy);
  }
  for (int attribute = 0; attribute < vtkDataSetAttributes::NUM_ATTRIBUTES; ++attribute)
  {
    if (vtkAbstractArray* active = smoothedCD->GetAbstractAttribute(attribute))
    {
      cellData->SetActiveAttribute(active->GetName(), attribute);
    }
  }

  vtkNew<vtkUnstructuredGrid> result;
  result->SetPoints(allPoints);
  result->SetCells(Dim == 3 ? VTK_TETRA : VTK_TRIANGLE, cellArray);
  result->GetPointData()->ShallowCopy(pointData);
  result->GetCellData()->ShallowCopy(cellData);
  result->GetFieldData()->ShallowCopy(output->GetFieldData());
  output->ShallowCopy(result);
  return stm::Status::Ok();
}

/// For a piece (stmImageToSpacetree::SplitIntoPieces), 1 at the points of its ghost cells,
/// which the smoothing holds so that adjacent pieces keep their shared points; empty for a mesh
/// without ghost cells.
template <int Dim, class IdType>
std::vector<std::uint8_t> GhostCellPoints(vtkUnstructuredGrid* input, const IdType* connectivity)
{
  if (!stmPieces::HasGhostCells(input))
  {
    return {};
  }
  const unsigned char* ghosts = stmPieces::GhostCellFlags(input);
  const vtkIdType cells = input->GetNumberOfCells();
  std::vector<std::uint8_t> held(static_cast<std::size_t>(input->GetNumberOfPoints()), 0);
  for (vtkIdType c = 0; c < cells; ++c)
  {
    for (int v = 0; v <= Dim && ghosts[c] != 0; ++v)
    {
      held[static_cast<std::size_t>(connectivity[c * (Dim + 1) + v])] = 1;
    }
  }
  return held;
}

/// The tessellation's root colours (stmPieces::RootColourName), by which the smoothing orders
/// its moves alike in a whole mesh and in its pieces; null without them, or with values that are
/// no root colours of a Dim-dimensional grid (a warning: e.g. a 3D mesh's array on a 2D mesh).
template <int Dim>
const std::uint8_t* RootColours(vtkAlgorithm* filter, vtkUnstructuredGrid* input)
{
  auto* colours = vtkUnsignedCharArray::SafeDownCast(
    input->GetCellData()->GetAbstractArray(stmPieces::RootColourName));
  if (!colours || colours->GetNumberOfComponents() != 1 ||
    colours->GetNumberOfTuples() != input->GetNumberOfCells() || colours->GetNumberOfTuples() == 0)
  {
    return nullptr;
  }
  const int limit = stm::RootColouring<Dim>::NumberOfColours;
  const unsigned char* values = colours->GetPointer(0);
  if (*std::max_element(values, values + colours->GetNumberOfTuples()) >= limit)
  {
    vtkWarningWithObjectMacro(filter,
      "the cell array " << stmPieces::RootColourName << " holds values of " << limit
                        << " or more, no root colours of a " << Dim
                        << "D spacetree: the smoothing orders its moves by point ids instead");
    return nullptr;
  }
  return values;
}

/// The mean length of the edges of the own cells (no ghost, by ghostCells when given), each
/// edge counted once per cell. With a controller, of every piece's own cells (collective): the
/// exact sums' parts are gathered, so the pieces get the whole mesh's value bit for bit.
template <int Dim, class IdType>
double MeanEdgeLength(const double* coordinates, const IdType* connectivity, std::int64_t cells,
  const unsigned char* ghostCells, vtkMultiProcessController* controller)
{
  stm::ExactSum lengths;
  std::int64_t edges = 0;
  for (std::int64_t c = 0; c < cells; ++c)
  {
    if (ghostCells && ghostCells[c])
    {
      continue;
    }
    const IdType* corners = connectivity + c * (Dim + 1);
    for (int a = 0; a < Dim; ++a)
    {
      for (int b = a + 1; b <= Dim; ++b)
      {
        double squared = 0.0;
        for (int axis = 0; axis < Dim; ++axis)
        {
          const double d = coordinates[static_cast<std::int64_t>(corners[a]) * Dim + axis] -
            coordinates[static_cast<std::int64_t>(corners[b]) * Dim + axis];
          squared += d * d;
        }
        lengths.Add(std::sqrt(squared));
        ++edges;
      }
    }
  }
  if (controller)
  {
    const std::vector<double> parts =
      stmPieceBorder::detail::AllGather(controller, lengths.Parts());
    lengths = stm::ExactSum();
    for (double part : parts)
    {
      lengths.Add(part);
    }
    const vtkTypeInt64 own = edges;
    vtkTypeInt64 all = 0;
    controller->AllReduce(&own, &all, 1, vtkCommunicator::SUM_OP);
    edges = all;
  }
  return edges > 0 ? lengths.Value() / static_cast<double>(edges) : 0.0;
}

template <int Dim, class IdType>
stm::Status Smooth(SmoothRequest& request, const IdType* connectivity)
{
  vtkUnstructuredGrid* input = request.Input;
  const vtkIdType points = input->GetNumberOfPoints();
  const vtkIdType cells = input->GetNumberOfCells();
  vtkPoints* inputPoints = input->GetPoints();
  const stmPlaneFrame& frame = request.Coordinates;
  std::vector<double> local = frame.CoreCoordinates<Dim>(inputPoints);
  std::vector<std::int64_t> originals =
    request.Filter->GetRestoreOriginalVolumes() && request.Options.TargetVolumes.empty()
    ? stmCutInput::CellMaterials(input, "OriginalMaterial")
    : std::vector<std::int64_t>();
  request.Options.VolumeTargetMaterials = originals.empty() ? nullptr : originals.data();
  const std::vector<std::uint8_t> held = GhostCellPoints<Dim>(input, connectivity);
  request.Options.HeldPoints = held.empty() ? nullptr : held.data();
  request.Options.GhostCells = held.empty() ? nullptr : stmPieces::GhostCellFlags(input);
  request.Options.CellRootColours = RootColours<Dim>(request.Filter, input);
  // Pieces on the ranks of an MPI run with the tessellation's root colours move every point as
  // the whole mesh's steps do (stmPieceExchange), if every rank can.
  std::unique_ptr<stmPieceExchange::Exchange> exchange;
  stmPieceExchange::Movers movers;
  if (request.Controller)
  {
    request.ExchangeAgreed = true;
    // The cut's volume targets are exchanged by their exact parts.
    vtkDataArray* volumeParts = input->GetFieldData()->GetArray(stmPieces::VolumePartsName);
    volumeParts = volumeParts && volumeParts->GetNumberOfComponents() == 2 ? volumeParts : nullptr;
    const bool can = !held.empty() && request.Options.CellRootColours &&
      request.Coordinates.CopiesCoordinates() && Dim >= 2 &&
      (request.Options.TargetVolumes.empty() || volumeParts);
    if (stmPieceExchange::AllAgree(request.Controller, can))
    {
      // Every part of the smoothing then moves the shared points as the whole mesh's does: no
      // rank takes the pass over them (stmPieceBorder), not even one whose smoothing fails.
      request.BorderPassTaken = true;
      if (!request.Options.TargetVolumes.empty())
      {
        request.Options.TargetVolumes =
          stmPieceExchange::SumVolumeParts(request.Controller, volumeParts);
      }
      movers = stmPieceExchange::FindMovers<Dim>(connectivity, cells, points,
        stmPieces::GhostCellFlags(input), request.Options.CellRootColours);
      exchange = std::make_unique<stmPieceExchange::Exchange>(
        request.Controller, stm::RootColouring<Dim>::NumberOfColours);
      exchange->Build<Dim>(connectivity, cells, points, held.data(), movers,
        [inputPoints](std::int64_t p, double* key) { inputPoints->GetPoint(p, key); });
      request.Options.Exchange = exchange.get();
      request.Options.HeldPoints = movers.Held.data();
      request.Options.GhostPoints = held.data();
      vtkDebugWithObjectMacro(request.Filter,
        "exchanging " << exchange->GetNumberOfSentPoints() << " points with "
                      << exchange->GetNumberOfPeers() << " pieces; "
                      << exchange->GetNumberOfUnmatchedPoints() << " held points unmatched");
      // Every point of a ghost cell lies in a cell of the piece that moves it, which sends it:
      // one without a match is a point the other pieces' meshes do not have.
      if (exchange->GetNumberOfUnmatchedPoints() > 0)
      {
        vtkWarningWithObjectMacro(request.Filter,
          "The pieces' meshes differ where they meet, so the mesh may have cracks there: of the "
          "points of this piece's ghost cells, "
            << exchange->GetNumberOfUnmatchedPoints()
            << " are no point of the pieces that own those cells (the snapping decided a point on "
               "their border differently; see docs/design.md, \"Why two root cells of "
               "ghosts\"). The smoothing leaves them where this piece has them.");
      }
    }
  }

  // The projector: Newton steps onto f = 0 of the implicit function, in the frame. VTK's
  // implicit functions may update a transform when evaluated, so evaluations are serialised.
  // The mean edge (the projector's step limit and tolerance scale) only with a projector: a
  // serial pass over every cell costs a noticeable part of the smoothing of a large mesh. It is
  // the whole mesh's in every piece that exchanges, so that the pieces project as it does.
  vtkImplicitFunction* function = request.Function;
  const double meanEdge = function
    ? MeanEdgeLength<Dim>(local.data(), connectivity, cells, request.Options.GhostCells,
        exchange ? request.Controller : nullptr)
    : 0.0;
  std::mutex evaluation;
  auto evaluate = [&](const double* position, double* gradient, const double* base)
  {
    double x[3], g[3];
    frame.Lift<Dim>(position, base, x);
    std::lock_guard<std::mutex> lock(evaluation);
    const double value = function->FunctionValue(x);
    function->FunctionGradient(x, g);
    frame.FlattenGradient<Dim>(g, gradient);
    return value;
  };
  auto projector = [&](std::int64_t id, double* position)
  {
    double base[3];
    inputPoints->GetPoint(id, base);
    double point[Dim];
    std::copy(position, position + Dim, point);
    double gradient[Dim];
    evaluate(point, gradient, base);
    double norm = 0.0;
    for (int a = 0; a < Dim; ++a)
    {
      norm += gradient[a] * gradient[a];
    }
    stm::LevelSetProjectionOptions options;
    options.MaxDistance = meanEdge;
    options.Tolerance = 1e-10 * std::sqrt(norm) * meanEdge;
    auto evaluateHere = [&](const double* x, double* g) { return evaluate(x, g, base); };
    if (!stm::ProjectToLevelSet<Dim>(point, evaluateHere, options))
    {
      return false;
    }
    std::copy(point, point + Dim, position);
    return true;
  };

  stmSMPExecutor executor(request.Filter);
  executor.SetProgressRange(0.05, 0.95);
  std::vector<std::uint8_t> roles; // the smoother's, for stmPieceBorder
  {
    // Scoped: the smoother's incidence and cell records (AAL, 116 labels: 430 MB) are freed
    // before the output's arrays are made.
    stm::BoundarySmoother<Dim> smoother;
    const stm::Status status = stmCutInput::WithCellMaterials(input,
      [&](const auto* materials)
      {
        return function ? smoother.Smooth(local.data(), points, connectivity, cells, materials,
                            request.Options, projector, executor)
                        : smoother.Smooth(local.data(), points, connectivity, cells, materials,
                            request.Options, executor);
      });
    if (!status.IsOk())
    {
      return status;
    }
    request.Stats = smoother.GetStats();
    if (request.Controller && !exchange)
    {
      roles = smoother.GetPointRoles();
    }
  }
  request.Options.Exchange = nullptr;
  request.Options.HeldPoints = held.empty() ? nullptr : held.data();
  request.Options.GhostPoints = nullptr;
  if (request.Controller && !exchange)
  {
    // The points the pieces share, and the cells at them (stmPieceBorder), now that every
    // piece has smoothed its own points.
    request.BorderPassTaken = true;
    const std::vector<std::int64_t> materials = stmCutInput::CellMaterials(input);
    const stmPieceBorder::Piece<Dim, IdType> piece{ local.data(), points, connectivity, cells,
      stmPieces::GhostCellFlags(input), held.empty() ? nullptr : held.data(),
      materials.empty() ? nullptr : materials.data(), roles.data() };
    auto keyOf = [inputPoints](std::int64_t p, double* key) { inputPoints->GetPoint(p, key); };
    executor.SetProgressRange(0.95, 0.95);
    const bool ready = frame.CopiesCoordinates(); // the same coordinates on every rank
    const stm::Status status = function
      ? stmPieceBorder::ImproveSharedPoints(request.Controller, ready, piece, keyOf,
          request.Options, projector, executor, request.Border)
      : stmPieceBorder::ImproveSharedPoints(request.Controller, ready, piece, keyOf,
          request.Options, stm::NoProjection(), executor, request.Border);
    if (!status.IsOk())
    {
      return status;
    }
  }
  std::vector<std::int64_t>().swap(originals);
  request.Options.VolumeTargetMaterials = nullptr;
  request.Options.HeldPoints = nullptr;
  request.Options.GhostCells = nullptr;
  request.Options.CellRootColours = nullptr;

  // The output: the input's cells and arrays, the moved points in the input's precision. The
  // root colours served the smoothing alone.
  vtkUnstructuredGrid* output = request.Output;
  output->ShallowCopy(input);
  output->GetCellData()->RemoveArray(stmPieces::RootColourName);
  output->GetFieldData()->RemoveArray(stmPieces::VolumePartsName);
  vtkNew<vtkPoints> moved;
  moved->SetDataType(inputPoints->GetDataType());
  moved->DeepCopy(inputPoints);
  vtkNew<vtkDoubleArray> displacement;
  displacement->SetName("SmoothingDisplacement");
  displacement->SetNumberOfComponents(3);
  displacement->SetNumberOfTuples(points);
  vtkSMPTools::For(0, points,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType p = begin; p < end; ++p)
      {
        double before[3], check[Dim], after[3];
        inputPoints->GetPoint(p, before);
        frame.ToCore<Dim>(before, check);
        if (std::equal(check, check + Dim, local.data() + p * Dim))
        {
          displacement->SetTuple3(p, 0.0, 0.0, 0.0);
          continue;
        }
        frame.Lift<Dim>(local.data() + p * Dim, before, after);
        moved->SetPoint(p, after);
        moved->GetPoint(p, after); // in the stored precision
        displacement->SetTuple3(
          p, after[0] - before[0], after[1] - before[1], after[2] - before[2]);
      }
    });
  output->SetPoints(moved);
  output->GetPointData()->AddArray(displacement);
  // Every rank takes part in an exchanged split, even when aborted (it tells the others so).
  if (!request.Filter->GetSplitInteriorEdges() || (!exchange && request.Filter->GetAbortExecute()))
  {
    return stm::Status::Ok();
  }
  return SplitEdges<Dim>(
    request, connectivity, local, held.empty() ? nullptr : held.data(), exchange.get(), executor);
}
} // namespace

stmBoundarySmooth::stmBoundarySmooth() = default;

stmBoundarySmooth::~stmBoundarySmooth()
{
  this->SetImplicitFunction(nullptr);
}

void stmBoundarySmooth::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "NumberOfIterations: " << this->NumberOfIterations << "\n";
  os << indent << "Method: " << (this->Method == TAUBIN ? "Taubin" : "Laplacian") << "\n";
  os << indent << "RelaxationFactor: " << this->RelaxationFactor << "\n";
  os << indent << "PassBand: " << this->PassBand << "\n";
  os << indent << "MaxDisplacement: " << this->MaxDisplacement << "\n";
  os << indent << "NumberOfInteriorLayers: " << this->NumberOfInteriorLayers << "\n";
  os << indent << "InteriorRelaxationInterval: " << this->InteriorRelaxationInterval << "\n";
  os << indent << "SmallPartPoints: " << this->SmallPartPoints << "\n";
  os << indent << "MaxConditionNumber: " << this->MaxConditionNumber << "\n";
  os << indent << "MinDihedralAngle: " << this->MinDihedralAngle << "\n";
  os << indent << "NumberOfImprovementSweeps: " << this->NumberOfImprovementSweeps << "\n";
  os << indent
     << "ImprovementMovesInterfaces: " << (this->ImprovementMovesInterfaces ? "On" : "Off") << "\n";
  os << indent << "SplitInteriorEdges: " << (this->SplitInteriorEdges ? "On" : "Off") << "\n";
  os << indent << "RestoreOriginalVolumes: " << (this->RestoreOriginalVolumes ? "On" : "Off")
     << "\n";
  os << indent << "BackgroundMaterial: " << this->BackgroundMaterial << "\n";
  os << indent << "ProjectToFunction: " << (this->ProjectToFunction ? "On" : "Off") << "\n";
  os << indent << "ImplicitFunction: " << (this->ImplicitFunction ? "" : "(none)\n");
  if (this->ImplicitFunction)
  {
    os << "\n";
    this->ImplicitFunction->PrintSelf(os, indent.GetNextIndent());
  }
  os << indent << "NumberOfMovedPoints: " << this->NumberOfMovedPoints << "\n";
  os << indent << "NumberOfRejectedMoves: " << this->NumberOfRejectedMoves << "\n";
  os << indent << "NumberOfImprovedPoints: " << this->NumberOfImprovedPoints << "\n";
  os << indent << "NumberOfSplitEdges: " << this->NumberOfSplitEdges << "\n";
  os << indent << "NumberOfKeptPoints: " << this->NumberOfKeptPoints << "\n";
  os << indent << "LargestVolumeErrorBefore: " << this->LargestVolumeErrorBefore << "\n";
  os << indent << "LargestVolumeErrorAfter: " << this->LargestVolumeErrorAfter << "\n";
}

vtkMTimeType stmBoundarySmooth::GetMTime()
{
  vtkMTimeType time = this->Superclass::GetMTime();
  if (this->ImplicitFunction)
  {
    time = std::max(time, this->ImplicitFunction->GetMTime());
  }
  return time;
}

int stmBoundarySmooth::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkUnstructuredGrid* input = vtkUnstructuredGrid::GetData(inputVector[0], 0);
  vtkUnstructuredGrid* output = vtkUnstructuredGrid::GetData(outputVector, 0);
  this->NumberOfMovedPoints = 0;
  this->NumberOfRejectedMoves = 0;
  this->NumberOfImprovedPoints = 0;
  this->NumberOfSplitEdges = 0;
  this->NumberOfKeptPoints = 0;
  this->LargestVolumeErrorBefore = 0.0;
  this->LargestVolumeErrorAfter = 0.0;
  output->Initialize();
  SmoothRequest request{ this, input, output, {},
    this->ProjectToFunction ? this->ImplicitFunction : nullptr, {}, {} };
  request.Controller = stmPieces::ControllerOfPieces(outputVector->GetInformationObject(0));
  auto fail = [&](const std::string& message)
  {
    output->Initialize();
    TakePartWithNothing(request, false);
    vtkErrorMacro(<< "BoundarySmooth failed: " << message);
    return 0;
  };
  std::string typeError;
  const int dimension = stmCutInput::Preflight(
    inputVector[0], input, "cut it with Marching Simplices or tetrahedralize it first", typeError);
  if (dimension < 0)
  {
    // An empty piece, or an upstream filter was aborted: an empty output, quietly.
    TakePartWithNothing(request, true);
    return 1;
  }
  if (dimension == 0)
  {
    return fail(typeError);
  }
  if (!(this->RelaxationFactor > 0.0 && this->RelaxationFactor <= 1.0))
  {
    return fail(
      "RelaxationFactor must be in (0, 1], got " + std::to_string(this->RelaxationFactor));
  }
  if (!(this->PassBand > 0.0 && this->PassBand < 1.0))
  {
    return fail("PassBand must be in (0, 1), got " + std::to_string(this->PassBand));
  }
  if (!(this->MaxConditionNumber >= 1.0))
  {
    return fail("MaxConditionNumber must be >= 1, got " + std::to_string(this->MaxConditionNumber));
  }
  if (!(this->MinDihedralAngle >= 0.0 && this->MinDihedralAngle < 180.0))
  {
    return fail("MinDihedralAngle must be in [0, 180) degrees, got " +
      std::to_string(this->MinDihedralAngle));
  }
  if (this->ProjectToFunction && !this->ImplicitFunction)
  {
    return fail("ProjectToFunction is on but no ImplicitFunction is set");
  }
  // The targets of RestoreOriginalVolumes: stmMultiMaterialCut's volumes per material before
  // its snapping moved points, else the volumes of the input cells per OriginalMaterial.
  vtkDataArray* targetVolumes = input->GetFieldData()->GetArray("OriginalMaterialVolumes");
  targetVolumes =
    targetVolumes && targetVolumes->GetNumberOfComponents() == 2 ? targetVolumes : nullptr;
  if (this->RestoreOriginalVolumes &&
    !(input->GetCellData()->GetArray("Material") &&
      (targetVolumes || input->GetCellData()->GetArray("OriginalMaterial"))))
  {
    return fail("RestoreOriginalVolumes needs the cell array Material, and the field array "
                "OriginalMaterialVolumes or the cell array OriginalMaterial");
  }

  request.Options.Method =
    this->Method == LAPLACIAN ? stm::SmoothingMethod::Laplacian : stm::SmoothingMethod::Taubin;
  request.Options.NumberOfIterations = this->NumberOfIterations;
  request.Options.RelaxationFactor = this->RelaxationFactor;
  request.Options.PassBand = this->PassBand;
  request.Options.MaxDisplacement = this->MaxDisplacement;
  request.Options.NumberOfInteriorLayers = this->NumberOfInteriorLayers;
  request.Options.InteriorRelaxationInterval = this->InteriorRelaxationInterval;
  request.Options.SmallPartPoints = this->SmallPartPoints;
  request.Options.MaxConditionNumber = this->MaxConditionNumber;
  request.Options.MinDihedralAngle = this->MinDihedralAngle;
  request.Options.NumberOfImprovementSweeps = this->NumberOfImprovementSweeps;
  request.Options.ImprovementMovesInterfaces = this->ImprovementMovesInterfaces;
  for (vtkIdType t = 0;
       this->RestoreOriginalVolumes && targetVolumes && t < targetVolumes->GetNumberOfTuples(); ++t)
  {
    request.Options.TargetVolumes[static_cast<std::int64_t>(targetVolumes->GetComponent(t, 0))] =
      targetVolumes->GetComponent(t, 1);
  }
  request.Options.BackgroundMaterial = this->BackgroundMaterial;
  std::string problem;
  if (!request.Coordinates.Build(input, dimension,
        "only planar triangle meshes and tetrahedral meshes can be smoothed", problem))
  {
    return fail(problem);
  }
  // Float points receive exactly the validated positions only when the frame copies
  // coordinates (3D, or a coordinate plane).
  request.Options.SinglePrecision =
    input->GetPoints()->GetDataType() == VTK_FLOAT && request.Coordinates.CopiesCoordinates();
  this->UpdateProgress(0.05);

  vtkCellArray* cells = input->GetCells();
  const stm::Status status = stmCutInput::DispatchSimplices(cells, dimension,
    [&](auto dim, const auto* ids) { return Smooth<decltype(dim)::value>(request, ids); });
  if (!status.IsOk())
  {
    output->Initialize();
    if (this->GetAbortExecute() || status.GetCode() == stm::Status::Code::Aborted)
    {
      TakePartWithNothing(request, false);
      return 1;
    }
    return fail(status.GetMessage());
  }
  this->NumberOfMovedPoints = static_cast<vtkIdType>(request.Stats.MovedPoints);
  this->NumberOfRejectedMoves = static_cast<vtkIdType>(request.Stats.RejectedMoves);
  this->NumberOfImprovedPoints =
    static_cast<vtkIdType>(request.Stats.ImprovedPoints + request.Border.ImprovedPoints);
  this->NumberOfSplitEdges = request.SplitEdges;
  this->NumberOfKeptPoints = static_cast<vtkIdType>(request.Stats.KeptPoints);
  this->LargestVolumeErrorBefore = request.Stats.LargestVolumeErrorBefore;
  this->LargestVolumeErrorAfter = request.Stats.LargestVolumeErrorAfter;
  this->UpdateProgress(1.0);
  return 1;
}
