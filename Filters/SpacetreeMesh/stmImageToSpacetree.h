// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmImageToSpacetree
 * @brief   build the spacetree of a segmented (label) image
 *
 * stmImageToSpacetree is the first stage of the SpacetreeMesh pipeline. It reads an integer label
 * array of a 2D or 3D vtkImageData (point or cell scalars; a point-data image has one voxel per
 * point, centred on it) and builds the spacetree of the paper's section 2.1: a root grid of
 * cells that covers the image (padded with background), refined with a Cartesian refinement
 * pattern (2x2x2, 3x3x3, 2x2x1, one per level, or chosen automatically so that cells are as
 * cubic as possible in physical units) while a cell holds more than one material. A material
 * is a label of the body of interest, or the background for every other label and the
 * padding. Every material interface is therefore resolved at voxel size.
 *
 * Size criteria refine further, and compose (the finest wins): a largest cell size per label
 * (in voxels), a largest size inside a region given by an implicit function (in physical units,
 * possibly below the voxel size), a sizing field (a point or cell array of the image with the
 * label array's association, in physical units), and grading (a leaf at most Grading times
 * larger than the finest leaf within its own size). Membership of a voxel in the region is
 * decided at the voxel centre. ThinPartRefinement refines, to half a voxel, the voxels that a
 * cut at the labels function would lose or pinch off (see Filters/Core/Spacetree/ThinParts.h),
 * so that the cut keeps every connected component.
 *
 * The output is a vtkUnstructuredGrid with one hexahedron (quad in 2D) per leaf and the cell
 * arrays "Level" (0 = root), "Material" (the label, or BackgroundLabel outside the body) and
 * "LatticeIndex" (the leaf's integer position at its level), plus field data that describe the
 * root grid, the image geometry and the body labels, so that stmSpacetreeBalance and
 * stmSpacetreeTessellate (or a file written and read back) rebuild the tree exactly.
 * Spacing, origin and direction matrix of the image are respected.
 *
 * Pieces (pvbatch and pvserver under MPI ask for piece k of n): by default piece 0 builds the
 * whole tree and the others are empty. With SplitIntoPieces, piece k builds the root cells of
 * box k of n of the whole image's root grid (stm::PieceRootBox), from their voxels and those of
 * two layers of root cells around them (the ghost layer, whose leaves get vtkGhostType
 * DUPLICATECELL). The leaves of a piece's own box, and the cells the later stages make of them
 * up to stmMarchingSimplices, are exactly those of the whole image, so adjacent pieces match on
 * their shared boundary (docs/design.md, "Pieces and MPI").
 *
 * Reference: "Image-based unstructured 3D mesh generation for medical applications",
 * section 2.1 (the specification of SpacetreeMesh).
 *
 * @sa stmSpacetreeBalance stmSpacetreeTessellate
 */

#ifndef stmImageToSpacetree_h
#define stmImageToSpacetree_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkUnstructuredGridAlgorithm.h"

#include <map>    // for the per-label sizes
#include <string> // for the pattern
#include <vector> // for the body labels

class vtkImplicitFunction;
class vtkMultiProcessController;

class SPACETREEMESHFILTERS_EXPORT stmImageToSpacetree : public vtkUnstructuredGridAlgorithm
{
public:
  static stmImageToSpacetree* New();
  vtkTypeMacro(stmImageToSpacetree, vtkUnstructuredGridAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /**
   * Whether arrays of this VTK data type (VTK_INT, ...) can hold labels: the integer types.
   */
  static bool IsLabelType(int dataType);

  ///@{
  /**
   * The labels that form the body of interest. Empty (the default) means every label present
   * in the image except BackgroundLabel. Every listed label must occur in the image.
   */
  void SetNumberOfBodyLabels(int count);
  int GetNumberOfBodyLabels() const;
  void SetBodyLabel(int index, int label);
  int GetBodyLabel(int index) const;
  void AddBodyLabel(int label);
  void RemoveAllBodyLabels();
  ///@}

  ///@{
  /**
   * The label given to leaves outside the body of interest (and to the padding of the root
   * grid). Default 0. It may not be one of the body labels.
   */
  vtkSetMacro(BackgroundLabel, int);
  vtkGetMacro(BackgroundLabel, int);
  ///@}

  ///@{
  /**
   * Largest root cell edge, in voxels, on every axis, when RootCellSize is automatic: the root
   * cells are the largest the refinement pattern reaches without exceeding it (and no larger
   * than needed to cover the image). Default 16, range 1 to 2^20.
   */
  vtkSetClampMacro(MaxCellSize, int, 1, 1 << 20);
  vtkGetMacro(MaxCellSize, int);
  ///@}

  ///@{
  /**
   * The refinement pattern: "auto" (the default: at every level, split the axes that leave
   * the cells closest to cubes in physical units; 2x2x2 for cubic voxels, 2x2x1 then 2x2x2 for
   * 0.5 x 0.5 x 1 mm voxels), or split counts per image axis joined by 'x' ("3x3x3"), or a
   * comma-separated list of them, finest level first, the last repeating for all coarser
   * levels ("2x2x1,2x2x2"). Counts are 1 to 8; an entry of only ones is an error. A 2D image
   * takes two counts, or three of which the flat axis is ignored.
   */
  vtkSetStdStringFromCharMacro(RefinementPattern);
  vtkGetCharFromStdStringMacro(RefinementPattern);
  ///@}

  ///@{
  /**
   * Root cell edges in voxels per image axis; (0, 0, 0), the default, chooses them from
   * MaxCellSize and the pattern. Otherwise every spanned axis needs a positive size, no larger
   * than the image, that the pattern reaches exactly. The image need not be divisible by it.
   */
  vtkSetVector3Macro(RootCellSize, int);
  vtkGetVector3Macro(RootCellSize, int);
  ///@}

  ///@{
  /**
   * Largest leaf edge, in voxels (>= 1), for the leaves of a label of the body of interest.
   * Labels without an entry are limited by the root cell size only.
   */
  void SetLabelMaxCellSize(double label, double size);
  void RemoveAllLabelMaxCellSizes();
  int GetNumberOfLabelMaxCellSizes() const;
  ///@}

  ///@{
  /**
   * A region (an implicit function: box, sphere, plane, cylinder, ...) inside which leaves
   * have no edge longer than RegionMaxCellSize, in physical units, below the voxel size if
   * asked. Inside means a value <= 0 at the voxel centre, or, with a positive RegionBandWidth,
   * an absolute value <= RegionBandWidth / 2 (a slab around a plane, a shell around a sphere).
   * Default: no region.
   */
  virtual void SetRefinementRegion(vtkImplicitFunction* region);
  vtkGetObjectMacro(RefinementRegion, vtkImplicitFunction);
  ///@}

  ///@{
  /**
   * Largest leaf edge inside the refinement region, in physical units; 0 (the default)
   * disables the region criterion. Negative values are an error.
   */
  vtkSetMacro(RegionMaxCellSize, double);
  vtkGetMacro(RegionMaxCellSize, double);
  ///@}

  ///@{
  /**
   * Width of the band around the region's zero set that counts as the region; 0 (the
   * default) means the inside (value <= 0).
   */
  vtkSetClampMacro(RegionBandWidth, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(RegionBandWidth, double);
  ///@}

  ///@{
  /**
   * Grading: a leaf may be at most Grading times larger (longest physical edge) than the
   * finest leaf within its own size. 0, the default, disables it; otherwise at least 1.5.
   */
  vtkSetMacro(Grading, double);
  vtkGetMacro(Grading, double);
  ///@}

  enum ThinPartModes
  {
    /// No refinement for thin parts (the staircase mesh keeps every voxel anyway).
    NO_THIN_PARTS = 0,
    /// The thin parts of the body against the background, for the binary cut of the body.
    THIN_BODY_PARTS = 1,
    /// The thin parts of every material, for the multi-material cut.
    THIN_MATERIAL_PARTS = 2
  };

  ///@{
  /**
   * Refine to half a voxel (on every axis) the voxels that a cut at the labels function would
   * lose or pinch off: voxels whose material is the strict majority at none of their corners,
   * and pairs of same-material neighbours whose shared face has no such corner (one-voxel
   * specks, lines and layers). Their centres and face centres become mesh points, so the cut
   * keeps a piece of every connected component. NO_THIN_PARTS (for a staircase mesh, which
   * keeps every voxel anyway), THIN_BODY_PARTS (the default: body against background, for
   * stmMarchingSimplices at the labels function, the default pipeline) or THIN_MATERIAL_PARTS
   * (every material, for stmMultiMaterialCut). Skipped, with a warning, when the refined lattice
   * would be too large. In either mode, the voxels at a convex corner or edge of their material
   * also get leaves of one voxel (NumberOfMinorityCornerVoxels).
   */
  vtkSetClampMacro(ThinPartRefinement, int, NO_THIN_PARTS, THIN_MATERIAL_PARTS);
  vtkGetMacro(ThinPartRefinement, int);
  ///@}

  /**
   * The voxels the last update refined as thin parts.
   */
  vtkGetMacro(NumberOfThinVoxels, vtkIdType);

  /**
   * The voxels the last update gave leaves of one voxel because they lie at a corner where their
   * material holds less than half of the voxels around it (a convex corner or edge), so that no
   * coarser leaf there loses its material near the corner (see stm::MinorityCornerVoxels).
   * Only with ThinPartRefinement other than NO_THIN_PARTS.
   */
  vtkGetMacro(NumberOfMinorityCornerVoxels, vtkIdType);

  ///@{
  /**
   * Use input array 1 (SetInputArrayToProcess(1, ...)) as a sizing field: the largest leaf
   * edge at each voxel, in physical units, positive. It must have the label array's
   * association. Default off.
   */
  vtkSetMacro(UseSizingArray, bool);
  vtkGetMacro(UseSizingArray, bool);
  vtkBooleanMacro(UseSizingArray, bool);
  ///@}

  ///@{
  /**
   * When the pipeline asks for piece k of n > 1, build only that piece's part of the tree (its
   * box of root cells and a ghost layer of two root cells) instead of the whole tree on piece 0.
   * Needs the whole image's extent from upstream; Grading is not supported with it. When every
   * rank of the global controller asks for its own piece, the ranks first sum the cells their
   * root cells' voxels will make, each from a slab of the image (stm::RootCellCostsOfLayers),
   * and the boxes are balanced by those costs; each piece then reads the voxels of its ghost box
   * (grown by one voxel with ThinPartRefinement: the ranks classify the thin parts together).
   * A pipeline that asks one process for several pieces halves the boxes by root cells, or with
   * ThinPartRefinement reads the whole image and balances them by its costs. Default off.
   */
  vtkSetMacro(SplitIntoPieces, bool);
  vtkGetMacro(SplitIntoPieces, bool);
  vtkBooleanMacro(SplitIntoPieces, bool);
  ///@}

  vtkMTimeType GetMTime() override;

protected:
  stmImageToSpacetree();
  ~stmImageToSpacetree() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  /// Under MPI: the whole image on piece 0, nothing on the others (stmPieces.h); with
  /// SplitIntoPieces, the voxels of the piece's root cells and its ghost layer; with
  /// ThinPartRefinement grown by one voxel when every rank meshes its own piece (the ranks
  /// classify the thin parts together), else the whole image (classified before the crop).
  /// When every rank meshes its own piece, first the rank's slab (SumRootCellCostsOverSlabs).
  int RequestUpdateExtent(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

  std::vector<int> BodyLabels;
  int BackgroundLabel = 0;
  int MaxCellSize = 16;
  std::string RefinementPattern = "auto";
  int RootCellSize[3] = { 0, 0, 0 };
  std::map<int, double> LabelMaxCellSizes;
  vtkImplicitFunction* RefinementRegion = nullptr;
  double RegionMaxCellSize = 0;
  double RegionBandWidth = 0;
  double Grading = 0;
  bool UseSizingArray = false;
  int ThinPartRefinement = THIN_BODY_PARTS;
  bool SplitIntoPieces = false;
  vtkIdType NumberOfThinVoxels = 0;
  vtkIdType NumberOfMinorityCornerVoxels = 0;

private:
  /// The first of two passes when every rank meshes its own piece: each rank reads its slab of
  /// root-cell layers, and the ranks sum the costs of the root cells (stm::RootCellCostsOfLayers)
  /// for the second pass, which lays the pieces out by them (CONTINUE_EXECUTING).
  int SumRootCellCostsOverSlabs(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector, vtkMultiProcessController* controller);

  // The whole root grid's costs from the first pass; the second pass forgets them.
  std::vector<long long> SummedRootCellCosts;
  bool HasSummedRootCellCosts = false;

  stmImageToSpacetree(const stmImageToSpacetree&) = delete;
  void operator=(const stmImageToSpacetree&) = delete;
};

#endif
