// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmBoundarySmooth
 * @brief   smooths the boundary and the material interfaces of a tetrahedral (triangle) mesh,
 *          then a few interior layers, rejecting moves that cost element quality
 *
 * stmBoundarySmooth is the paper's boundary smoothing (section 3.4) with the volumetric
 * Laplacian smoothing near the boundary of its section 4. Surface points (on facets shared by
 * cells of different "Material", or on the outer boundary of a cell that is not
 * BackgroundMaterial) move toward the centroid of their surface neighbours: TAUBIN (lambda|mu,
 * the default, which does not shrink) or LAPLACIAN with the damping RelaxationFactor (which
 * does). Points on the outer boundary of BackgroundMaterial cells (the box of background around
 * the body) stay fixed. Where three or more materials meet, a point on a junction line (3D)
 * moves only along the line, and a point where lines meet (a quadruple point) or a 2D triple
 * point stays. After every InteriorRelaxationInterval-th surface iteration and after the last,
 * NumberOfInteriorLayers rings of interior points next to the surface get one volumetric
 * Laplacian pass; small parts (a single voxel) keep the shape the cut gave them
 * (SmallPartPoints). Every move is validated: it
 * must keep every incident cell's orientation and keep the worst condition number and the
 * smallest dihedral angle around the point within MaxConditionNumber / MinDihedralAngle (or no
 * worse than before, where they already were); else it is tried at half and a quarter of its
 * length, else the point stays. The worst element of the mesh therefore never gets worse.
 * Optionally, moves are limited to MaxDisplacement from the original position, and surface
 * points are projected onto the zero level of ImplicitFunction (ProjectToFunction).
 * Optionally (RestoreOriginalVolumes), the interfaces then move along their normals to give
 * every material back its original volume. Last, NumberOfImprovementSweeps sweeps move the
 * points of the cells still beyond the quality bounds to improve them, in the directions that
 * keep every material's volume (along interfaces and junction lines), then, where cells are
 * still beyond them (ImprovementMovesInterfaces), moving interface points off their interface.
 * Cells still beyond the bounds after that have an edge inside one material split where that
 * makes them less bad (SplitInteriorEdges; see Filters/Core/Smooth/InteriorEdgeSplit.h).
 *
 * Input: a vtkUnstructuredGrid of only tetrahedra (3D) or only triangles in a plane (2D), e.g.
 * the output of stmMarchingSimplices, with the cell array "Material" (without it, every cell is
 * one material that is not the background). Output: the same cells and arrays with the points
 * moved (same precision as the input points) and the point array "SmoothingDisplacement" (3
 * components); with split edges, the new points and cells appended (NumberOfSplitEdges). Point
 * arrays such as "SeparatingFunction" are passed unchanged, not re-evaluated. The result does not
 * depend on the number of threads (see Filters/Core/Smooth/BoundarySmooth.h for the method and its
 * decisions).
 *
 * A piece of a larger mesh (stmImageToSpacetree::SplitIntoPieces), whose ghost cells carry
 * vtkGhostType: the points of the ghost cells are held where they are and no edge with a held
 * end is split, so that adjacent pieces keep the points and facets they share. The own points'
 * moves then read only the ghost cells that share a point with the own cells (the interior
 * layers stop at held points), the one ring that the cuts keep by default.
 *
 * When every rank of an MPI run asks for its own piece (piece k of n on rank k of n, as
 * pvbatch's UpdatePiece and `mpiexec stmesh` do) and the cells carry the tessellation's
 * "RootColour", the ranks exchange what the iterations need (stmPieceExchange.h): each point is
 * moved by the piece that owns the root cell of its block, and the others receive its role, its
 * Taubin targets and its positions after every colour, so the iterations move every point as in
 * the whole mesh, bit for bit. So do the small parts (their sizes summed over all pieces), the
 * volume restoration (the ranks sum the volumes per material and the weights of its system
 * exactly over all pieces: stm::ExactSum; the targets from stmMultiMaterialCut's
 * "OriginalMaterialVolumeParts", which the filter removes from its output) and the quality
 * improvement (its candidates move in root blocks), and the interior edge splits (the ranks
 * gather the cells around every piece's bad cells and each runs the whole mesh's splits on
 * them). When the ranks cannot exchange (e.g. cells
 * without root colours), they instead improve the cells beyond the quality bounds at the points
 * their pieces share after the smoothing, together: each updates its ghost cells to the
 * neighbours' smoothed points, and in rank order each improves such cells, moving the shared
 * points too, and sends what it moved (stmPieceBorder.h). Either way the shared points stay
 * equal bit for bit. Every rank must execute the filter, as for VTK's other parallel filters.
 * The filter removes "RootColour" from its output.
 *
 * @sa stmMarchingSimplices stmSeparatingFunction
 */

#ifndef stmBoundarySmooth_h
#define stmBoundarySmooth_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkUnstructuredGridAlgorithm.h"

class vtkImplicitFunction;

class SPACETREEMESHFILTERS_EXPORT stmBoundarySmooth : public vtkUnstructuredGridAlgorithm
{
public:
  static stmBoundarySmooth* New();
  vtkTypeMacro(stmBoundarySmooth, vtkUnstructuredGridAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  enum Methods
  {
    /// lambda|mu smoothing (Taubin 1995): no shrinking.
    TAUBIN = 0,
    /// Laplacian smoothing with damping (the paper's): shrinks convex bodies.
    LAPLACIAN = 1
  };

  ///@{
  /**
   * Surface iterations (a Taubin iteration is a lambda and a mu step), in [0, 1000]. Default 20.
   */
  vtkSetClampMacro(NumberOfIterations, int, 0, 1000);
  vtkGetMacro(NumberOfIterations, int);
  ///@}

  ///@{
  /**
   * TAUBIN (the default) or LAPLACIAN.
   */
  vtkSetClampMacro(Method, int, TAUBIN, LAPLACIAN);
  vtkGetMacro(Method, int);
  ///@}

  ///@{
  /**
   * lambda: the fraction of the way to the neighbours' centroid a point moves per step, in
   * (0, 1]. Default 0.5. Values outside are an error at update time.
   */
  vtkSetMacro(RelaxationFactor, double);
  vtkGetMacro(RelaxationFactor, double);
  ///@}

  ///@{
  /**
   * Taubin's pass band k in (0, 1): 1 / mu = k - 1 / lambda. Default 0.1. Values outside are an
   * error at update time.
   */
  vtkSetMacro(PassBand, double);
  vtkGetMacro(PassBand, double);
  ///@}

  ///@{
  /**
   * Largest distance of a point from its input position, in the mesh's units; 0 (the default)
   * means unlimited.
   */
  vtkSetClampMacro(MaxDisplacement, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(MaxDisplacement, double);
  ///@}

  ///@{
  /**
   * Rings of interior points next to the surface smoothed (volumetric Laplacian) after every
   * InteriorRelaxationInterval-th surface iteration and after the last, in [0, 10]. Default 2.
   */
  vtkSetClampMacro(NumberOfInteriorLayers, int, 0, 10);
  vtkGetMacro(NumberOfInteriorLayers, int);
  ///@}

  ///@{
  /**
   * Surface iterations per relaxation of the interior layers: after every k-th iteration and
   * after the last, in [1, 1000]. Default 4 (1: after every iteration, which costs more moves
   * for the same quality).
   */
  vtkSetClampMacro(InteriorRelaxationInterval, int, 1, 1000);
  vtkGetMacro(InteriorRelaxationInterval, int);
  ///@}

  ///@{
  /**
   * Small parts are kept as the cut made them, so that the smoothing loses no single-voxel
   * component: a part of one material whose interior points (on no interface) number at most
   * this many, all within the interior layers, keeps its points (only the quality improvement
   * may still move its surface points), and so does every interior-layer point with at most one
   * interior neighbour (the centre of a single voxel that touches a larger part along an edge,
   * the tip of a spike). In [0, 1000]; 0 turns both off. Default 8.
   */
  vtkSetClampMacro(SmallPartPoints, int, 0, 1000);
  vtkGetMacro(SmallPartPoints, int);
  ///@}

  ///@{
  /**
   * A move may not make the worst condition number (Verdict's, 1 for the regular simplex) of
   * the cells around the point exceed this, unless they already did (then: no worse), nor the
   * input's worst. >= 1; default 3.5.
   */
  vtkSetMacro(MaxConditionNumber, double);
  vtkGetMacro(MaxConditionNumber, double);
  ///@}

  ///@{
  /**
   * A move may not make the smallest dihedral angle (the smallest angle of triangles) of the
   * cells around the point fall below this, unless it already did (then: no smaller), nor below
   * the input's smallest. Degrees in [0, 180); default 15.
   */
  vtkSetMacro(MinDihedralAngle, double);
  vtkGetMacro(MinDihedralAngle, double);
  ///@}

  ///@{
  /**
   * Sweeps of the quality improvement after the iterations: the surface and interior-layer
   * points of cells beyond MaxConditionNumber or MinDihedralAngle move to improve their worst
   * cell, in the directions that keep every material's volume to first order (an interface
   * point in its tangent plane, a junction-line point along its line, a quadruple point not at
   * all). 2D and 3D meshes; 0 turns it off. In [0, 100]; default 10.
   */
  vtkSetClampMacro(NumberOfImprovementSweeps, int, 0, 100);
  vtkGetMacro(NumberOfImprovementSweeps, int);
  ///@}

  ///@{
  /**
   * Whether, when the improvement sweeps that keep the volumes leave cells beyond the quality
   * bounds, as many sweeps again may move the interface points of those cells (between exactly
   * two materials, the outside counting as one) in every direction, off their interface: a
   * needle over a short edge between interface points cannot widen within the tangent planes.
   * The volumes change by a negligible amount; junction-line points still move only along their
   * lines, quadruple points not at all. Off keeps every interface exactly. Default on.
   */
  vtkSetMacro(ImprovementMovesInterfaces, bool);
  vtkGetMacro(ImprovementMovesInterfaces, bool);
  vtkBooleanMacro(ImprovementMovesInterfaces, bool);
  ///@}

  ///@{
  /**
   * Whether cells still beyond the quality bounds after the smoothing and the improvement have
   * an edge inside one material split (every cell around it of that material, the edge on no
   * interface and not on the outer boundary): a new point, which no interface holds, goes where
   * the new cells are least bad, when they are less bad than the cells they replace. Each cell
   * around the edge becomes two (the first keeps its id and cell data, the second is appended
   * with a copy of them); the new points are appended with point data interpolated at the
   * edge's midpoint and a zero SmoothingDisplacement. Volumes and interfaces do not change.
   * 2D and 3D meshes. Default on.
   */
  vtkSetMacro(SplitInteriorEdges, bool);
  vtkGetMacro(SplitInteriorEdges, bool);
  vtkBooleanMacro(SplitInteriorEdges, bool);
  ///@}

  ///@{
  /**
   * Whether, after the iterations, the interfaces move along their normals so that every
   * material gets back its original volume: the field array "OriginalMaterialVolumes" (pairs
   * of material and volume, which stmMultiMaterialCut writes: each material's volume before
   * the cut and its snapping, after a spacetree its voxels' volume), or without it the volume
   * of the input cells whose "OriginalMaterial" is that material. The points between exactly two
   * materials (the outside counting as one) move, by a per-material offset solved from the
   * volume errors (rounds until every material is within 0.01% of its target, at most ten; each
   * move validated like a smoothing move); junction points stay; the background takes up the
   * difference. Needs the cell array "Material". In a piece (SplitIntoPieces) the volumes are
   * those of its own cells: its ghost cells keep theirs. Default off.
   */
  vtkSetMacro(RestoreOriginalVolumes, bool);
  vtkGetMacro(RestoreOriginalVolumes, bool);
  vtkBooleanMacro(RestoreOriginalVolumes, bool);
  ///@}

  ///@{
  /**
   * The "Material" of the background: its cells' outer-boundary points stay fixed and its
   * outer-boundary facets are no surface. Default 0.
   */
  vtkSetMacro(BackgroundMaterial, int);
  vtkGetMacro(BackgroundMaterial, int);
  ///@}

  ///@{
  /**
   * Whether each tentative surface position is projected onto the zero level of
   * ImplicitFunction (Newton steps along its gradient) before the validation. Default off.
   */
  vtkSetMacro(ProjectToFunction, bool);
  vtkGetMacro(ProjectToFunction, bool);
  vtkBooleanMacro(ProjectToFunction, bool);
  ///@}

  ///@{
  /**
   * The function of ProjectToFunction, negative inside (e.g. the vtkSphere given to
   * stmSeparatingFunction). Required when ProjectToFunction is on. Default none.
   */
  void SetImplicitFunction(vtkImplicitFunction* function);
  vtkGetObjectMacro(ImplicitFunction, vtkImplicitFunction);
  ///@}

  /**
   * Results of the last update: points whose position changed, moves rejected (the point
   * stayed, after the half and quarter moves were rejected too), and points the quality
   * improvement moved (once per sweep).
   */
  vtkGetMacro(NumberOfMovedPoints, vtkIdType);
  vtkGetMacro(NumberOfRejectedMoves, vtkIdType);
  vtkGetMacro(NumberOfImprovedPoints, vtkIdType);

  /**
   * Result of the last update with SplitInteriorEdges: the edges split (each added one point and
   * as many cells as were around it); in a piece, the new points the piece holds.
   */
  vtkGetMacro(NumberOfSplitEdges, vtkIdType);

  /**
   * Result of the last update with SmallPartPoints: the points it kept in place (interior
   * points of small parts and tips, and the surface points of small parts).
   */
  vtkGetMacro(NumberOfKeptPoints, vtkIdType);

  /**
   * Results of the last update with RestoreOriginalVolumes: the largest relative difference of
   * a material's volume from the volume of its original cells, before and after the
   * restoration (0 without it).
   */
  vtkGetMacro(LargestVolumeErrorBefore, double);
  vtkGetMacro(LargestVolumeErrorAfter, double);

  /**
   * Also the implicit function's modification time.
   */
  vtkMTimeType GetMTime() override;

protected:
  stmBoundarySmooth();
  ~stmBoundarySmooth() override;

  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

private:
  stmBoundarySmooth(const stmBoundarySmooth&) = delete;
  void operator=(const stmBoundarySmooth&) = delete;

  int NumberOfIterations = 20;
  int Method = TAUBIN;
  double RelaxationFactor = 0.5;
  double PassBand = 0.1;
  double MaxDisplacement = 0.0;
  int NumberOfInteriorLayers = 2;
  int InteriorRelaxationInterval = 4;
  int SmallPartPoints = 8;
  double MaxConditionNumber = 3.5;
  double MinDihedralAngle = 15.0;
  int NumberOfImprovementSweeps = 10;
  bool ImprovementMovesInterfaces = true;
  bool SplitInteriorEdges = true;
  bool RestoreOriginalVolumes = false;
  int BackgroundMaterial = 0;
  bool ProjectToFunction = false;
  vtkImplicitFunction* ImplicitFunction = nullptr;
  vtkIdType NumberOfMovedPoints = 0;
  vtkIdType NumberOfRejectedMoves = 0;
  vtkIdType NumberOfImprovedPoints = 0;
  vtkIdType NumberOfSplitEdges = 0;
  vtkIdType NumberOfKeptPoints = 0;
  double LargestVolumeErrorBefore = 0.0;
  double LargestVolumeErrorAfter = 0.0;
};

#endif
