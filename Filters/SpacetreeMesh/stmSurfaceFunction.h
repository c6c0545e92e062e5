// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmSurfaceFunction
 * @brief   a separating function that can be evaluated anywhere, with its gradient: an implicit
 *          function, or a gray image against a threshold (private to the module)
 *
 * stmSeparatingFunction samples it at the mesh points; stmVertexSnap projects snapped vertices
 * onto its zero set along the gradient. The gray image convention is the one of
 * stmSeparatingFunction: f = gray - threshold, negated when the inside is above the threshold,
 * minus TieShift(threshold) so that a gray value equal to the threshold is inside, and so no
 * plateau of such values is a zero set of whole cells; the gray values (voxel values at the
 * image points) interpolated trilinearly in the image's
 * physical space. The image is closed at its boundary (stm::ClosedVoxelField): beyond it f is
 * the magnitude of the nearest voxel's, so the surface of an inside that reaches the boundary
 * lies on it. The image may be a sub-extent of a larger one (a piece's read): every value then
 * is the whole image's wherever the sub-extent holds the voxels within one voxel (NaN where it
 * does not).
 *
 * Evaluation is thread-safe: the gray image is read only, and the implicit function (not
 * documented as thread-safe in VTK) is evaluated under a lock.
 */

#ifndef stmSurfaceFunction_h
#define stmSurfaceFunction_h

#include "Cut/SeparatingFunction.h"

#include "vtkSmartPointer.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <string>
#include <vector>

class vtkImageData;
class vtkImplicitFunction;

class stmSurfaceFunction
{
public:
  /// Uses an implicit function, evaluated in physical coordinates.
  void SetImplicitFunction(vtkImplicitFunction* function);

  /// Uses the gray image's active point scalars (first component); `wholeExtent` is the extent
  /// of the image it is a part of (null: the image is whole). False with `error` set for an
  /// image without scalars or without voxels.
  bool SetGrayImage(vtkImageData* image, const int* wholeExtent, double threshold,
    bool insideAboveThreshold, std::string& error);

  /// How far f lies below the signed gray value: a millionth of the threshold's magnitude, at
  /// least 1e-6 (far above the cut's default zero tolerance of 1e-9, far below a gray level).
  static double TieShift(double threshold) { return 1e-6 * std::max(1.0, std::abs(threshold)); }

  /// f at a physical point.
  double Evaluate(const double x[3]) const;

  /// f at a physical point and its gradient in physical coordinates.
  double EvaluateWithGradient(const double x[3], double gradient[3]) const;

private:
  /// The continuous voxel position of a physical point (0 at the outer corner of the first
  /// voxel); flat axes, which have one sample, at their only voxel.
  void VoxelPosition(const double x[3], double position[3]) const;

  vtkSmartPointer<vtkImplicitFunction> Implicit;
  mutable std::mutex ImplicitLock;
  std::vector<double> Gray; // signed: f at the voxels
  stm::ClosedVoxelField<3, double> Field;
  int Dimensions[3] = { 0, 0, 0 };  // the whole image's
  int ExtentStart[3] = { 0, 0, 0 }; // the whole image's first index per axis
  double PhysicalToIndex[3][4] = {};
};

#endif
