// SPDX-License-Identifier: BSD-3-Clause
#include "stmSurfaceFunction.h"

#include "stmFunctionValues.h"

#include "vtkDataArray.h"
#include "vtkImageData.h"
#include "vtkImplicitFunction.h"
#include "vtkMatrix4x4.h"
#include "vtkPointData.h"

#include <algorithm>
#include <cmath>

void stmSurfaceFunction::SetImplicitFunction(vtkImplicitFunction* function)
{
  this->Implicit = function;
  this->Gray.clear();
}

bool stmSurfaceFunction::SetGrayImage(vtkImageData* image, const int* wholeExtent, double threshold,
  bool insideAboveThreshold, std::string& error)
{
  this->Implicit = nullptr;
  vtkDataArray* scalars = image->GetPointData()->GetScalars();
  if (!scalars)
  {
    error = "the gray image has no point scalars";
    return false;
  }
  int extent[6];
  image->GetExtent(extent);
  const int* whole = wholeExtent ? wholeExtent : extent;
  for (int axis = 0; axis < 3; ++axis)
  {
    this->Dimensions[axis] = whole[2 * axis + 1] - whole[2 * axis] + 1;
    this->ExtentStart[axis] = whole[2 * axis];
    if (extent[2 * axis] > extent[2 * axis + 1])
    {
      error = "the gray image is empty";
      return false;
    }
    if (extent[2 * axis] < whole[2 * axis] || extent[2 * axis + 1] > whole[2 * axis + 1])
    {
      error = "the gray image's extent is not within its whole extent";
      return false;
    }
  }
  if (scalars->GetNumberOfTuples() !=
    static_cast<vtkIdType>(extent[1] - extent[0] + 1) * (extent[3] - extent[2] + 1) *
      (extent[5] - extent[4] + 1))
  {
    error = "the gray image's scalars do not match its extent";
    return false;
  }
  // f is computed in place, so a double array the image owns is copied once, anything else
  // converted once.
  if (scalars->GetNumberOfComponents() == 1)
  {
    const double* values = stmFunctionValues::AsDoubles(scalars, this->Gray);
    if (values != this->Gray.data())
    {
      this->Gray.assign(values, values + scalars->GetNumberOfTuples());
    }
  }
  else
  {
    this->Gray.resize(static_cast<std::size_t>(scalars->GetNumberOfTuples()));
    for (vtkIdType i = 0; i < scalars->GetNumberOfTuples(); ++i)
    {
      this->Gray[i] = scalars->GetComponent(i, 0);
    }
  }
  // A gray value equal to the threshold counts as inside: f is lowered by TieShift. Else the
  // plateaus of such values (whole blocks of an upsampled integer image) make f exactly zero on
  // whole cells, which the snap and the cut cannot place a surface in (the 2x-upsampled AAL
  // atlas with ch2bet at 60: worst condition number 12.9 instead of 3.5).
  const double sign = insideAboveThreshold ? -1.0 : 1.0;
  const double shift = TieShift(threshold);
  for (double& value : this->Gray)
  {
    value = sign * (value - threshold) - shift;
  }
  this->Field.Dimensions = { this->Dimensions[0], this->Dimensions[1], this->Dimensions[2] };
  this->Field.BoxFirst = { extent[0] - whole[0], extent[2] - whole[2], extent[4] - whole[4] };
  this->Field.BoxDimensions = { extent[1] - extent[0] + 1, extent[3] - extent[2] + 1,
    extent[5] - extent[4] + 1 };
  this->Field.Values = this->Gray.data();
  // The physical-to-index matrix gives the index in the whole image, whose samples start at the
  // whole extent's first index.
  vtkMatrix4x4* matrix = image->GetPhysicalToIndexMatrix();
  for (int r = 0; r < 3; ++r)
  {
    for (int c = 0; c < 4; ++c)
    {
      this->PhysicalToIndex[r][c] = matrix->GetElement(r, c);
    }
  }
  return true;
}

void stmSurfaceFunction::VoxelPosition(const double x[3], double position[3]) const
{
  for (int axis = 0; axis < 3; ++axis)
  {
    const double* row = this->PhysicalToIndex[axis];
    const double index =
      row[0] * x[0] + row[1] * x[1] + row[2] * x[2] + row[3] - this->ExtentStart[axis];
    position[axis] = this->Dimensions[axis] == 1 ? 0.5 : index + 0.5;
  }
}

double stmSurfaceFunction::Evaluate(const double x[3]) const
{
  if (this->Implicit)
  {
    std::lock_guard<std::mutex> lock(this->ImplicitLock);
    double point[3] = { x[0], x[1], x[2] };
    return this->Implicit->FunctionValue(point);
  }
  double position[3];
  this->VoxelPosition(x, position);
  return this->Field.Sample(position);
}

double stmSurfaceFunction::EvaluateWithGradient(const double x[3], double gradient[3]) const
{
  if (this->Implicit)
  {
    std::lock_guard<std::mutex> lock(this->ImplicitLock);
    double point[3] = { x[0], x[1], x[2] };
    this->Implicit->FunctionGradient(point, gradient);
    return this->Implicit->FunctionValue(point);
  }
  double position[3], voxelGradient[3];
  this->VoxelPosition(x, position);
  const double value = this->Field.SampleWithGradient(position, voxelGradient);
  // Chain rule through the affine physical -> index map; flat axes do not vary.
  for (int c = 0; c < 3; ++c)
  {
    gradient[c] = 0.0;
    for (int axis = 0; axis < 3; ++axis)
    {
      if (this->Dimensions[axis] != 1)
      {
        gradient[c] += voxelGradient[axis] * this->PhysicalToIndex[axis][c];
      }
    }
  }
  return value;
}
