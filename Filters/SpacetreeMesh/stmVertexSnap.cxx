// SPDX-License-Identifier: BSD-3-Clause
#include "stmVertexSnap.h"

#include "stmCutInput.h"
#include "stmFunctionValues.h"
#include "stmSMPExecutor.h"
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
#include <string>
#include <vector>

vtkStandardNewMacro(stmVertexSnap);
vtkCxxSetObjectMacro(stmVertexSnap, ImplicitFunction, vtkImplicitFunction);

namespace
{
/// The core's Dim coordinates of the mesh points: 3D as they are; for triangles, two coordinates
/// in their plane (the two other axes when the plane is orthogonal to an axis, so that moved
/// points keep exact coordinates, else an orthonormal frame).
template <int Dim>
struct PlaneFrame
{
  vtkPoints* Points = nullptr;
  int Axes[2] = { 0, 1 };
  bool AxisAligned = true;
  double Origin[3] = { 0, 0, 0 };
  double U[3] = { 1, 0, 0 };
  double W[3] = { 0, 1, 0 };

  template <class IdType>
  bool Build(vtkPoints* points, const IdType* connectivity, vtkIdType cells, std::string& error)
  {
    this->Points = points;
    if (Dim == 3)
    {
      return true;
    }
    double normal[3] = { 0, 0, 0 };
    for (vtkIdType cell = 0; cell < cells; ++cell)
    {
      double a[3], b[3], c[3], ab[3], ac[3], n[3];
      points->GetPoint(connectivity[3 * cell], a);
      points->GetPoint(connectivity[3 * cell + 1], b);
      points->GetPoint(connectivity[3 * cell + 2], c);
      vtkMath::Subtract(b, a, ab);
      vtkMath::Subtract(c, a, ac);
      vtkMath::Cross(ab, ac, n);
      // Inconsistently oriented triangles must not cancel: align each with the sum so far.
      const double sign = vtkMath::Dot(n, normal) < 0 ? -1.0 : 1.0;
      for (int k = 0; k < 3; ++k)
      {
        normal[k] += sign * n[k];
      }
    }
    if (vtkMath::Norm(normal) == 0.0)
    {
      error = "the triangles have no area";
      return false;
    }
    points->GetPoint(0, this->Origin);
    int zeros = 0, normalAxis = 0;
    for (int k = 0; k < 3; ++k)
    {
      zeros += normal[k] == 0.0 ? 1 : 0;
      normalAxis = normal[k] != 0.0 ? k : normalAxis;
    }
    this->AxisAligned = zeros == 2;
    vtkMath::Normalize(normal);
    if (this->AxisAligned)
    {
      this->Axes[0] = (normalAxis + 1) % 3;
      this->Axes[1] = (normalAxis + 2) % 3;
    }
    else
    {
      vtkMath::Perpendiculars(normal, this->U, this->W, 0.0);
    }
    double bounds[6];
    points->GetBounds(bounds);
    const double tolerance = 1e-9 *
      std::max(1.0,
        std::sqrt((bounds[1] - bounds[0]) * (bounds[1] - bounds[0]) +
          (bounds[3] - bounds[2]) * (bounds[3] - bounds[2]) +
          (bounds[5] - bounds[4]) * (bounds[5] - bounds[4])));
    for (vtkIdType p = 0; p < points->GetNumberOfPoints(); ++p)
    {
      double x[3], d[3];
      points->GetPoint(p, x);
      vtkMath::Subtract(x, this->Origin, d);
      if (std::abs(vtkMath::Dot(d, normal)) > tolerance)
      {
        error = "the triangles do not lie in one plane (point " + std::to_string(p) +
          " is off it); vertex snapping needs a planar triangle mesh";
        return false;
      }
    }
    return true;
  }

  void ToCore(const double x[3], double* core) const
  {
    if (Dim == 3)
    {
      std::copy(x, x + 3, core);
    }
    else if (this->AxisAligned)
    {
      core[0] = x[this->Axes[0]];
      core[1] = x[this->Axes[1]];
    }
    else
    {
      double d[3];
      vtkMath::Subtract(x, this->Origin, d);
      core[0] = vtkMath::Dot(d, this->U);
      core[1] = vtkMath::Dot(d, this->W);
    }
  }

  /// The 3D position of point `point` moved to core coordinates: only its in-plane coordinates
  /// change.
  void Lift(vtkIdType point, const double* core, double x[3]) const
  {
    this->Points->GetPoint(point, x);
    if (Dim == 3)
    {
      std::copy(core, core + 3, x);
      return;
    }
    if (this->AxisAligned)
    {
      x[this->Axes[0]] = core[0];
      x[this->Axes[1]] = core[1];
      return;
    }
    double now[2];
    this->ToCore(x, now);
    for (int k = 0; k < 3; ++k)
    {
      x[k] += (core[0] - now[0]) * this->U[k] + (core[1] - now[1]) * this->W[k];
    }
  }

  /// A 3D gradient as a gradient in the core coordinates (its in-plane part).
  void FlattenGradient(const double gradient[3], double* core) const
  {
    if (Dim == 3)
    {
      std::copy(gradient, gradient + 3, core);
    }
    else if (this->AxisAligned)
    {
      core[0] = gradient[this->Axes[0]];
      core[1] = gradient[this->Axes[1]];
    }
    else
    {
      core[0] = vtkMath::Dot(gradient, this->U);
      core[1] = vtkMath::Dot(gradient, this->W);
    }
  }
};

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
};

template <int Dim, class IdType>
stm::Status Snap(SnapRequest& request, const IdType* connectivity, std::string& error)
{
  vtkUnstructuredGrid* input = request.Input;
  vtkPoints* inputPoints = input->GetPoints();
  const vtkIdType numberOfPoints = input->GetNumberOfPoints();
  PlaneFrame<Dim> frame;
  if (!frame.Build(inputPoints, connectivity, input->GetNumberOfCells(), error))
  {
    return stm::Status::Invalid(error);
  }
  std::vector<double> coordinates(static_cast<std::size_t>(numberOfPoints) * Dim);
  vtkSMPTools::For(0, numberOfPoints,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType p = begin; p < end; ++p)
      {
        double x[3];
        inputPoints->GetPoint(p, x);
        frame.ToCore(x, coordinates.data() + p * Dim);
      }
    });

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
    projection.MaxDistance = std::max(input->GetLength(), 1e-300);
    auto projector = [&](std::int64_t point, const double*, const double* target, double* result)
    {
      double x[Dim];
      std::copy(target, target + Dim, x);
      auto evaluate = [&](const double* y, double* gradient)
      {
        double position[3], spatialGradient[3];
        frame.Lift(static_cast<vtkIdType>(point), y, position);
        const double value = surface->EvaluateWithGradient(position, spatialGradient);
        frame.FlattenGradient(spatialGradient, gradient);
        return value;
      };
      if (!stm::ProjectToLevelSet<Dim>(x, evaluate, projection))
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
      double x[3];
      frame.Lift(p, coordinates.data() + p * Dim, x);
      request.MovedPoints.push_back(p);
      request.MovedPositions.insert(request.MovedPositions.end(), x, x + 3);
    }
  }
  return stm::Status::Ok();
}
} // namespace

stmVertexSnap::stmVertexSnap()
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

int stmVertexSnap::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkUnstructuredGrid* input = vtkUnstructuredGrid::GetData(inputVector[0], 0);
  vtkUnstructuredGrid* output = vtkUnstructuredGrid::GetData(outputVector, 0);
  this->NumberOfSnappedPoints = 0;
  this->NumberOfRefusedSnaps = 0;
  this->NumberOfAdjustedPoints = 0;
  output->Initialize();
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  if (inInfo && inInfo->Get(vtkAlgorithm::ABORTED()))
  {
    return 1; // an upstream filter was aborted: an empty output, quietly
  }
  auto fail = [&](const std::string& message)
  {
    output->Initialize();
    vtkErrorMacro(<< "VertexSnap failed: " << message);
    return 0;
  };
  if (!input || input->GetNumberOfCells() == 0)
  {
    return fail("the input mesh has no cells");
  }
  int offendingType = 0;
  const int dimension = stmCutInput::SimplexDimension(input, offendingType);
  if (dimension == 0)
  {
    return fail("the input must be a mesh of only tetrahedra or only triangles, but it has cells "
                "of VTK type " +
      std::to_string(offendingType) +
      "; tessellate with Output Type Simplicial (or run Tetrahedralize) first");
  }
  int association = -1;
  vtkDataArray* function = this->GetInputArrayToProcess(0, input, association);
  const char* name = this->GetInputArrayInformation(0)->Get(vtkDataObject::FIELD_NAME());
  std::string error;
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
    if (this->ImplicitFunction)
    {
      surface.SetImplicitFunction(this->ImplicitFunction);
    }
    else if (!image)
    {
      return fail("Projection is Function, but there is neither an implicit function nor a gray "
                  "image on input port 1");
    }
    else if (!surface.SetGrayImage(image, this->Threshold, this->InsideAboveThreshold, error))
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
  SnapRequest request{ this, input, &values, {}, project ? &surface : nullptr, {}, {}, {}, {} };
  request.Options.Alpha = this->Alpha;
  request.Options.QualityBound = this->QualityBound;
  request.Options.Rule =
    this->SnapRule == QUALITY_DRIVEN ? stm::SnapRule::QualityDriven : stm::SnapRule::Threshold;
  request.Options.IsoValue = this->IsoValue;
  request.Options.ZeroTolerance = this->ZeroTolerance;
  vtkCellArray* cells = input->GetCells();
  stm::Status status;
  if (cells->IsStorage64Bit())
  {
    const vtkTypeInt64* ids = cells->GetConnectivityArray64()->GetPointer(0);
    status = dimension == 3 ? Snap<3>(request, ids, error) : Snap<2>(request, ids, error);
  }
  else
  {
    const vtkTypeInt32* ids = cells->GetConnectivityArray32()->GetPointer(0);
    status = dimension == 3 ? Snap<3>(request, ids, error) : Snap<2>(request, ids, error);
  }
  if (!status.IsOk())
  {
    output->Initialize();
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
