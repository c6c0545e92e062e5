// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmVertexSnap
 * @brief   moves mesh vertices onto the separating surface where it passes close to them, so
 *          that marching simplices makes fewer and better elements
 *
 * stmVertexSnap is the paper's vertex snapping (section 3.3), to run between the separating
 * function (stmSpacetreeTessellate, stmSeparatingFunction) and stmMarchingSimplices. The input
 * is a vtkUnstructuredGrid of only tetrahedra, or only triangles in a plane, with a point scalar
 * f (input array 0, found exactly as stmMarchingSimplices finds it: by default
 * "SeparatingFunction", else the active point scalars). An edge from a point with f below
 * IsoValue - ZeroTolerance to one above IsoValue + ZeroTolerance is cut at parameter t; the
 * nearer end is at distance min(t, 1 - t) of the edge length.
 * - THRESHOLD (the paper's rule): a point snaps when an incident edge is cut closer than Alpha
 *   (0 to 0.5, default 1/3, the paper's best) to it. Alpha 0 snaps nothing; 0.5 snaps an end of
 *   every cut edge.
 * - QUALITY_DRIVEN (the default; the paper's proposed improvement; Alpha is ignored): the nearer
 *   end of every cut edge snaps (or is nudged) only if the elements marching simplices would then
 *   make around it have a worst condition number no larger than those the cut would make. Once
 *   every point has decided, the points whose cells still have a piece above condition number
 *   2.5 decide again, given their neighbours' final states (back to the cut, or another snap or
 *   nudge), where that lowers their worst. The cut's worst element never gets worse.
 * A snapped point moves to the edge's intersection (Projection EDGE, the default) or, with
 * Projection FUNCTION, onto the zero set of the ImplicitFunction (if set) or of the gray image on
 * input port 1 (f = gray - Threshold, negated when InsideAboveThreshold, as in
 * stmSeparatingFunction) by Newton steps along the gradient from the edge's intersection; a
 * projection that fails or lands farther than the edge length from the point falls back to the
 * edge's intersection. Its f becomes exactly IsoValue. A snap is refused when a cell around the
 * point would have all its points on the surface, or would be inverted or flattened; points
 * that compete for one cell are decided by the smaller distance, then the smaller point id, so
 * the output does not depend on the number of threads.
 *
 * A point whose snap is refused is nudged instead: its f is pushed away from IsoValue (the point
 * stays) just enough that every cut on its edges lies at least Alpha of the edge from it
 * (QUALITY_DRIVEN: 0.4, and only where that makes better elements), so the surface moves by
 * less than Alpha of an edge, as a snap would move it; GetNumberOfAdjustedPoints counts them.
 * QUALITY_DRIVEN chooses per point the best of cutting, snapping along any of its cut edges of
 * distance at most 1/2, and nudging. THRESHOLD with QualityBound > 0 also refuses (and nudges) a
 * snap that would make elements worse than QualityBound and worse than the cut's.
 *
 * Output: the input mesh with the moved points (in the input's point precision), the function
 * array updated (snapped and nudged points), and the point array "Snapped" (1 where a point
 * moved, 2 where it was nudged, else 0); the cells and all other arrays pass through.
 *
 * @sa stmMarchingSimplices stmSeparatingFunction stmSpacetreeTessellate
 */

#ifndef stmVertexSnap_h
#define stmVertexSnap_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkUnstructuredGridAlgorithm.h"

#include <memory> // for std::unique_ptr

class stmGrayImagePieces;
class vtkImplicitFunction;

class SPACETREEMESHFILTERS_EXPORT stmVertexSnap : public vtkUnstructuredGridAlgorithm
{
public:
  static stmVertexSnap* New();
  vtkTypeMacro(stmVertexSnap, vtkUnstructuredGridAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  enum SnapRules
  {
    /// Snap where the cut is closer than Alpha to a point (the paper's rule).
    THRESHOLD = 0,
    /// Snap where that does not make the cut elements' worst condition number larger.
    QUALITY_DRIVEN = 1
  };

  enum Projections
  {
    /// To the intersection of the cut edge (the linear interpolant's zero).
    EDGE = 0,
    /// Onto the zero set of the implicit function or the gray image.
    FUNCTION = 1
  };

  ///@{
  /**
   * THRESHOLD rule: a point snaps when an incident edge is cut closer to it than Alpha times the
   * edge length. Clamped to [0, 0.5]; default 1/3.
   */
  vtkSetClampMacro(Alpha, double, 0.0, 0.5);
  vtkGetMacro(Alpha, double);
  ///@}

  ///@{
  /**
   * THRESHOLD rule: when > 0, a snap is refused (and the point nudged) where the elements the
   * cut then makes around the point would have a worst condition number above QualityBound and
   * above the cut's without the snap. >= 0; default 0 (off: the paper's rule alone). 3 keeps
   * Alpha 0.34 to 0.5 from making the flat elements those Alphas make otherwise.
   */
  vtkSetClampMacro(QualityBound, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(QualityBound, double);
  ///@}

  ///@{
  /**
   * QUALITY_DRIVEN (the default) or THRESHOLD. Quality driven gives the better mesh on real
   * label images: on the AAL brain mask, after the cut and 20 smoothing iterations, a worst
   * condition number of 3.50 and a smallest dihedral angle of 15.0 degrees with 6.5 million
   * tetrahedra, against 3.75, 10.5 degrees and 7.3 million with THRESHOLD at 1/3.
   */
  vtkSetClampMacro(SnapRule, int, THRESHOLD, QUALITY_DRIVEN);
  vtkGetMacro(SnapRule, int);
  ///@}

  ///@{
  /**
   * The separating surface is f = IsoValue. Default 0.
   */
  vtkSetMacro(IsoValue, double);
  vtkGetMacro(IsoValue, double);
  ///@}

  ///@{
  /**
   * A point with |f - IsoValue| <= ZeroTolerance is on the surface already (as in
   * stmMarchingSimplices). In the units of f, >= 0; default 1e-9.
   */
  vtkSetClampMacro(ZeroTolerance, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(ZeroTolerance, double);
  ///@}

  ///@{
  /**
   * Where a snapped point goes: EDGE (the default) or FUNCTION.
   */
  vtkSetClampMacro(Projection, int, EDGE, FUNCTION);
  vtkGetMacro(Projection, int);
  ///@}

  ///@{
  /**
   * The function of Projection FUNCTION, in physical coordinates, negative inside. When none is
   * set, the gray image on input port 1 is used. Default none.
   */
  void SetImplicitFunction(vtkImplicitFunction* function);
  vtkGetObjectMacro(ImplicitFunction, vtkImplicitFunction);
  ///@}

  /**
   * The gray image of Projection FUNCTION without an implicit function (input port 1,
   * optional).
   */
  void SetGrayImageConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(1, output); }

  ///@{
  /**
   * The gray value of the surface in the gray image. Default 0. A voxel of exactly this value is
   * inside, as in stmSeparatingFunction.
   */
  vtkSetMacro(Threshold, double);
  vtkGetMacro(Threshold, double);
  ///@}

  ///@{
  /**
   * Whether the inside (f < 0) is brighter than Threshold in the gray image. Default on.
   */
  vtkSetMacro(InsideAboveThreshold, bool);
  vtkGetMacro(InsideAboveThreshold, bool);
  vtkBooleanMacro(InsideAboveThreshold, bool);
  ///@}

  /**
   * Points the last update moved, and snaps it refused (a cell would have been all on the
   * surface, inverted or flattened, or, QUALITY_DRIVEN, worse).
   */
  vtkGetMacro(NumberOfSnappedPoints, vtkIdType);
  vtkGetMacro(NumberOfRefusedSnaps, vtkIdType);

  /**
   * Points of the last update whose snap was refused and whose f was nudged instead (see the
   * class description; they are among the refused snaps, and marked 2 in "Snapped").
   */
  vtkGetMacro(NumberOfAdjustedPoints, vtkIdType);

  vtkMTimeType GetMTime() override;

protected:
  stmVertexSnap();
  ~stmVertexSnap() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  /// The whole gray image for one piece; for one of several, the voxels around the piece's
  /// points (stmGrayImagePieces).
  int RequestUpdateExtent(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

private:
  stmVertexSnap(const stmVertexSnap&) = delete;
  void operator=(const stmVertexSnap&) = delete;

  double Alpha = 1.0 / 3.0;
  double QualityBound = 0.0;
  int SnapRule = QUALITY_DRIVEN;
  double IsoValue = 0.0;
  double ZeroTolerance = 1e-9;
  int Projection = EDGE;
  vtkImplicitFunction* ImplicitFunction = nullptr;
  double Threshold = 0.0;
  bool InsideAboveThreshold = true;
  vtkIdType NumberOfSnappedPoints = 0;
  vtkIdType NumberOfRefusedSnaps = 0;
  vtkIdType NumberOfAdjustedPoints = 0;
  std::unique_ptr<stmGrayImagePieces> GrayPieces;
};

#endif
