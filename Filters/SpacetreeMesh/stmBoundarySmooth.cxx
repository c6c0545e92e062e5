// SPDX-License-Identifier: BSD-3-Clause
#include "stmBoundarySmooth.h"

#include "stmSMPExecutor.h"

#include "Cut/LevelSetProjection.h"
#include "Smooth/BoundarySmooth.h"

#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCellType.h"
#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkIdList.h"
#include "vtkImplicitFunction.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMath.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkSMPTools.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <array>
#include <cmath>
#include <mutex>
#include <string>
#include <vector>

vtkStandardNewMacro(stmBoundarySmooth);
vtkCxxSetObjectMacro(stmBoundarySmooth, ImplicitFunction, vtkImplicitFunction);

namespace
{
/// The dimension of a mesh of only tetrahedra (3) or only triangles (2); 0 otherwise, with the
/// offending cell type.
int SimplexDimension(vtkUnstructuredGrid* input, int& offendingType)
{
  vtkUnsignedCharArray* types = input->GetCellTypesArray();
  const vtkIdType cells = input->GetNumberOfCells();
  const unsigned char first = types->GetValue(0);
  offendingType = first;
  if (first != VTK_TETRA && first != VTK_TRIANGLE)
  {
    return 0;
  }
  for (vtkIdType c = 1; c < cells; ++c)
  {
    if (types->GetValue(c) != first)
    {
      offendingType = types->GetValue(c);
      return 0;
    }
  }
  return first == VTK_TETRA ? 3 : 2;
}

/// The frame of the mesh's coordinates: Dim orthonormal axes from an origin. A triangle mesh
/// in a coordinate plane uses two coordinate axes, so that its points are copied exactly.
struct Frame
{
  double Origin[3] = { 0, 0, 0 };
  double Axes[3][3] = { { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 } };
  int CoordinateAxes[3] = { 0, 1, 2 }; // -1: not a coordinate axis
};

/// The plane of a triangle mesh, or an error message when the triangles are not in a plane.
std::string FindPlane(vtkUnstructuredGrid* input, Frame& frame)
{
  double bounds[6];
  input->GetBounds(bounds);
  const double diagonal = std::sqrt(
    vtkMath::Distance2BetweenPoints(std::array<double, 3>{ bounds[0], bounds[2], bounds[4] }.data(),
      std::array<double, 3>{ bounds[1], bounds[3], bounds[5] }.data()));
  for (int flat = 0; flat < 3; ++flat)
  {
    if (bounds[2 * flat + 1] - bounds[2 * flat] <= 0.0)
    {
      int next = 0;
      for (int axis = 0; axis < 3; ++axis)
      {
        if (axis != flat)
        {
          frame.CoordinateAxes[next++] = axis;
        }
      }
      return "";
    }
  }
  // A tilted plane: the normal of the largest triangle, checked against every point.
  vtkPoints* points = input->GetPoints();
  double best = 0.0, normal[3] = { 0, 0, 0 };
  vtkCellArray* cells = input->GetCells();
  vtkNew<vtkIdList> ids;
  for (vtkIdType c = 0; c < input->GetNumberOfCells(); ++c)
  {
    cells->GetCellAtId(c, ids);
    double a[3], b[3], d[3], u[3], v[3], n[3];
    points->GetPoint(ids->GetId(0), a);
    points->GetPoint(ids->GetId(1), b);
    points->GetPoint(ids->GetId(2), d);
    for (int k = 0; k < 3; ++k)
    {
      u[k] = b[k] - a[k];
      v[k] = d[k] - a[k];
    }
    vtkMath::Cross(u, v, n);
    const double area = vtkMath::Norm(n);
    if (area > best)
    {
      best = area;
      for (int k = 0; k < 3; ++k)
      {
        normal[k] = n[k] / area;
      }
      std::copy(a, a + 3, frame.Origin);
    }
  }
  if (!(best > 0.0))
  {
    return "every triangle is degenerate";
  }
  for (vtkIdType p = 0; p < points->GetNumberOfPoints(); ++p)
  {
    double x[3];
    points->GetPoint(p, x);
    double offset = 0.0;
    for (int k = 0; k < 3; ++k)
    {
      offset += (x[k] - frame.Origin[k]) * normal[k];
    }
    if (std::abs(offset) > 1e-9 * diagonal)
    {
      return "the triangles do not lie in a plane (point " + std::to_string(p) +
        " is off it); only planar triangle meshes and tetrahedral meshes can be smoothed";
    }
  }
  double helper[3] = { 1, 0, 0 };
  if (std::abs(normal[0]) > 0.9)
  {
    helper[0] = 0;
    helper[1] = 1;
  }
  vtkMath::Cross(normal, helper, frame.Axes[0]);
  vtkMath::Normalize(frame.Axes[0]);
  vtkMath::Cross(normal, frame.Axes[0], frame.Axes[1]);
  vtkMath::Normalize(frame.Axes[1]);
  frame.CoordinateAxes[0] = frame.CoordinateAxes[1] = -1;
  return "";
}

struct SmoothRequest
{
  stmBoundarySmooth* Filter;
  vtkUnstructuredGrid* Input;
  vtkUnstructuredGrid* Output;
  stm::BoundarySmoothOptions Options;
  vtkImplicitFunction* Function; // null: no projection
  Frame Coordinates;
  stm::BoundarySmoothStats Stats;
};

template <int Dim>
void ToFrame(const Frame& frame, const double x[3], double* local)
{
  for (int a = 0; a < Dim; ++a)
  {
    if (frame.CoordinateAxes[a] >= 0)
    {
      local[a] = x[frame.CoordinateAxes[a]];
    }
    else
    {
      local[a] = 0.0;
      for (int k = 0; k < 3; ++k)
      {
        local[a] += (x[k] - frame.Origin[k]) * frame.Axes[a][k];
      }
    }
  }
}

/// The 3D position of frame coordinates; `base` gives the coordinates no frame axis sets (the
/// flat axis of a coordinate plane).
template <int Dim>
void FromFrame(const Frame& frame, const double* local, const double base[3], double x[3])
{
  if (Dim == 3 || frame.CoordinateAxes[0] >= 0)
  {
    std::copy(base, base + 3, x);
    for (int a = 0; a < Dim; ++a)
    {
      x[frame.CoordinateAxes[a]] = local[a];
    }
    return;
  }
  for (int k = 0; k < 3; ++k)
  {
    x[k] = frame.Origin[k];
    for (int a = 0; a < Dim; ++a)
    {
      x[k] += local[a] * frame.Axes[a][k];
    }
  }
}

template <int Dim, class IdType>
stm::Status Smooth(SmoothRequest& request, const IdType* connectivity)
{
  vtkUnstructuredGrid* input = request.Input;
  const vtkIdType points = input->GetNumberOfPoints();
  const vtkIdType cells = input->GetNumberOfCells();
  vtkPoints* inputPoints = input->GetPoints();
  const Frame& frame = request.Coordinates;
  std::vector<double> local(static_cast<std::size_t>(points) * Dim);
  vtkSMPTools::For(0, points,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType p = begin; p < end; ++p)
      {
        double x[3];
        inputPoints->GetPoint(p, x);
        ToFrame<Dim>(frame, x, local.data() + p * Dim);
      }
    });
  std::vector<std::int64_t> materials;
  if (vtkDataArray* material = input->GetCellData()->GetArray("Material"))
  {
    materials.resize(static_cast<std::size_t>(cells));
    vtkSMPTools::For(0, cells,
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType c = begin; c < end; ++c)
        {
          materials[c] = static_cast<std::int64_t>(material->GetComponent(c, 0));
        }
      });
  }

  // The projector: Newton steps onto f = 0 of the implicit function, in the frame. VTK's
  // implicit functions may update a transform when evaluated, so evaluations are serialised.
  // The mean edge (the projector's step limit) only with a projector: a serial pass over every
  // cell through vtkPoints costs a noticeable part of the smoothing of a large mesh.
  vtkImplicitFunction* function = request.Function;
  double meanEdge = 0.0;
  for (vtkIdType c = 0; function && c < cells; ++c)
  {
    double a[3], b[3];
    inputPoints->GetPoint(connectivity[c * (Dim + 1)], a);
    inputPoints->GetPoint(connectivity[c * (Dim + 1) + 1], b);
    meanEdge += std::sqrt(vtkMath::Distance2BetweenPoints(a, b)) / cells;
  }
  std::mutex evaluation;
  auto evaluate = [&](const double* position, double* gradient, const double* base)
  {
    double x[3], g[3];
    FromFrame<Dim>(frame, position, base, x);
    std::lock_guard<std::mutex> lock(evaluation);
    const double value = function->FunctionValue(x);
    function->FunctionGradient(x, g);
    for (int a = 0; a < Dim; ++a) // the gradient's components along the frame's axes
    {
      gradient[a] =
        frame.CoordinateAxes[a] >= 0 ? g[frame.CoordinateAxes[a]] : vtkMath::Dot(g, frame.Axes[a]);
    }
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
  stm::BoundarySmoother<Dim> smoother;
  const std::int64_t* materialPointer = materials.empty() ? nullptr : materials.data();
  const stm::Status status = function ? smoother.Smooth(local.data(), points, connectivity, cells,
                                          materialPointer, request.Options, projector, executor)
                                      : smoother.Smooth(local.data(), points, connectivity, cells,
                                          materialPointer, request.Options, executor);
  if (!status.IsOk())
  {
    return status;
  }
  request.Stats = smoother.GetStats();

  // The output: the input's cells and arrays, the moved points in the input's precision.
  vtkUnstructuredGrid* output = request.Output;
  output->ShallowCopy(input);
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
        ToFrame<Dim>(frame, before, check);
        if (std::equal(check, check + Dim, local.data() + p * Dim))
        {
          displacement->SetTuple3(p, 0.0, 0.0, 0.0);
          continue;
        }
        FromFrame<Dim>(frame, local.data() + p * Dim, before, after);
        moved->SetPoint(p, after);
        moved->GetPoint(p, after); // in the stored precision
        displacement->SetTuple3(
          p, after[0] - before[0], after[1] - before[1], after[2] - before[2]);
      }
    });
  output->SetPoints(moved);
  output->GetPointData()->AddArray(displacement);
  return stm::Status::Ok();
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
  os << indent << "MaxConditionNumber: " << this->MaxConditionNumber << "\n";
  os << indent << "MinDihedralAngle: " << this->MinDihedralAngle << "\n";
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
  output->Initialize();
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  if (inInfo && inInfo->Get(vtkAlgorithm::ABORTED()))
  {
    return 1; // an upstream filter was aborted: an empty output, quietly
  }
  auto fail = [&](const std::string& message)
  {
    output->Initialize();
    vtkErrorMacro(<< "BoundarySmooth failed: " << message);
    return 0;
  };
  if (!input || input->GetNumberOfCells() == 0 || !input->GetPoints())
  {
    return fail("the input mesh has no cells");
  }
  int offendingType = 0;
  const int dimension = SimplexDimension(input, offendingType);
  if (dimension == 0)
  {
    return fail("the input must be a mesh of only tetrahedra or only triangles, but it has cells "
                "of VTK type " +
      std::to_string(offendingType) +
      "; cut it with Marching Simplices or tetrahedralize it first");
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

  SmoothRequest request{ this, input, output, {},
    this->ProjectToFunction ? this->ImplicitFunction : nullptr, {}, {} };
  request.Options.Method =
    this->Method == LAPLACIAN ? stm::SmoothingMethod::Laplacian : stm::SmoothingMethod::Taubin;
  request.Options.NumberOfIterations = this->NumberOfIterations;
  request.Options.RelaxationFactor = this->RelaxationFactor;
  request.Options.PassBand = this->PassBand;
  request.Options.MaxDisplacement = this->MaxDisplacement;
  request.Options.NumberOfInteriorLayers = this->NumberOfInteriorLayers;
  request.Options.MaxConditionNumber = this->MaxConditionNumber;
  request.Options.MinDihedralAngle = this->MinDihedralAngle;
  request.Options.BackgroundMaterial = this->BackgroundMaterial;
  if (dimension == 2)
  {
    const std::string problem = FindPlane(input, request.Coordinates);
    if (!problem.empty())
    {
      return fail(problem);
    }
  }
  // Float points receive exactly the validated positions only when the frame copies
  // coordinates (3D, or a coordinate plane).
  request.Options.SinglePrecision =
    input->GetPoints()->GetDataType() == VTK_FLOAT && request.Coordinates.CoordinateAxes[0] >= 0;
  this->UpdateProgress(0.05);

  vtkCellArray* cells = input->GetCells();
  stm::Status status;
  if (cells->IsStorage64Bit())
  {
    const vtkTypeInt64* ids = cells->GetConnectivityArray64()->GetPointer(0);
    status = dimension == 3 ? Smooth<3>(request, ids) : Smooth<2>(request, ids);
  }
  else
  {
    const vtkTypeInt32* ids = cells->GetConnectivityArray32()->GetPointer(0);
    status = dimension == 3 ? Smooth<3>(request, ids) : Smooth<2>(request, ids);
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
  this->NumberOfMovedPoints = static_cast<vtkIdType>(request.Stats.MovedPoints);
  this->NumberOfRejectedMoves = static_cast<vtkIdType>(request.Stats.RejectedMoves);
  this->UpdateProgress(1.0);
  return 1;
}
