// SPDX-License-Identifier: BSD-3-Clause
#include "stmVertexSnap.h"

#include "stmCutInput.h"
#include "stmFunctionValues.h"
#include "stmGrayImagePieces.h"
#include "stmPieceExchange.h"
#include "stmPieces.h"
#include "stmPlaneFrame.h"
#include "stmSMPExecutor.h"
#include "stmSnapExchange.h"
#include "stmSurfaceFunction.h"

#include "Cut/LevelSetProjection.h"
#include "Cut/VertexSnap.h"

#include "vtkCellArray.h"
#include "vtkDataArray.h"
#include "vtkImageData.h"
#include "vtkImplicitFunction.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMath.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkSMPTools.h"
#include "vtkSmartPointer.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

vtkStandardNewMacro(stmVertexSnap);
vtkCxxSetObjectMacro(stmVertexSnap, ImplicitFunction, vtkImplicitFunction);

namespace
{
struct SnapRequest
{
  stmVertexSnap* Filter;
  vtkUnstructuredGrid* Input;
  std::vector<double>* Values;
  stm::VertexSnapOptions Options;
  const stmSurfaceFunction* Surface; // null: edge intersections only
  std::vector<vtkIdType> MovedPoints;
  std::vector<double> MovedPositions; // 3 per moved point
  std::vector<std::uint8_t> Moved;    // 1 moved, 2 nudged
  stm::VertexSnapCounts Counts;
  // Pieces on the ranks of an MPI run: the controller, and whether this rank has taken its part
  // in the agreement on exchanging the snap's states (stmSnapExchange).
  vtkMultiProcessController* Controller = nullptr;
  bool ExchangeAgreed = false;
};

/// This rank's part in the agreement on exchanging when it snaps nothing (an empty piece, or a
/// failure before the snap): no rank then exchanges.
void TakePartWithNothing(SnapRequest& request)
{
  if (request.Controller && !request.ExchangeAgreed)
  {
    request.ExchangeAgreed = true;
    stmPieceExchange::AllAgree(request.Controller, false);
  }
}

template <int Dim, class IdType>
stm::Status Snap(SnapRequest& request, const IdType* connectivity, std::string& error)
{
  vtkUnstructuredGrid* input = request.Input;
  vtkPoints* inputPoints = input->GetPoints();
  const vtkIdType numberOfPoints = input->GetNumberOfPoints();
  stmPlaneFrame frame;
  if (!frame.Build(input, Dim, "vertex snapping needs a planar triangle mesh", error))
  {
    TakePartWithNothing(request);
    return stm::Status::Invalid(error);
  }
  std::vector<double> coordinates = frame.CoreCoordinates<Dim>(inputPoints);
  // Pieces on the ranks of an MPI run decide as the whole mesh does (stmSnapExchange), if every
  // rank has a piece with ghost cells.
  std::unique_ptr<stmSnapExchange> exchange;
  if (request.Controller)
  {
    request.ExchangeAgreed = true;
    if (stmPieceExchange::AllAgree(request.Controller, stmPieces::HasGhostCells(input)))
    {
      exchange = std::make_unique<stmSnapExchange>(request.Controller, inputPoints,
        stmSnapExchange::FindOwnPoints<Dim>(connectivity, input->GetNumberOfCells(), numberOfPoints,
          stmPieces::GhostCellFlags(input)));
      request.Options.Exchange = exchange.get();
    }
  }

  stmSMPExecutor executor(request.Filter);
  executor.SetProgressRange(0.1, 0.9);
  stm::VertexSnap<Dim> snap;
  stm::Status status;
  if (request.Surface)
  {
    const stmSurfaceFunction* surface = request.Surface;
    stm::LevelSetProjectionOptions projection;
    projection.IsoValue = request.Options.IsoValue;
    // Converged well within the zero tolerance (Newton gets there in a few steps from the edge's
    // intersection); the snap sets f to exactly IsoValue.
    projection.Tolerance =
      request.Options.ZeroTolerance > 0 ? std::min(request.Options.ZeroTolerance, 1e-12) : 1e-12;
    // The Newton steps stay within the box of the vertex's cells (starBox), whatever the piece:
    // a piece's gray image covers its points' bounds, and a step beyond them would fail in a
    // piece where the whole image lets it converge.
    auto projector = [&](std::int64_t point, const double*, const double* target,
                       const double* starBox, double* result)
    {
      double x[Dim], original[3];
      std::copy(target, target + Dim, x);
      inputPoints->GetPoint(static_cast<vtkIdType>(point), original);
      stm::LevelSetProjectionOptions withinStar = projection;
      withinStar.MaxDistance = 0.0;
      for (int c = 0; c < Dim; ++c)
      {
        withinStar.MaxDistance += (starBox[Dim + c] - starBox[c]) * (starBox[Dim + c] - starBox[c]);
      }
      withinStar.MaxDistance = std::sqrt(withinStar.MaxDistance);
      auto evaluate = [&](const double* y, double* gradient)
      {
        for (int c = 0; c < Dim; ++c)
        {
          if (!(y[c] >= starBox[c] && y[c] <= starBox[Dim + c]))
          {
            return std::nan("");
          }
        }
        double position[3], spatialGradient[3];
        frame.Lift<Dim>(y, original, position);
        const double value = surface->EvaluateWithGradient(position, spatialGradient);
        frame.FlattenGradient<Dim>(spatialGradient, gradient);
        return value;
      };
      if (!stm::ProjectToLevelSet<Dim>(x, evaluate, withinStar))
      {
        return false;
      }
      std::copy(x, x + Dim, result);
      return true;
    };
    status = snap.Snap(coordinates.data(), request.Values->data(), numberOfPoints, connectivity,
      input->GetNumberOfCells(), request.Options, projector, executor);
  }
  else
  {
    status = snap.Snap(coordinates.data(), request.Values->data(), numberOfPoints, connectivity,
      input->GetNumberOfCells(), request.Options, executor);
  }
  if (!status.IsOk())
  {
    return status;
  }
  // A held point that no piece sends lies on another piece's own cell that piece does not have.
  if (exchange && exchange->GetNumberOfUnmatchedPoints() > 0)
  {
    vtkWarningWithObjectMacro(request.Filter,
      "The pieces' meshes differ where they meet: of the points of this piece's ghost cells "
      "whose snap it decides, "
        << exchange->GetNumberOfUnmatchedPoints()
        << " are no point of the pieces that own those cells, which decide them; this piece "
           "decides them without the other pieces, and the mesh may have cracks there.");
  }
  request.Moved = snap.GetMovedFlags();
  const std::vector<std::uint8_t>& nudged = snap.GetNudgedFlags();
  for (std::size_t p = 0; p < nudged.size(); ++p)
  {
    request.Moved[p] = nudged[p] ? 2 : request.Moved[p];
  }
  request.Counts = snap.GetCounts();
  for (vtkIdType p = 0; p < numberOfPoints; ++p)
  {
    if (request.Moved[p] == 1)
    {
      double original[3], x[3];
      inputPoints->GetPoint(p, original);
      frame.Lift<Dim>(coordinates.data() + p * Dim, original, x);
      request.MovedPoints.push_back(p);
      request.MovedPositions.insert(request.MovedPositions.end(), x, x + 3);
    }
  }
  return stm::Status::Ok();
}
} // namespace

stmVertexSnap::stmVertexSnap()
  : GrayPieces(new stmGrayImagePieces)
{
  this->SetNumberOfInputPorts(2);
  this->SetInputArrayToProcess(
    0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS, "SeparatingFunction");
}

stmVertexSnap::~stmVertexSnap()
{
  this->SetImplicitFunction(nullptr);
}

void stmVertexSnap::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Alpha: " << this->Alpha << "\n";
  os << indent << "QualityBound: " << this->QualityBound << "\n";
  os << indent << "SnapRule: " << (this->SnapRule == THRESHOLD ? "Threshold" : "QualityDriven")
     << "\n";
  os << indent << "IsoValue: " << this->IsoValue << "\n";
  os << indent << "ZeroTolerance: " << this->ZeroTolerance << "\n";
  os << indent << "Projection: " << (this->Projection == EDGE ? "Edge" : "Function") << "\n";
  os << indent << "ImplicitFunction: " << (this->ImplicitFunction ? "" : "(none)\n");
  if (this->ImplicitFunction)
  {
    os << "\n";
    this->ImplicitFunction->PrintSelf(os, indent.GetNextIndent());
  }
  os << indent << "Threshold: " << this->Threshold << "\n";
  os << indent << "InsideAboveThreshold: " << (this->InsideAboveThreshold ? "On" : "Off") << "\n";
  os << indent << "NumberOfSnappedPoints: " << this->NumberOfSnappedPoints << "\n";
  os << indent << "NumberOfRefusedSnaps: " << this->NumberOfRefusedSnaps << "\n";
  os << indent << "NumberOfAdjustedPoints: " << this->NumberOfAdjustedPoints << "\n";
}

vtkMTimeType stmVertexSnap::GetMTime()
{
  vtkMTimeType time = this->Superclass::GetMTime();
  if (this->ImplicitFunction)
  {
    time = std::max(time, this->ImplicitFunction->GetMTime());
  }
  return time;
}

int stmVertexSnap::FillInputPortInformation(int port, vtkInformation* info)
{
  if (port == 1)
  {
    info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
    return 1;
  }
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkUnstructuredGrid");
  return 1;
}

int stmVertexSnap::RequestUpdateExtent(
  vtkInformation* request, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  const int result = this->Superclass::RequestUpdateExtent(request, inputVector, outputVector);
  this->GrayPieces->Request(
    outputVector->GetInformationObject(0), inputVector[1]->GetInformationObject(0));
  return result;
}

int stmVertexSnap::RequestData(vtkInformation* pipelineRequest, vtkInformationVector** inputVector,
  vtkInformationVector* outputVector)
{
  vtkUnstructuredGrid* input = vtkUnstructuredGrid::GetData(inputVector[0], 0);
  vtkUnstructuredGrid* output = vtkUnstructuredGrid::GetData(outputVector, 0);
  stmGrayImagePieces::Scope grayPass(this->GrayPieces.get(), pipelineRequest);
  this->NumberOfSnappedPoints = 0;
  this->NumberOfRefusedSnaps = 0;
  this->NumberOfAdjustedPoints = 0;
  output->Initialize();
  SnapRequest request{ this, input, nullptr, {}, nullptr, {}, {}, {}, {} };
  request.Controller = stmPieces::ControllerOfPieces(outputVector->GetInformationObject(0));
  auto fail = [&](const std::string& message)
  {
    output->Initialize();
    TakePartWithNothing(request);
    vtkErrorMacro(<< "VertexSnap failed: " << message);
    return 0;
  };
  std::string error;
  const int dimension =
    stmCutInput::Preflight(inputVector[0], input, stmCutInput::TessellateSimplicialFirst, error);
  if (dimension < 0)
  {
    TakePartWithNothing(request);
    return 1; // an empty piece, or an upstream filter was aborted: an empty output, quietly
  }
  if (dimension == 0)
  {
    return fail(error);
  }
  int association = -1;
  vtkDataArray* function = this->GetInputArrayToProcess(0, input, association);
  const char* name = this->GetInputArrayInformation(0)->Get(vtkDataObject::FIELD_NAME());
  function = stmCutInput::FindSeparatingFunction(function, association, name, input, error);
  if (!function)
  {
    return fail(error);
  }

  stmSurfaceFunction surface;
  const bool project = this->Projection == FUNCTION;
  if (project)
  {
    vtkImageData* image = vtkImageData::GetData(inputVector[1], 0);
    vtkInformation* grayInfo = inputVector[1]->GetInformationObject(0);
    if (this->ImplicitFunction)
    {
      surface.SetImplicitFunction(this->ImplicitFunction);
    }
    else if (!image)
    {
      return fail("Projection is Function, but there is neither an implicit function nor a gray "
                  "image on input port 1");
    }
    else if (this->GrayPieces->IsFirstPass(
               pipelineRequest, outputVector->GetInformationObject(0), grayInfo, image, input))
    {
      grayPass.KeepGoing();
      return 1; // the second pass samples the voxels around the piece's points
    }
    else if (!surface.SetGrayImage(image, stmGrayImagePieces::WholeExtent(grayInfo),
               this->Threshold, this->InsideAboveThreshold, error))
    {
      return fail(error);
    }
  }

  std::vector<double> values;
  const double* source = stmFunctionValues::AsDoubles(function, values);
  if (source != values.data())
  {
    values.assign(source, source + function->GetNumberOfTuples());
  }
  this->UpdateProgress(0.05);
  request.Values = &values;
  request.Surface = project ? &surface : nullptr;
  request.Options.Alpha = this->Alpha;
  request.Options.QualityBound = this->QualityBound;
  request.Options.Rule =
    this->SnapRule == QUALITY_DRIVEN ? stm::SnapRule::QualityDriven : stm::SnapRule::Threshold;
  request.Options.IsoValue = this->IsoValue;
  request.Options.ZeroTolerance = this->ZeroTolerance;
  vtkCellArray* cells = input->GetCells();
  const stm::Status status = stmCutInput::DispatchSimplices(cells, dimension,
    [&](auto dim, const auto* ids) { return Snap<decltype(dim)::value>(request, ids, error); });
  if (!status.IsOk())
  {
    output->Initialize();
    TakePartWithNothing(request);
    if (this->GetAbortExecute() || status.GetCode() == stm::Status::Code::Aborted)
    {
      return 1;
    }
    return fail(status.GetMessage());
  }

  // The input, with its points (in their precision) and the function updated where they moved.
  output->ShallowCopy(input);
  vtkNew<vtkPoints> points;
  points->SetDataType(input->GetPoints()->GetDataType());
  points->DeepCopy(input->GetPoints());
  auto updated = vtkSmartPointer<vtkDataArray>::Take(function->NewInstance());
  updated->DeepCopy(function);
  for (std::size_t i = 0; i < request.MovedPoints.size(); ++i)
  {
    points->SetPoint(request.MovedPoints[i], request.MovedPositions.data() + 3 * i);
    updated->SetComponent(request.MovedPoints[i], 0, this->IsoValue);
  }
  for (vtkIdType p = 0; p < input->GetNumberOfPoints(); ++p)
  {
    if (request.Moved[p] == 2)
    {
      updated->SetComponent(p, 0, values[p]); // nudged: only f changed
    }
  }
  output->SetPoints(points);
  vtkPointData* outPD = output->GetPointData();
  const bool wasScalars = outPD->GetScalars() == function;
  for (int a = 0; a < outPD->GetNumberOfArrays(); ++a)
  {
    if (outPD->GetAbstractArray(a) == function)
    {
      outPD->RemoveArray(a);
      break;
    }
  }
  outPD->AddArray(updated);
  if (wasScalars)
  {
    outPD->SetScalars(updated);
  }
  vtkNew<vtkUnsignedCharArray> snapped;
  snapped->SetName("Snapped");
  snapped->SetNumberOfValues(input->GetNumberOfPoints());
  std::copy(request.Moved.begin(), request.Moved.end(), snapped->GetPointer(0));
  outPD->AddArray(snapped);
  this->NumberOfSnappedPoints = request.Counts.Snapped;
  this->NumberOfRefusedSnaps = request.Counts.Refused();
  this->NumberOfAdjustedPoints = request.Counts.Nudged;
  this->UpdateProgress(1.0);
  return 1;
}
