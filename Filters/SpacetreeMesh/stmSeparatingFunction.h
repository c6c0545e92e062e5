// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmSeparatingFunction
 * @brief   adds a separating function to the points of a mesh: an implicit function, or the
 *          gray values of an image against a threshold
 *
 * stmMarchingSimplices cuts a mesh where a point scalar crosses an iso-value. The default one,
 * computed from the labels by stmSpacetreeTessellate, follows the voxels; this filter provides
 * the others of the paper's section 3.1 as the point array "SeparatingFunction" (made the
 * active scalars), negative inside:
 * - IMPLICIT_FUNCTION: the value of a vtkImplicitFunction at each point (in ParaView a sphere,
 *   box, plane, cylinder or quadric with its 3D widget), e.g. the paper's analytic ball.
 * - GRAY_IMAGE: the gray values of the image on input port 1 (its active point scalars, first
 *   component), interpolated trilinearly at each point in the image's physical space (origin,
 *   spacing and direction), minus Threshold, negated when InsideAboveThreshold (a bright body:
 *   brain, bone). The image is closed at its boundary: beyond it a point gets the magnitude of
 *   the value at the nearest voxel, so where the inside reaches the boundary its surface lies
 *   on it. NaN gray values stay NaN, which stmMarchingSimplices refuses. Asked for one of
 *   several pieces (under MPI), the filter reads only the voxels around the piece's points,
 *   in two passes (the first finds the piece's bounds), and gives the values of the whole
 *   image.
 * The input passes through otherwise unchanged.
 *
 * @sa stmMarchingSimplices stmSpacetreeTessellate
 */

#ifndef stmSeparatingFunction_h
#define stmSeparatingFunction_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkPointSetAlgorithm.h"

#include <memory> // for std::unique_ptr

class stmGrayImagePieces;
class vtkImplicitFunction;

class SPACETREEMESHFILTERS_EXPORT stmSeparatingFunction : public vtkPointSetAlgorithm
{
public:
  static stmSeparatingFunction* New();
  vtkTypeMacro(stmSeparatingFunction, vtkPointSetAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  enum Modes
  {
    /// The implicit function's value at each point.
    IMPLICIT_FUNCTION = 0,
    /// The gray image on input port 1 against Threshold.
    GRAY_IMAGE = 1
  };

  ///@{
  /**
   * IMPLICIT_FUNCTION (the default) or GRAY_IMAGE.
   */
  vtkSetClampMacro(Mode, int, IMPLICIT_FUNCTION, GRAY_IMAGE);
  vtkGetMacro(Mode, int);
  ///@}

  ///@{
  /**
   * The function of IMPLICIT_FUNCTION mode, evaluated in physical coordinates. Default none
   * (an error in that mode).
   */
  void SetImplicitFunction(vtkImplicitFunction* function);
  vtkGetObjectMacro(ImplicitFunction, vtkImplicitFunction);
  ///@}

  ///@{
  /**
   * The gray value of the surface in GRAY_IMAGE mode. Default 0. A voxel of exactly this value
   * is inside: f is lowered by a millionth of the threshold's magnitude (at least 1e-6), so that
   * a plateau of such voxels (an upsampled or a binary integer image) is no zero set of whole
   * cells.
   */
  vtkSetMacro(Threshold, double);
  vtkGetMacro(Threshold, double);
  ///@}

  ///@{
  /**
   * In GRAY_IMAGE mode, whether the inside (f < 0) is brighter than Threshold. Default on.
   */
  vtkSetMacro(InsideAboveThreshold, bool);
  vtkGetMacro(InsideAboveThreshold, bool);
  vtkBooleanMacro(InsideAboveThreshold, bool);
  ///@}

  /**
   * The gray image of GRAY_IMAGE mode (input port 1).
   */
  void SetGrayImageConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(1, output); }

  vtkMTimeType GetMTime() override;

protected:
  stmSeparatingFunction();
  ~stmSeparatingFunction() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  /// The whole gray image for one piece; for one of several, the voxels around the piece's
  /// points (stmGrayImagePieces).
  int ComputeInputUpdateExtent(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

private:
  stmSeparatingFunction(const stmSeparatingFunction&) = delete;
  void operator=(const stmSeparatingFunction&) = delete;

  int Mode = IMPLICIT_FUNCTION;
  vtkImplicitFunction* ImplicitFunction = nullptr;
  double Threshold = 0.0;
  bool InsideAboveThreshold = true;
  std::unique_ptr<stmGrayImagePieces> GrayPieces;
};

#endif
