// SPDX-License-Identifier: BSD-3-Clause
/**
 * stmesh: the command-line front end of SpacetreeMesh.
 *
 * Reads a segmented (label) image, runs stmImageToSpacetree, stmSpacetreeBalance and
 * stmSpacetreeTessellate (tetrahedra, a hybrid mesh or the leaf cells) and, unless --separating
 * none, snaps points next to the separating surface onto it (stmVertexSnap), cuts the
 * tetrahedra at the surface with stmMarchingSimplices and smooths the cut surface
 * (stmBoundarySmooth). The separating function is the labels' (optionally smoothed, computed by
 * stmSpacetreeTessellate) or one of stmSeparatingFunction: a gray image against an iso-value, or
 * a sphere. It writes the result as a .vtu or legacy .vtk file (the surface as .vtp or .vtk),
 * printing a per-stage table of wall time, output size and peak memory. Run `stmesh --help` for
 * the usage.
 *
 * Error policy: every failure (bad command line, unreadable or corrupt input, filter error,
 * write error) ends with messages on stderr that start with "stmesh: error:" and exit code 2 for
 * a usage error, 1 for anything else. VTK reports errors through vtkErrorMacro, which does not
 * throw, so every reader, filter, writer and executive gets an ErrorEvent observer, and the
 * output window (which receives the errors of objects without observers) is replaced; any
 * recorded error fails the run. The output is written to a temporary file that is renamed only
 * on success, so a failure never leaves a partial file under the requested name.
 */

#include "Check/SimplexQuality.h"
#include "stmAbaqusWriter.h"
#include "stmBoundarySmooth.h"
#include "stmExodusWriter.h"
#include "stmFEBioWriter.h"
#include "stmGmshWriter.h"
#include "stmImageToSpacetree.h"
#include "stmInterfaceSurface.h"
#include "stmLabelTable.h"
#include "stmMarchingSimplices.h"
#include "stmMeditWriter.h"
#include "stmMultiMaterialCut.h"
#include "stmSeparatingFunction.h"
#include "stmSpacetreeBalance.h"
#include "stmSpacetreeTessellate.h"
#include "stmVertexSnap.h"
#include "stmXMLPUnstructuredGridWriter.h"
#include "stmXMLPolyDataWriter.h"
#include "stmXMLUnstructuredGridWriter.h"
#include "stmeshErrors.h"
#include "stmeshImageInput.h"
#include "stmeshMemoryPolicy.h"
#include "stmeshParallel.h"
#include "stmeshText.h"

#include "vtkAlgorithm.h"
#include "vtkAlgorithmOutput.h"
#include "vtkArrayDispatch.h"
#include "vtkBox.h"
#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCommand.h"
#include "vtkCylinder.h"
#include "vtkDataArray.h"
#include "vtkDataArrayRange.h"
#include "vtkDataSetAttributes.h"
#include "vtkDoubleArray.h"
#include "vtkExtractCells.h"
#include "vtkFieldData.h"
#include "vtkGenericCell.h"
#include "vtkIdList.h"
#include "vtkImageData.h"
#include "vtkImplicitBoolean.h"
#include "vtkImplicitFunction.h"
#include "vtkInformation.h"
#include "vtkIntArray.h"
#include "vtkLongLongArray.h"
#include "vtkMatrix4x4.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkPlane.h"
#include "vtkPointData.h"
#include "vtkPointSet.h"
#include "vtkPoints.h"
#include "vtkPolyData.h"
#include "vtkPolyDataWriter.h"
#include "vtkProgrammableFilter.h"
#include "vtkSMPThreadLocal.h"
#include "vtkSMPTools.h"
#include "vtkSmartPointer.h"
#include "vtkSphere.h"
#include "vtkTrivialProducer.h"
#include "vtkType.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"
#include "vtkUnstructuredGridWriter.h"
#include "vtkVariant.h"
#include "vtkVersion.h"
#include "vtkXMLWriter.h"

#include <sched.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#ifndef STMESH_VERSION
#define STMESH_VERSION "unknown"
#endif

namespace
{
using stmesh::AvailableMemoryBytes;
using stmesh::CheckReadableFile;
using stmesh::Diagnostics;
using stmesh::EndsWith;
using stmesh::Errors;
using stmesh::Failure;
using stmesh::FileName;
using stmesh::FindImageFormat;
using stmesh::GatherOnFirstRank;
using stmesh::GiB;
using stmesh::ImageFormatInfo;
using stmesh::ImageInfo;
using stmesh::ImageRole;
using stmesh::ImageValues;
using stmesh::LaunchEnvironment;
using stmesh::ParallelRun;
using stmesh::ReadLaunchEnvironment;
using stmesh::SupportedInputExtensions;
using stmesh::ThrowIfFailed;
using stmesh::ToLower;
using stmesh::Trim;
using stmesh::Watch;
using stmesh::WithGlobalIds;
using stmesh::WithoutGhostCells;
// Debian package mricron-data: the AAL atlas, a 181 x 217 x 181 label image with 116 regions.
const char* const DefaultInput = "/usr/share/mricron/templates/aal.nii.gz";

const int DefaultMaxCellSize = 16;
const int MaxMaxCellSize = 1 << 20; // stmImageToSpacetree clamps to this
const int DefaultBalanceLevel = 1;
const int MaxBalanceLevel = 20; // stmSpacetreeBalance clamps to this
const int MaxThreads = 4096;
const int MaxBoundaryLayers = 100;      // stmSpacetreeTessellate clamps to this
const int MaxSplitCount = 8;            // stmImageToSpacetree's largest split count per axis
const double MinimumGrading = 1.5;      // stmImageToSpacetree's smallest grading
const double DefaultAlpha = 1.0 / 3.0;  // the paper's choice (section 3.3, Table 2)
const double MaxAlpha = 0.5;            // stmVertexSnap's range: 0.5 snaps every cut edge
const int DefaultSmoothIterations = 20; // the paper's Fig. 10
const int MaxSmoothIterations = 1000;   // stmBoundarySmooth clamps to this

const char* const UsageText =
  R"(Usage: stmesh [INPUT] [-o OUTPUT] [--labels 1,2,5|all] [--max-cell-size N] [--balance L]
              [--merge S1,S2,...:T]... [--min-component-voxels N]
              [--pattern P] [--root-cell-size X,Y,Z] [--max-cell-size-label L:S,...]
              [--refine-region REGION:SIZE] [--grading G] [--sizing-array NAME]
              [--balance-label L:LEVEL,...] [--balance-region REGION:LEVEL]
              [--elements simplicial|hybrid|leaves] [--templates midpoint|regular|extended]
              [--cell-template checkerboard|kuhn] [--boundary-layer N]
              [--separating labels|smooth:SIGMA|gray:FILE:ISO|sphere:CX,CY,CZ,R|none]
              [--output-mode volume|surface] [--keep both|inside|outside] [--iso V]
              [--materials merged|separate] [--thin-parts refine|ignore]
              [--alpha A] [--snap threshold|quality|none]
              [--smooth-iterations N] [--smooth-method taubin|laplacian]
              [--stop-after spacetree|balance|tessellate|snap|cut|smooth] [--threads N]
              [--summary FILE.json] [--compressor lz4|zlib|none] [--interfaces FILE.vtp]
              [--keep-memory auto|yes|no] [--mpi]
       mpiexec -n P stmesh [OPTIONS] INPUT -o OUTPUT.pvtu
       stmesh -h|--help
       stmesh --version

Mesh a segmented (label) image with SpacetreeMesh: build the spacetree of the labels, balance
it, tessellate it into a conforming tetrahedral mesh, snap the points next to a separating
surface (by default the smooth boundary of the labels' voxels) onto it, cut the mesh at that
surface and smooth the cut surface, with a cell array "Material". With --separating none the
mesh keeps the voxel staircase: tetrahedra, a hybrid mesh or the leaf cells, with the labels as
"Material".

Arguments:
  INPUT                 label image: .nii, .nii.gz (NIfTI), .mha, .mhd (MetaImage), .nrrd, .nhdr
                        (NRRD) or .vti (VTK XML image); integer scalars. Default:
                        /usr/share/mricron/templates/aal.nii.gz (Debian package mricron-data).
  -o OUTPUT             .vtu (VTK XML, inline binary) or .vtk (legacy VTK, binary); with
                        --output-mode surface .vtp (VTK XML polydata, inline binary) or .vtk.
                        Finite-element formats, one group per material (tag = the label; the
                        labels of 0 or less, such as the background, take the tags after the
                        largest label), node and element numbers = VTK ids + 1: .msh (Gmsh
                        4.1, a named physical group per material), .mesh (Medit, references
                        = tags), .inp (Abaqus, an ELSET per material; solids only), .feb
                        (FEBio 4.0, a SolidDomain and a placeholder material per material;
                        solids only), .exo or .e (Exodus II, an element block per material
                        and cell type; solids only). Default: the input's base name with .vtu (.vtp for a
                        surface), in the current directory. .pvtu (VTK XML in pieces, one
                        per MPI rank: OUTPUT.pvtu and OUTPUT/OUTPUT_R.vtu) for a run under MPI
                        (see --mpi), with the point arrays GlobalPointIds and vtkGhostType (a
                        point shared by pieces belongs to the lowest rank) and the cell array
                        ProcessId. A single-file output under MPI is gathered
                        on rank 0, the pieces' shared points merged.
  --msh-format F        ascii (the default, Gmsh's) or binary, for a .msh output.
  --report DIR          also write a visual quality report into DIR (made if needed): the
                        summary (summary.json), histograms of the minimum dihedral angle and of
                        the condition number per material (quality_histograms.png), the mesh
                        cut by the plane through its centre normal to z (cut.png), their
                        figures (quality.json) and index.html showing them. Made by Debian's
                        python3 with python3-matplotlib (python3 -m spacetreemesh.report); a
                        mesh in a finite-element format is also written as DIR/mesh.vtu for it.
                        Needs a volume mesh (not --output-mode surface).
  --background B        keep or drop the cells of Material 0 (the layer of background cells
                        around the body that the cut needs; the cut's outside) in the output.
                        Default: drop for the finite-element formats, keep for the VTK ones.
  --label-names FILE|none
                        names of the labels, one "LABEL NAME" per line (MRIcron's .txt beside
                        an atlas, e.g. /usr/share/mricron/templates/aal.nii.txt; FreeSurfer's
                        colour tables; ITK-SNAP's label files, name in double quotes): they name
                        the material groups of the finite-element outputs and go into every
                        output mesh as the field data MaterialNames and MaterialNameLabels.
                        Default: INPUT.txt (the .gz left out) if it exists, as beside MRIcron's
                        atlases, when the materials are the labels; none: no names.
  --labels L1,L2,...|all
                        labels that form the body of interest. Default (or all): every
                        non-zero label. Several labels, or all, given here are meshed as
                        materials (--materials separate) unless --materials merged, another
                        --separating, --output-mode surface, --keep or --iso is given.
  --materials M         what the cut stage makes of the body's labels: merged (the default
                        without --labels: one body, the binary cut) or separate (the default
                        with several --labels or all: every label its own material,
                        cut at the interfaces between them with conforming triple lines and
                        quadruple points; needs --separating labels; the cut stage snaps by
                        the quality rule before each material unless --snap none; --output-mode
                        surface, --keep and --iso do not apply: --interfaces writes the
                        interfaces).
  --thin-parts T        refine (the default) or ignore the thin parts of the labels: with
                        --separating labels, the voxels the cut would lose or pinch off (one-
                        voxel specks, lines and layers of the body, or of each material with
                        --materials separate) are refined to half a voxel, so that the cut
                        keeps every connected component. The spacetree stage says how many.
  --merge S1,S2,...:T   merge labels before meshing: the voxels of the source labels S1, S2, ...
                        get label T (a new label, one of the sources, or a label the image
                        already holds). Repeat the option for several groups, as in
                        --merge 1,2,3:10 --merge 5,6:11. Every source must occur in the image
                        and belong to one group only; 0 (the background) can be neither a
                        source nor a target. --labels, --max-cell-size-label and
                        --balance-label refer to the merged labels. Its time counts in the
                        read stage.
  --max-cell-size N     largest leaf edge in voxels, 1 to 1048576. Default 16.
  --balance L           largest level difference between adjacent leaves, 1 to 20; 0 skips
                        balancing. Default 1 (best-shaped tetrahedra).
  --pattern P           refinement pattern: auto (the default: cells as cubic as possible in
                        physical units), split counts per image axis joined by x, 1 to 8 each
                        (3x3x3), or a comma-separated list of them, finest level first, the
                        last repeating for coarser levels (2x2x1,2x2x2). A 2D image takes two
                        counts per entry (or three, the flat axis ignored).
  --root-cell-size X,Y,Z
                        root cell edges in voxels (X,Y for a 2D image), at most the image size
                        and reached exactly by the pattern; not with --max-cell-size. Default:
                        the largest cells the pattern reaches within --max-cell-size.
  --max-cell-size-label L:S[,L:S...]
                        largest leaf edge S, in voxels (at least 1), for the leaves of label L.
  --refine-region REGION:SIZE
                        largest leaf edge SIZE (> 0, physical units, e.g. mm; may be below the
                        voxel size) for the voxels whose centre is in REGION, one of (in
                        physical coordinates):
                          box:X0,Y0,Z0,X1,Y1,Z1         X0 < X1, Y0 < Y1, Z0 < Z1
                          sphere:CX,CY,CZ,R             centre and radius R > 0
                          cylinder:CX,CY,CZ,AX,AY,AZ,R  infinite; a point on the axis, the
                                                        axis direction and radius R > 0
                          slab:PX,PY,PZ,NX,NY,NZ,W      the band of width W > 0 around the
                                                        plane through P with normal N
  --grading G           grade the leaf sizes: no leaf more than G times larger than the finest
                        leaf within its own size; G >= 1.5. Default: no grading.
  --sizing-array NAME   an array of the image (with the association of the labels: point or
                        cell data) that gives the largest leaf edge at each voxel, in physical
                        units, positive.
  --balance-label L:LEVEL[,L:LEVEL...]
                        balance level, 1 to 20, of the leaves of label L instead of --balance;
                        two adjacent leaves satisfy the smaller of their levels.
  --balance-region REGION:LEVEL
                        balance level, 1 to 20, of the leaves whose centre is in REGION (the
                        same REGION syntax as --refine-region; a slab of width W is the band
                        around its plane), overriding --balance and --balance-label.
  --elements E          the cells of the output: simplicial (the default: conforming
                        tetrahedra, triangles in 2D), hybrid (conforming hexahedra, pyramids
                        and tetrahedra; quads and triangles in 2D) or leaves (the leaf cells as
                        hexahedra or quads, with hanging nodes marked by the point array
                        "HangingNode"). Cutting needs simplicial elements: hybrid and leaves
                        need --separating none (or --stop-after tessellate or earlier).
  --templates T         how simplicial output triangulates the leaves and their faces: midpoint
                        (the centre of every face joined to its facets), regular (the default:
                        faces without extra vertices on their boundary take the cell template)
                        or extended (in addition, faces that can be cones from one of their
                        corners become that cone, without a new point). Only for simplicial
                        output; ignored, with a warning, with --elements hybrid or leaves.
  --cell-template C     the template of cubes (squares) without extra vertices: checkerboard
                        (the default: 5 tetrahedra per cube, alternating) or kuhn (the 6
                        tetrahedra around the main diagonal). Only for simplicial output, like
                        --templates.
  --boundary-layer N    also output N layers of background leaves around the body (Material 0,
                        the background label), 0 to 100. Default 0. A separating function
                        adds the layers its surface needs (1 for labels, 1 + 3 SIGMA / voxel
                        size for smooth).
  --separating F        the separating function whose zero set the cut stage follows (negative
                        inside), one of:
                          labels         the default: the labels' voxels, interpolated
                                         between the voxel centres
                          smooth:SIGMA   the same, smoothed by a Gaussian of SIGMA > 0 (mm,
                                         0.01 to 1000)
                          gray:FILE:ISO  the gray image FILE (any INPUT format, any scalar
                                         type, in the label image's physical space) where
                                         brighter than ISO (or equal) is inside
                          sphere:CX,CY,CZ,R
                                         the ball of centre CX,CY,CZ and radius R > 0 (mm)
                          none           no cut stage: the staircase mesh of the voxels
                        labels and smooth also give --stop-after tessellate the point array
                        "SeparatingFunction" and its background layers; gray and sphere act in
                        the cut stage only (their tessellation has the labels' function).
  --output-mode M       the cut's output: volume (the default: the tetrahedra on both sides,
                        "Material" the body label (the label of --labels if it gives one, else
                        1) inside and 0 outside, "OriginalMaterial" the tessellation's label)
                        or surface (the separating surface as triangles, lines in 2D, oriented
                        outward).
  --keep K              the tetrahedra the volume output keeps: both (the default), inside or
                        outside.
  --iso V               cut where the separating function equals V instead of 0 (for gray:
                        where the gray value is ISO - V).
                        --output-mode, --keep and --iso apply to the cut stage only; they are
                        ignored, with a warning, with --separating none or an earlier
                        --stop-after.
  --alpha A             the threshold snap rule (given alone, it selects that rule): move a
                        point onto the separating surface, instead of cutting an edge next to
                        it, when the surface crosses the edge within A times its length from
                        the point; 0 to 0.5 (0.5 cuts no edge, 0 snaps nothing). Default 1/3
                        (the paper's choice).
  --snap R              the snap rule: quality (the default: snap the nearer end of a cut edge
                        unless that makes worse elements than the cut), threshold (snap
                        wherever --alpha says) or none (no snap stage).
                        Points move along the cut edge with labels and smooth, along the
                        function's gradient with gray and sphere.
  --smooth-iterations N iterations of the smooth stage, which smooths the cut surface (and the
                        interfaces between materials) and relaxes the cells next to it, 0 to
                        1000; 0 skips it. Default 20.
  --smooth-method M     taubin (the default: smoothing without shrinking) or laplacian.
                        --alpha, --snap, --smooth-iterations and --smooth-method need a
                        separating function; they are ignored, with a warning, with --separating
                        none or a --stop-after before their stage.
  --stop-after STAGE    write the output of spacetree, balance, tessellate, snap, cut or smooth.
                        Default: smooth, or tessellate with --separating none. With smoothing,
                        the cut keeps both sides, and --keep and --output-mode surface act
                        after the smoothing, on the smoothed mesh.
  --threads N           number of threads, 1 to 4096. Default: all cores, or VTK_SMP_MAX_THREADS.
                        The STDThread backend is used unless VTK_SMP_BACKEND_IN_USE is set.
  --keep-memory K       keep the memory a stage frees in the process for the next stages
                        instead of giving it back to the system (glibc: no separate mappings
                        for large blocks, no trimming): fewer page faults, which cost about 10
                        us each on virtual machines (the AAL runs a fifth faster there), for
                        about an eighth more peak memory. auto (the default): yes unless
                        GLIBC_TUNABLES is set or the image's voxels times 400 bytes exceed a
                        quarter of the available memory; yes; no.
  --summary FILE.json   also write the per-stage figures (seconds, peak memory and minor page
                        faults; for tessellate also the inserted points, the cells per type,
                        the boundary layers and, for hybrid and leaves output, the volume
                        fraction of the hexahedra; for snap the snapped points and the refused
                        snaps; for cut the split cells, the cut points and the inside and
                        outside cells; for smooth the moved points, the rejected moves, the
                        quality improvement moves and the split interior edges), the
                        spacetree's cell size per level (in voxels) and the per-material counts
                        as JSON.
  --compressor C        compression of .vtu and .vtp files: lz4 (the default, fastest), zlib
                        (files about 2.3 times smaller, written about 0.8 s slower per 5
                        million tetrahedra on two threads) or none.
  --interfaces FILE     also write the interfaces of the output mesh to FILE (.vtp, VTK XML
                        polydata, or .vtk, legacy): every facet between two materials and every
                        outer-boundary facet of a non-background cell, once each (triangles; lines
                        in 2D), with the cell array BoundaryLabels (the material the facet's
                        normal points out of, the smaller one at an interface; then the other
                        side, -1 outside the mesh) and CellId (the mesh cell). Threshold it on
                        BoundaryLabels for one region's closed surface or one interface. Needs a
                        volume mesh of tetrahedra (triangles): not with --output-mode surface,
                        --stop-after spacetree|balance or --elements hybrid|leaves. Its stage
                        "interfaces" (extraction and writing) follows "write".
  --min-component-voxels N
                        the structure report (the "materials:" line and "materials" in the
                        summary) counts only the connected components (6-connected voxels; 4
                        in 2D) of at least N voxels, N >= 1. Default 1.
                        The report, made after the timed stages for volume output, lists per
                        Material M of the mesh (and per body material of the image missing
                        from it): the voxels that map to M (with a cut the body labels map to
                        the inside Material, all else to 0; without one the body labels to
                        themselves, all else to 0), their volume, the mesh's volume of M, the
                        relative volume error, the image's components of M and the lost ones
                        (no tested voxel centre, all or 1000 of each component, lies in a cell
                        of M). The background (0) is listed only when the mesh has it, and the
                        printed line's counts leave it out.
  --mpi                 start MPI even without a launcher that announces itself (Open MPI's,
                        MPICH's or a PMIx mpiexec are recognised; a .pvtu output starts MPI
                        too). With P > 1 ranks every rank reads only its extent of the image
                        (a .nii.gz is inflated up to it), and of --separating gray's image the
                        voxels around its piece's points, meshes its share of the root cells
                        with ghost root cells beyond it (two, more for root cells under 16
                        voxels) and drops the ghosts; the pieces are the one-rank mesh cell for
                        cell, the smoothing included: the ranks exchange the points they share
                        in every part of it, the edge splits too. Each rank uses the machine's
                        cores divided by the ranks on it, at most the cores the launcher bound
                        it to, unless --threads or VTK_SMP_MAX_THREADS says otherwise. Not with
                        --grading or --output-mode surface; --report and --interfaces need a
                        single-file output. Rank 0 prints the table of its own piece and each
                        rank's time, cells, peak memory and voxels read.
  -h, --help            show this help and exit.
  --version             show the version and exit.

Exit status: 0 on success, 1 on an error, 2 on a usage error.
)";

//------------------------------------------------------------------------------------------------
// Usage errors (Failure: stmeshErrors.h). Each line of what() becomes one "stmesh: error:" line
// on stderr.

class UsageError : public std::runtime_error
{
public:
  explicit UsageError(const std::string& message)
    : std::runtime_error(message)
  {
  }
};

//------------------------------------------------------------------------------------------------
// Small string helpers.

std::string DirectoryName(const std::string& path)
{
  const std::size_t slash = path.find_last_of('/');
  if (slash == std::string::npos)
  {
    return ".";
  }
  return slash == 0 ? "/" : path.substr(0, slash);
}

std::string AbsolutePath(const std::string& path)
{
  if (!path.empty() && path[0] == '/')
  {
    return path;
  }
  std::vector<char> buffer(4096);
  if (!getcwd(buffer.data(), buffer.size()))
  {
    return path;
  }
  return std::string(buffer.data()) + "/" + path;
}

//------------------------------------------------------------------------------------------------
// Input and output formats, chosen by extension (case-insensitive).

enum class MeshFormat
{
  XMLUnstructuredGrid,
  PartitionedXML, // .pvtu: a piece per MPI rank (stmeshParallel.h)
  LegacyVTK,
  XMLPolyData, // the cut's surface only
  Gmsh,        // .msh, 4.1
  Medit,       // .mesh
  Abaqus,      // .inp
  FEBio,       // .feb
  Exodus       // .exo, .e
};

/// The finite-element formats: volume meshes only, written by the module's writers.
bool IsFiniteElementFormat(MeshFormat format)
{
  return format == MeshFormat::Gmsh || format == MeshFormat::Medit ||
    format == MeshFormat::Abaqus || format == MeshFormat::FEBio || format == MeshFormat::Exodus;
}

bool FindMeshFormat(const std::string& path, MeshFormat& format)
{
  const std::string lower = ToLower(FileName(path));
  if (lower.size() > 5 && EndsWith(lower, ".pvtu"))
  {
    format = MeshFormat::PartitionedXML;
    return true;
  }
  if (lower.size() > 4 && EndsWith(lower, ".vtu"))
  {
    format = MeshFormat::XMLUnstructuredGrid;
    return true;
  }
  if (lower.size() > 4 && EndsWith(lower, ".vtp"))
  {
    format = MeshFormat::XMLPolyData;
    return true;
  }
  if (lower.size() > 4 && EndsWith(lower, ".vtk"))
  {
    format = MeshFormat::LegacyVTK;
    return true;
  }
  const std::pair<const char*, MeshFormat> finiteElement[] = { { ".msh", MeshFormat::Gmsh },
    { ".mesh", MeshFormat::Medit }, { ".inp", MeshFormat::Abaqus }, { ".feb", MeshFormat::FEBio },
    { ".exo", MeshFormat::Exodus }, { ".e", MeshFormat::Exodus } };
  for (const auto& entry : finiteElement)
  {
    if (lower.size() > std::strlen(entry.first) && EndsWith(lower, entry.first))
    {
      format = entry.second;
      return true;
    }
  }
  return false;
}

//------------------------------------------------------------------------------------------------
// Command line.

/// The stages in pipeline order (compared with < and >=).
enum class StopStage
{
  Spacetree,
  Balance,
  Tessellate,
  Snap,
  Cut,
  Smooth
};

const char* StopStageName(StopStage stage)
{
  switch (stage)
  {
    case StopStage::Spacetree:
      return "spacetree";
    case StopStage::Balance:
      return "balance";
    case StopStage::Tessellate:
      return "tessellate";
    case StopStage::Snap:
      return "snap";
    case StopStage::Cut:
      return "cut";
    case StopStage::Smooth:
      return "smooth";
  }
  return "?";
}

/// A keyword of --elements, --templates or --cell-template and the stmSpacetreeTessellate
/// constant it stands for.
struct NamedValue
{
  const char* Name;
  int Value;
};

const NamedValue ElementKinds[] = { { "simplicial", stmSpacetreeTessellate::SIMPLICIAL },
  { "hybrid", stmSpacetreeTessellate::HYBRID }, { "leaves", stmSpacetreeTessellate::LEAVES } };
const NamedValue TemplateRules[] = { { "midpoint", stmSpacetreeTessellate::MIDPOINT_EVERYWHERE },
  { "regular", stmSpacetreeTessellate::REGULAR_FACES },
  { "extended", stmSpacetreeTessellate::EXTENDED } };
const NamedValue CellTemplates[] = { { "checkerboard", stmSpacetreeTessellate::CHECKERBOARD },
  { "kuhn", stmSpacetreeTessellate::KUHN } };
const NamedValue OutputModes[] = { { "volume", stmMarchingSimplices::VOLUME },
  { "surface", stmMarchingSimplices::SURFACE } };
const NamedValue KeptSides[] = { { "both", stmMarchingSimplices::BOTH },
  { "inside", stmMarchingSimplices::INSIDE }, { "outside", stmMarchingSimplices::OUTSIDE } };
/// --snap none has no filter constant: it drops the snap stage.
const int NoSnap = -1;
const NamedValue SnapRules[] = { { "threshold", stmVertexSnap::THRESHOLD },
  { "quality", stmVertexSnap::QUALITY_DRIVEN }, { "none", NoSnap } };
const NamedValue SmoothMethods[] = { { "taubin", stmBoundarySmooth::TAUBIN },
  { "laplacian", stmBoundarySmooth::LAPLACIAN } };

/// The value of a keyword option (--elements, --templates, --cell-template), by its name.
template <std::size_t N>
int ParseKeyword(const std::string& text, const std::string& what, const NamedValue (&choices)[N])
{
  std::string names;
  for (const NamedValue& choice : choices)
  {
    if (text == choice.Name)
    {
      return choice.Value;
    }
    names += std::string(names.empty() ? "" : ", ") + choice.Name;
  }
  throw UsageError(what + ": '" + text + "' is not one of " + names);
}

/// The name of a keyword option's value, for the summary.
template <std::size_t N>
const char* KeywordName(int value, const NamedValue (&choices)[N])
{
  for (const NamedValue& choice : choices)
  {
    if (choice.Value == value)
    {
      return choice.Name;
    }
  }
  return "?";
}

/// A region of --refine-region or --balance-region: an implicit function in physical coordinates
/// and the size (or balance level) that applies inside it.
struct RegionOption
{
  std::string Type;           // empty: no region; box, sphere, cylinder or slab
  std::vector<double> Values; // the numbers after the type, as given
  double Size = 0.0;          // --refine-region: the largest leaf edge in physical units
  int Level = 0;              // --balance-region: the balance level
};

/// --separating: the function the cut stage follows.
enum class SeparatingKind
{
  None,   // no cut stage
  Labels, // stmSpacetreeTessellate LABELS
  Smooth, // stmSpacetreeTessellate SMOOTHED_LABELS
  Gray,   // stmSeparatingFunction GRAY_IMAGE
  Sphere  // stmSeparatingFunction IMPLICIT_FUNCTION with a vtkSphere
};

struct SeparatingOption
{
  SeparatingKind Kind = SeparatingKind::Labels;
  std::string Text = "labels"; // as given, for the summary
  double Sigma = 0.0;          // smooth: mm
  std::string GrayImage;       // gray: the image file
  double GrayIso = 0.0;        // gray: the threshold
  std::vector<double> Sphere;  // sphere: CX, CY, CZ, R
};

/// One --merge group: the source labels and the label they become.
struct MergeGroup
{
  std::vector<int> Sources; // in the order given
  int Target = 0;
  std::string Text; // as given, for messages
};

struct Options
{
  bool ShowHelp = false;
  bool ShowVersion = false;
  std::string Input;                // empty: the default image
  std::string Output;               // empty: derived from the input's name
  std::vector<int> Labels;          // empty: every non-zero label
  std::vector<MergeGroup> Merges;   // --merge, in the order given
  long long MinComponentVoxels = 1; // --min-component-voxels
  bool MinComponentVoxelsGiven = false;
  int MaxCellSize = DefaultMaxCellSize;
  int BalanceLevel = DefaultBalanceLevel; // 0: no balancing
  StopStage StopAfter = StopStage::Tessellate;
  int Elements = stmSpacetreeTessellate::SIMPLICIAL;        // --elements: the OutputType
  int TemplateRule = stmSpacetreeTessellate::REGULAR_FACES; // --templates
  int CellTemplate = stmSpacetreeTessellate::CHECKERBOARD;  // --cell-template
  int BoundaryLayers = 0;                                   // --boundary-layer
  std::vector<std::string> SimplicialOnlyOptions;           // --templates, --cell-template if given
  int Threads = 0;                                          // 0: not given on the command line
  std::string SummaryPath;
  std::string Compressor = "lz4"; // of .vtu files: lz4, zlib or none
  std::string Interfaces;         // --interfaces: the interface surface's file, or empty
  bool BinaryMsh = false;         // --msh-format binary
  int Background = -1;            // --background: 1 keep, 0 drop, -1 the format's default
  bool MshFormatGiven = false;
  std::string LabelNames;        // --label-names: the label table's file, or empty
  std::string ReportDirectory;   // --report: the visual report's directory, or empty
  std::string Pattern = "auto";  // normalised: lower case, no blanks
  int PatternCounts = 0;         // split counts per entry (2 or 3); 0 for auto
  std::vector<int> RootCellSize; // empty: automatic; else 2 or 3 sizes in voxels
  std::vector<std::pair<int, double>> LabelMaxCellSizes;
  RegionOption RefineRegion;
  double Grading = 0.0; // 0: off
  std::string SizingArray;
  std::vector<std::pair<int, int>> LabelBalanceLevels;
  RegionOption BalanceRegion;
  SeparatingOption Separating;                    // --separating
  int OutputMode = stmMarchingSimplices::VOLUME;  // --output-mode
  int KeepSide = stmMarchingSimplices::BOTH;      // --keep
  double IsoValue = 0.0;                          // --iso
  std::vector<std::string> CutOnlyOptions;        // --output-mode, --keep, --iso if given
  double Alpha = DefaultAlpha;                    // --alpha
  int SnapRule = stmVertexSnap::QUALITY_DRIVEN;   // --snap; NoSnap for none
  bool SnapRuleGiven = false;                     // --snap given (else --alpha means threshold)
  std::vector<std::string> SnapOnlyOptions;       // --alpha, --snap if given
  int SmoothIterations = DefaultSmoothIterations; // --smooth-iterations
  int SmoothMethod = stmBoundarySmooth::TAUBIN;   // --smooth-method
  std::vector<std::string> SmoothOnlyOptions;     // --smooth-iterations, --smooth-method if given
  bool SeparatingGiven = false;
  bool StopAfterGiven = false;
  bool SeparateMaterials = false; // --materials separate, or several --labels (see below)
  bool MaterialsGiven = false;
  bool LabelsGiven = false;
  bool RefineThinParts = true; // --thin-parts refine
  bool ThinPartsGiven = false;
  bool Mpi = false; // --mpi: start MPI without a launcher that announces itself
  // --keep-memory
  stmesh::KeepMemoryOption KeepMemory = stmesh::KeepMemoryOption::Automatic;

  /// Whether the run reaches the snap stage (it may still skip it: --snap none), the cut stage
  /// and the smooth stage; whether the smooth stage does anything; whether the run writes the
  /// surface (a vtkPolyData).
  bool ReachesSnap() const { return this->StopAfter >= StopStage::Snap; }
  bool Cuts() const { return this->StopAfter >= StopStage::Cut; }
  bool ReachesSmooth() const { return this->StopAfter == StopStage::Smooth; }
  bool Snaps() const
  {
    return this->ReachesSnap() && this->SnapRule != NoSnap && !this->SeparateMaterials;
  }
  bool Smooths() const { return this->ReachesSmooth() && this->SmoothIterations > 0; }
  bool WritesSurface() const
  {
    return this->Cuts() && this->OutputMode == stmMarchingSimplices::SURFACE;
  }
  /// The spacetree's thin-part refinement: for the labels function only, also in a run that
  /// stops before the cut, so that its spacetree and tessellation are the full run's.
  int ThinPartMode() const
  {
    if (!this->RefineThinParts || this->Separating.Kind != SeparatingKind::Labels)
    {
      return stmImageToSpacetree::NO_THIN_PARTS;
    }
    return this->SeparateMaterials ? stmImageToSpacetree::THIN_MATERIAL_PARTS
                                   : stmImageToSpacetree::THIN_BODY_PARTS;
  }
};

/// The first cut option given that applies to one body only (--keep, --iso, --output-mode
/// surface), which the multi-material cut does not make; nullptr if there is none.
const std::string* FirstSingleBodyCutOption(const Options& options)
{
  for (const std::string& name : options.CutOnlyOptions)
  {
    if (name != "--output-mode" || options.OutputMode != stmMarchingSimplices::VOLUME)
    {
      return &name;
    }
  }
  return nullptr;
}

/// Whether the output's Material values are the image's labels (so that a label table names
/// them): not when the cut makes a body of several labels one material.
bool MaterialsAreLabels(const Options& options)
{
  return !(options.Cuts() && !options.SeparateMaterials && options.Labels.size() != 1);
}

// strtoll skips leading blanks and stops at the first non-digit, so "3x", " 3" or "" would slip
// through; demand that the whole text is one decimal integer.
long long ParseInteger(
  const std::string& text, const std::string& what, long long minimum, long long maximum)
{
  if (text.empty())
  {
    throw UsageError(what + " needs an integer value, got an empty string");
  }
  if (std::isspace(static_cast<unsigned char>(text[0])))
  {
    throw UsageError(what + ": '" + text + "' is not an integer");
  }
  errno = 0;
  char* end = nullptr;
  const long long value = std::strtoll(text.c_str(), &end, 10);
  if (end == text.c_str() || *end != '\0')
  {
    throw UsageError(what + ": '" + text + "' is not an integer");
  }
  if (errno == ERANGE || value < minimum || value > maximum)
  {
    throw UsageError(what + ": " + text + " is out of range (" + std::to_string(minimum) + " to " +
      std::to_string(maximum) + ")");
  }
  return value;
}

std::vector<int> ParseLabels(const std::string& text)
{
  std::vector<int> labels;
  if (Trim(text) == "all")
  {
    return labels; // the default, spelled out
  }
  std::set<int> seen;
  std::size_t begin = 0;
  while (true)
  {
    const std::size_t comma = text.find(',', begin);
    const std::string item =
      Trim(text.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin));
    if (item.empty())
    {
      throw UsageError(
        "--labels: empty entry in '" + text + "'; give comma-separated integers such as 1,2,5");
    }
    const int label = static_cast<int>(ParseInteger(item, "--labels", VTK_INT_MIN, VTK_INT_MAX));
    if (label == 0)
    {
      throw UsageError("--labels: 0 is the background label and cannot be part of the body");
    }
    if (!seen.insert(label).second)
    {
      throw UsageError("--labels: label " + item + " is listed twice");
    }
    labels.push_back(label);
    if (comma == std::string::npos)
    {
      break;
    }
    begin = comma + 1;
  }
  return labels;
}

/// The items of a separated list, trimmed; an empty item is an error that shows the example.
std::vector<std::string> SplitList(
  const std::string& text, char separator, const std::string& what, const std::string& example)
{
  std::vector<std::string> items;
  std::size_t begin = 0;
  while (true)
  {
    const std::size_t end = text.find(separator, begin);
    const std::string item =
      Trim(text.substr(begin, end == std::string::npos ? std::string::npos : end - begin));
    if (item.empty())
    {
      throw UsageError(what + ": empty entry in '" + text + "'; give " + example);
    }
    items.push_back(item);
    if (end == std::string::npos)
    {
      break;
    }
    begin = end + 1;
  }
  return items;
}

/// A finite decimal number ("2", "-0.5", "1e-3"); like ParseInteger, the whole text must be the
/// number (no blanks, no "inf", "nan" or hexadecimal).
double ParseReal(const std::string& text, const std::string& what)
{
  if (text.empty())
  {
    throw UsageError(what + " needs a number, got an empty string");
  }
  if (text.find_first_not_of("0123456789+-.eE") != std::string::npos)
  {
    throw UsageError(what + ": '" + text + "' is not a number");
  }
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0')
  {
    throw UsageError(what + ": '" + text + "' is not a number");
  }
  if (!std::isfinite(value))
  {
    throw UsageError(what + ": " + text + " is out of range");
  }
  return value;
}

/// --merge S1,S2,...:T. A label is the source of one group only, and no source of one group is
/// the target of another (chains such as 1:2 and 2:3 would be ambiguous).
MergeGroup ParseMerge(const std::string& text, const std::vector<MergeGroup>& earlier)
{
  const std::string what = "--merge";
  const std::string example = "SOURCES:TARGET such as 1,2,3:10";
  const std::size_t colon = text.find(':');
  if (colon == std::string::npos || text.find(':', colon + 1) != std::string::npos)
  {
    throw UsageError(what + ": '" + text + "' is not " + example);
  }
  MergeGroup group;
  group.Text = text;
  const std::string targetText = Trim(text.substr(colon + 1));
  group.Target =
    static_cast<int>(ParseInteger(targetText, what + " target", VTK_INT_MIN, VTK_INT_MAX));
  if (group.Target == 0)
  {
    throw UsageError(
      what + ": the target of '" + text + "' is 0, the background label; give a non-zero label");
  }
  std::set<int> seen;
  for (const std::string& item : SplitList(text.substr(0, colon), ',', what, example))
  {
    const int source =
      static_cast<int>(ParseInteger(item, what + " source", VTK_INT_MIN, VTK_INT_MAX));
    if (source == 0)
    {
      throw UsageError(what + ": 0 is the background label and cannot be merged ('" + text + "')");
    }
    if (!seen.insert(source).second)
    {
      throw UsageError(what + ": label " + item + " is listed twice in '" + text + "'");
    }
    group.Sources.push_back(source);
  }
  for (const MergeGroup& other : earlier)
  {
    for (const int source : group.Sources)
    {
      if (std::find(other.Sources.begin(), other.Sources.end(), source) != other.Sources.end())
      {
        throw UsageError(what + ": label " + std::to_string(source) + " is a source of both '" +
          other.Text + "' and '" + text + "'; a label can be merged into one target only");
      }
    }
    const auto isSourceOf = [](const MergeGroup& g, int label)
    { return std::find(g.Sources.begin(), g.Sources.end(), label) != g.Sources.end(); };
    if (isSourceOf(other, group.Target) && other.Target != group.Target)
    {
      throw UsageError(what + ": label " + std::to_string(group.Target) + " is the target of '" +
        text + "' and a source of '" + other.Text + "'; give the whole group in one --merge");
    }
    if (isSourceOf(group, other.Target) && other.Target != group.Target)
    {
      throw UsageError(what + ": label " + std::to_string(other.Target) + " is the target of '" +
        other.Text + "' and a source of '" + text + "'; give the whole group in one --merge");
    }
  }
  return group;
}

/// --pattern: "auto", or entries of 2 or 3 split counts (1 to 8) joined by 'x', separated by
/// commas. Returns the text normalised as stmImageToSpacetree reads it (lower case, no blanks)
/// and the number of counts per entry (0 for auto).
std::string ParsePattern(const std::string& text, int& countsPerEntry)
{
  std::string pattern;
  for (const char c : text)
  {
    if (!std::isspace(static_cast<unsigned char>(c)))
    {
      pattern += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
  }
  countsPerEntry = 0;
  if (pattern == "auto")
  {
    return pattern;
  }
  if (pattern.empty())
  {
    throw UsageError("--pattern needs a value such as auto, 3x3x3 or 2x2x1,2x2x2");
  }
  if (pattern.find_first_not_of("0123456789x,") != std::string::npos)
  {
    throw UsageError(
      "--pattern: '" + text + "' is not auto or split counts such as 3x3x3 or 2x2x1,2x2x2");
  }
  for (const std::string& entry :
    SplitList(pattern, ',', "--pattern", "split counts such as 3x3x3 or 2x2x1,2x2x2"))
  {
    const std::vector<std::string> counts =
      SplitList(entry, 'x', "--pattern", "split counts such as 3x3x3 or 2x2x1,2x2x2");
    if (counts.size() != 2 && counts.size() != 3)
    {
      throw UsageError("--pattern: entry '" + entry + "' has " + std::to_string(counts.size()) +
        " split counts; give 3 per entry (2 for a 2D image)");
    }
    if (countsPerEntry != 0 && static_cast<int>(counts.size()) != countsPerEntry)
    {
      throw UsageError("--pattern: the entries of '" + text +
        "' have different numbers of split counts; give 3 per entry (2 for a 2D image)");
    }
    countsPerEntry = static_cast<int>(counts.size());
    bool splits = false;
    for (const std::string& count : counts)
    {
      splits = ParseInteger(count, "--pattern split count", 1, MaxSplitCount) > 1 || splits;
    }
    if (!splits)
    {
      throw UsageError("--pattern: entry '" + entry + "' splits no axis (all counts are 1)");
    }
  }
  return pattern;
}

/// --root-cell-size: 2 or 3 positive sizes in voxels.
std::vector<int> ParseRootCellSize(const std::string& text)
{
  const std::vector<std::string> items =
    SplitList(text, ',', "--root-cell-size", "sizes in voxels such as 8,8,4");
  if (items.size() != 2 && items.size() != 3)
  {
    throw UsageError("--root-cell-size: '" + text + "' has " + std::to_string(items.size()) +
      " sizes; give X,Y,Z in voxels (X,Y for a 2D image)");
  }
  std::vector<int> sizes;
  for (const std::string& item : items)
  {
    sizes.push_back(static_cast<int>(ParseInteger(item, "--root-cell-size", 1, MaxMaxCellSize)));
  }
  return sizes;
}

/// "L:V[,L:V...]": non-zero labels, each listed once, each with a value text.
std::vector<std::pair<int, std::string>> ParseLabelPairs(
  const std::string& text, const std::string& what, const std::string& example)
{
  std::vector<std::pair<int, std::string>> pairs;
  std::set<int> seen;
  for (const std::string& item : SplitList(text, ',', what, example))
  {
    const std::size_t colon = item.find(':');
    if (colon == std::string::npos || item.find(':', colon + 1) != std::string::npos)
    {
      throw UsageError(what + ": '" + item + "' is not LABEL:VALUE; give " + example);
    }
    const std::string labelText = Trim(item.substr(0, colon));
    const int label =
      static_cast<int>(ParseInteger(labelText, what + " label", VTK_INT_MIN, VTK_INT_MAX));
    if (label == 0)
    {
      throw UsageError(what + ": 0 is the background label and cannot be part of the body");
    }
    if (!seen.insert(label).second)
    {
      throw UsageError(what + ": label " + labelText + " is listed twice");
    }
    pairs.emplace_back(label, Trim(item.substr(colon + 1)));
  }
  return pairs;
}

std::vector<std::pair<int, double>> ParseLabelMaxCellSizes(const std::string& text)
{
  const std::string what = "--max-cell-size-label";
  std::vector<std::pair<int, double>> sizes;
  for (const auto& pair : ParseLabelPairs(text, what, "LABEL:SIZE pairs such as 3:2,7:8"))
  {
    const double size = ParseReal(pair.second, what + " size");
    if (!(size > 0))
    {
      throw UsageError(what + ": the size of label " + std::to_string(pair.first) +
        " must be positive, got " + pair.second);
    }
    if (size < 1)
    {
      throw UsageError(what + ": the size of label " + std::to_string(pair.first) + " is " +
        pair.second + " voxels, below one voxel; use --refine-region or --sizing-array for " +
        "cells smaller than a voxel");
    }
    if (size > MaxMaxCellSize)
    {
      throw UsageError(what + ": the size of label " + std::to_string(pair.first) + " (" +
        pair.second + ") is out of range (1 to " + std::to_string(MaxMaxCellSize) + ")");
    }
    sizes.emplace_back(pair.first, size);
  }
  return sizes;
}

std::vector<std::pair<int, int>> ParseLabelBalanceLevels(const std::string& text)
{
  const std::string what = "--balance-label";
  std::vector<std::pair<int, int>> levels;
  for (const auto& pair : ParseLabelPairs(text, what, "LABEL:LEVEL pairs such as 3:2,7:1"))
  {
    levels.emplace_back(
      pair.first, static_cast<int>(ParseInteger(pair.second, what + " level", 1, MaxBalanceLevel)));
  }
  return levels;
}

struct RegionType
{
  const char* Name;
  std::size_t Count;
  const char* Form;
};

const RegionType RegionTypes[] = { { "box", 6, "box:X0,Y0,Z0,X1,Y1,Z1" },
  { "sphere", 4, "sphere:CX,CY,CZ,R" }, { "cylinder", 7, "cylinder:CX,CY,CZ,AX,AY,AZ,R" },
  { "slab", 7, "slab:PX,PY,PZ,NX,NY,NZ,W" } };

/// --refine-region TYPE:NUMBERS:SIZE and --balance-region TYPE:NUMBERS:LEVEL.
RegionOption ParseRegion(const std::string& text, const std::string& what, bool balanceLevel)
{
  const std::string valueName = balanceLevel ? "LEVEL" : "SIZE";
  const std::string example = balanceLevel ? "sphere:0,-20,10,15:2" : "sphere:0,-20,10,15:0.5";
  const std::size_t first = text.find(':');
  const std::size_t second = first == std::string::npos ? first : text.find(':', first + 1);
  if (second == std::string::npos || text.find(':', second + 1) != std::string::npos)
  {
    throw UsageError(what + ": '" + text + "' is not REGION:" + valueName +
      " (TYPE:NUMBERS:" + valueName + ", for example " + example + ")");
  }
  RegionOption region;
  const std::string type = Trim(text.substr(0, first));
  const RegionType* found = nullptr;
  for (const RegionType& candidate : RegionTypes)
  {
    if (type == candidate.Name)
    {
      found = &candidate;
    }
  }
  if (!found)
  {
    throw UsageError(
      what + ": unknown region type '" + type + "'; use box, sphere, cylinder or slab");
  }
  region.Type = type;
  const std::vector<std::string> items = SplitList(text.substr(first + 1, second - first - 1), ',',
    what, "the numbers of " + std::string(found->Form));
  for (const std::string& item : items)
  {
    region.Values.push_back(ParseReal(item, what + " " + type));
  }
  if (region.Values.size() != found->Count)
  {
    throw UsageError(what + ": " + found->Form + " needs " + std::to_string(found->Count) +
      " numbers, got " + std::to_string(region.Values.size()));
  }
  const std::vector<double>& v = region.Values;
  if (type == "box")
  {
    if (!(v[0] < v[3] && v[1] < v[4] && v[2] < v[5]))
    {
      throw UsageError(what + ": degenerate box in '" + text +
        "'; box:X0,Y0,Z0,X1,Y1,Z1 needs X0 < X1, Y0 < Y1 and Z0 < Z1");
    }
  }
  else if (type == "sphere" || type == "cylinder")
  {
    if (type == "cylinder" && v[3] == 0 && v[4] == 0 && v[5] == 0)
    {
      throw UsageError(what + ": the cylinder axis AX,AY,AZ is zero");
    }
    if (!(v.back() > 0))
    {
      throw UsageError(what + ": the " + type + " radius must be positive, got " + items.back());
    }
  }
  else // slab
  {
    if (v[3] == 0 && v[4] == 0 && v[5] == 0)
    {
      throw UsageError(what + ": the slab normal NX,NY,NZ is zero");
    }
    if (!(v[6] > 0))
    {
      throw UsageError(what + ": the slab width must be positive, got " + items.back());
    }
  }
  const std::string value = Trim(text.substr(second + 1));
  if (balanceLevel)
  {
    region.Level = static_cast<int>(ParseInteger(value, what + " level", 1, MaxBalanceLevel));
  }
  else
  {
    region.Size = ParseReal(value, what + " size");
    if (!(region.Size > 0))
    {
      throw UsageError(what + ": SIZE must be positive, got " + value);
    }
  }
  return region;
}

/// --separating labels|smooth:SIGMA|gray:FILE:ISO|sphere:CX,CY,CZ,R|none.
SeparatingOption ParseSeparating(const std::string& text)
{
  const std::string what = "--separating";
  const std::string choices = "labels, smooth:SIGMA, gray:FILE:ISO, sphere:CX,CY,CZ,R or none";
  SeparatingOption separating;
  separating.Text = text;
  const std::size_t colon = text.find(':');
  const std::string type = text.substr(0, colon);
  const std::string rest = colon == std::string::npos ? std::string() : text.substr(colon + 1);
  if ((type == "labels" || type == "none") && colon == std::string::npos)
  {
    separating.Kind = type == "labels" ? SeparatingKind::Labels : SeparatingKind::None;
    return separating;
  }
  if (type == "smooth")
  {
    if (colon == std::string::npos)
    {
      throw UsageError(what + ": smooth needs the Gaussian's sigma in mm, as in smooth:1.5");
    }
    separating.Kind = SeparatingKind::Smooth;
    separating.Sigma = ParseReal(Trim(rest), what + ": smooth SIGMA");
    if (!(separating.Sigma > 0))
    {
      throw UsageError(what + ": smooth SIGMA must be positive, got " + Trim(rest));
    }
    if (separating.Sigma < 0.01 || separating.Sigma > 1000)
    {
      throw UsageError(
        what + ": smooth SIGMA " + Trim(rest) + " is out of range (0.01 to 1000 mm)");
    }
    return separating;
  }
  if (type == "gray")
  {
    // The file name may hold colons; the iso-value follows the last one.
    const std::size_t last = text.rfind(':');
    if (colon == std::string::npos || last == colon)
    {
      throw UsageError(
        what + ": '" + text + "' is not gray:FILE:ISO (for example gray:t1.nii.gz:300)");
    }
    separating.Kind = SeparatingKind::Gray;
    separating.GrayImage = text.substr(colon + 1, last - colon - 1);
    if (separating.GrayImage.empty())
    {
      throw UsageError(what + ": gray:FILE:ISO needs a file name, got '" + text + "'");
    }
    separating.GrayIso = ParseReal(Trim(text.substr(last + 1)), what + ": gray ISO");
    return separating;
  }
  if (type == "sphere")
  {
    if (colon == std::string::npos)
    {
      throw UsageError(what + ": sphere needs its centre and radius, as in sphere:0,-20,10,15");
    }
    separating.Kind = SeparatingKind::Sphere;
    const std::vector<std::string> items =
      SplitList(rest, ',', what + ": sphere", "the numbers of sphere:CX,CY,CZ,R");
    for (const std::string& item : items)
    {
      separating.Sphere.push_back(ParseReal(item, what + ": sphere"));
    }
    if (separating.Sphere.size() != 4)
    {
      throw UsageError(what + ": sphere:CX,CY,CZ,R needs 4 numbers, got " +
        std::to_string(separating.Sphere.size()));
    }
    if (!(separating.Sphere[3] > 0))
    {
      throw UsageError(what + ": the sphere radius must be positive, got " + items.back());
    }
    return separating;
  }
  throw UsageError(what + ": '" + text + "' is not one of " + choices);
}

Options ParseCommandLine(int argc, char* argv[])
{
  Options options;
  bool inputGiven = false;
  bool optionsEnded = false;
  std::set<std::string> seenOptions;
  for (int i = 1; i < argc; ++i)
  {
    const std::string argument = argv[i];
    if (!optionsEnded && argument == "--")
    {
      optionsEnded = true;
      continue;
    }
    if (optionsEnded || argument.size() < 2 || argument[0] != '-')
    {
      if (inputGiven)
      {
        throw UsageError("more than one INPUT given ('" + options.Input + "' and '" + argument +
          "'); stmesh meshes one image per run");
      }
      if (argument.empty())
      {
        throw UsageError("INPUT is an empty string");
      }
      options.Input = argument;
      inputGiven = true;
      continue;
    }
    if (argument == "-h" || argument == "--help")
    {
      options.ShowHelp = true;
      continue;
    }
    if (argument == "--version")
    {
      options.ShowVersion = true;
      continue;
    }
    if (argument == "--mpi")
    {
      options.Mpi = true;
      continue;
    }

    // Options with a value: "--name value" or "--name=value" ("-o value" only).
    std::string name = argument;
    std::string value;
    bool inlineValue = false;
    const std::size_t equals = argument.find('=');
    if (argument.compare(0, 2, "--") == 0 && equals != std::string::npos)
    {
      name = argument.substr(0, equals);
      value = argument.substr(equals + 1);
      inlineValue = true;
    }
    static const std::set<std::string> valueOptions = { "-o", "--labels", "--max-cell-size",
      "--balance", "--stop-after", "--threads", "--summary", "--compressor", "--pattern",
      "--root-cell-size", "--max-cell-size-label", "--refine-region", "--grading", "--sizing-array",
      "--balance-label", "--balance-region", "--elements", "--templates", "--cell-template",
      "--boundary-layer", "--separating", "--output-mode", "--keep", "--iso", "--alpha", "--snap",
      "--smooth-iterations", "--smooth-method", "--merge", "--min-component-voxels", "--interfaces",
      "--materials", "--thin-parts", "--msh-format", "--label-names", "--background", "--report",
      "--keep-memory" };
    if (valueOptions.count(name) == 0)
    {
      throw UsageError("unknown option '" + name + "'");
    }
    if (!inlineValue)
    {
      if (i + 1 >= argc)
      {
        throw UsageError(name + " needs a value");
      }
      value = argv[++i];
    }
    if (!seenOptions.insert(name).second && name != "--merge") // --merge: one per group
    {
      throw UsageError(name + " given more than once");
    }

    if (name == "-o")
    {
      if (value.empty())
      {
        throw UsageError("-o needs a file name");
      }
      options.Output = value;
    }
    else if (name == "--labels")
    {
      options.Labels = ParseLabels(value);
      options.LabelsGiven = true;
    }
    else if (name == "--merge")
    {
      options.Merges.push_back(ParseMerge(value, options.Merges));
    }
    else if (name == "--min-component-voxels")
    {
      options.MinComponentVoxels =
        ParseInteger(value, name, 1, std::numeric_limits<long long>::max());
      options.MinComponentVoxelsGiven = true;
    }
    else if (name == "--max-cell-size")
    {
      options.MaxCellSize = static_cast<int>(ParseInteger(value, name, 1, MaxMaxCellSize));
    }
    else if (name == "--balance")
    {
      options.BalanceLevel = static_cast<int>(ParseInteger(value, name, 0, MaxBalanceLevel));
    }
    else if (name == "--stop-after")
    {
      options.StopAfterGiven = true;
      if (value == "spacetree")
      {
        options.StopAfter = StopStage::Spacetree;
      }
      else if (value == "balance")
      {
        options.StopAfter = StopStage::Balance;
      }
      else if (value == "tessellate")
      {
        options.StopAfter = StopStage::Tessellate;
      }
      else if (value == "snap")
      {
        options.StopAfter = StopStage::Snap;
      }
      else if (value == "cut")
      {
        options.StopAfter = StopStage::Cut;
      }
      else if (value == "smooth")
      {
        options.StopAfter = StopStage::Smooth;
      }
      else
      {
        throw UsageError("--stop-after: '" + value +
          "' is not one of spacetree, balance, tessellate, snap, cut, smooth");
      }
    }
    else if (name == "--separating")
    {
      options.Separating = ParseSeparating(value);
      options.SeparatingGiven = true;
    }
    else if (name == "--output-mode")
    {
      options.OutputMode = ParseKeyword(value, name, OutputModes);
      options.CutOnlyOptions.push_back(name);
    }
    else if (name == "--keep")
    {
      options.KeepSide = ParseKeyword(value, name, KeptSides);
      options.CutOnlyOptions.push_back(name);
    }
    else if (name == "--iso")
    {
      options.IsoValue = ParseReal(value, name);
      options.CutOnlyOptions.push_back(name);
    }
    else if (name == "--alpha")
    {
      options.Alpha = ParseReal(value, name);
      if (!(options.Alpha >= 0 && options.Alpha <= MaxAlpha))
      {
        throw UsageError("--alpha: A must be between 0 and 0.5, got " + value);
      }
      options.SnapOnlyOptions.push_back(name);
    }
    else if (name == "--thin-parts")
    {
      if (value != "refine" && value != "ignore")
      {
        throw UsageError("--thin-parts: '" + value + "' is not one of refine, ignore");
      }
      options.RefineThinParts = value == "refine";
      options.ThinPartsGiven = true;
    }
    else if (name == "--materials")
    {
      if (value != "merged" && value != "separate")
      {
        throw UsageError("--materials: '" + value + "' is not one of merged, separate");
      }
      options.SeparateMaterials = value == "separate";
      options.MaterialsGiven = true;
    }
    else if (name == "--snap")
    {
      options.SnapRule = ParseKeyword(value, name, SnapRules);
      options.SnapRuleGiven = true;
      options.SnapOnlyOptions.push_back(name);
    }
    else if (name == "--smooth-iterations")
    {
      options.SmoothIterations =
        static_cast<int>(ParseInteger(value, name, 0, MaxSmoothIterations));
      options.SmoothOnlyOptions.push_back(name);
    }
    else if (name == "--smooth-method")
    {
      options.SmoothMethod = ParseKeyword(value, name, SmoothMethods);
      options.SmoothOnlyOptions.push_back(name);
    }
    else if (name == "--elements")
    {
      options.Elements = ParseKeyword(value, name, ElementKinds);
    }
    else if (name == "--templates")
    {
      options.TemplateRule = ParseKeyword(value, name, TemplateRules);
      options.SimplicialOnlyOptions.push_back(name);
    }
    else if (name == "--cell-template")
    {
      options.CellTemplate = ParseKeyword(value, name, CellTemplates);
      options.SimplicialOnlyOptions.push_back(name);
    }
    else if (name == "--boundary-layer")
    {
      options.BoundaryLayers = static_cast<int>(ParseInteger(value, name, 0, MaxBoundaryLayers));
    }
    else if (name == "--compressor")
    {
      if (value != "lz4" && value != "zlib" && value != "none")
      {
        throw UsageError("--compressor: '" + value + "' is not one of lz4, zlib, none");
      }
      options.Compressor = value;
    }
    else if (name == "--keep-memory")
    {
      if (!stmesh::ParseKeepMemoryOption(value, options.KeepMemory))
      {
        throw UsageError("--keep-memory: '" + value + "' is not one of auto, yes, no");
      }
    }
    else if (name == "--msh-format")
    {
      if (value != "ascii" && value != "binary")
      {
        throw UsageError("--msh-format: '" + value + "' is not one of ascii, binary");
      }
      options.BinaryMsh = value == "binary";
      options.MshFormatGiven = true;
    }
    else if (name == "--background")
    {
      if (value != "keep" && value != "drop")
      {
        throw UsageError("--background: '" + value + "' is not one of keep, drop");
      }
      options.Background = value == "keep" ? 1 : 0;
    }
    else if (name == "--report")
    {
      if (value.empty())
      {
        throw UsageError("--report needs a directory");
      }
      options.ReportDirectory = value;
    }
    else if (name == "--label-names")
    {
      if (value.empty())
      {
        throw UsageError("--label-names needs a file name");
      }
      options.LabelNames = value;
    }
    else if (name == "--threads")
    {
      options.Threads = static_cast<int>(ParseInteger(value, name, 1, MaxThreads));
    }
    else if (name == "--interfaces")
    {
      if (value.empty())
      {
        throw UsageError("--interfaces needs a file name");
      }
      options.Interfaces = value;
    }
    else if (name == "--summary")
    {
      if (value.empty())
      {
        throw UsageError("--summary needs a file name");
      }
      options.SummaryPath = value;
    }
    else if (name == "--pattern")
    {
      options.Pattern = ParsePattern(value, options.PatternCounts);
    }
    else if (name == "--root-cell-size")
    {
      options.RootCellSize = ParseRootCellSize(value);
    }
    else if (name == "--max-cell-size-label")
    {
      options.LabelMaxCellSizes = ParseLabelMaxCellSizes(value);
    }
    else if (name == "--refine-region")
    {
      options.RefineRegion = ParseRegion(value, name, false);
    }
    else if (name == "--grading")
    {
      options.Grading = ParseReal(value, name);
      if (!(options.Grading >= MinimumGrading))
      {
        throw UsageError("--grading: G must be at least 1.5, got " + value);
      }
    }
    else if (name == "--sizing-array")
    {
      if (value.empty())
      {
        throw UsageError("--sizing-array needs an array name");
      }
      options.SizingArray = value;
    }
    else if (name == "--balance-label")
    {
      options.LabelBalanceLevels = ParseLabelBalanceLevels(value);
    }
    else if (name == "--balance-region")
    {
      options.BalanceRegion = ParseRegion(value, name, true);
    }
  }

  if (!options.RootCellSize.empty() && seenOptions.count("--max-cell-size"))
  {
    throw UsageError("--root-cell-size and --max-cell-size exclude each other: the root cell "
                     "size replaces the largest cell size");
  }
  if (options.BalanceLevel == 0 &&
    (!options.LabelBalanceLevels.empty() || !options.BalanceRegion.Type.empty()))
  {
    throw UsageError(
      std::string(options.LabelBalanceLevels.empty() ? "--balance-region" : "--balance-label") +
      " needs balancing and cannot be combined with --balance 0");
  }

  // --alpha is the threshold rule's parameter: given without --snap, it asks for that rule.
  if (!options.SnapRuleGiven &&
    std::find(options.SnapOnlyOptions.begin(), options.SnapOnlyOptions.end(), "--alpha") !=
      options.SnapOnlyOptions.end())
  {
    options.SnapRule = stmVertexSnap::THRESHOLD;
  }

  // The smooth stage: the last one by default when there is a separating function.
  const bool separates = options.Separating.Kind != SeparatingKind::None;
  if (!options.StopAfterGiven)
  {
    options.StopAfter = separates ? StopStage::Smooth : StopStage::Tessellate;
  }
  else if (options.StopAfter >= StopStage::Snap && !separates)
  {
    throw UsageError(std::string("--stop-after ") + StopStageName(options.StopAfter) +
      " needs a separating function, but --separating is none; give --stop-after tessellate "
      "or another --separating");
  }
  if (options.Cuts() && options.Elements != stmSpacetreeTessellate::SIMPLICIAL)
  {
    throw UsageError(std::string("--elements ") + KeywordName(options.Elements, ElementKinds) +
      ": cutting at the separating function (--separating " + options.Separating.Text +
      ") needs simplicial elements; give --separating none for a " +
      KeywordName(options.Elements, ElementKinds) + " mesh of the voxels");
  }

  // Naming several labels, or all, asks for them as materials, as an atlas meshed for a solver
  // needs: the cut keeps each label its own material unless --materials says otherwise or the
  // run is one that the multi-material cut does not make (another separating function, a
  // surface, --keep or --iso). The default body, no --labels, stays one body (the brain mask).
  if (!options.MaterialsGiven && options.LabelsGiven && options.Labels.size() != 1 &&
    options.Cuts() && options.Separating.Kind == SeparatingKind::Labels &&
    !FirstSingleBodyCutOption(options))
  {
    options.SeparateMaterials = true;
  }

  if (options.SeparateMaterials && options.Cuts())
  {
    if (options.Separating.Kind != SeparatingKind::Labels)
    {
      throw UsageError("--materials separate cuts at the interfaces of the labels, but "
                       "--separating is " +
        options.Separating.Text + "; give --separating labels (the default)");
    }
    if (const std::string* name = FirstSingleBodyCutOption(options))
    {
      throw UsageError(*name +
        " applies to one body, not to --materials separate; write the "
        "interfaces between the materials with --interfaces");
    }
  }

  MeshFormat format = MeshFormat::XMLUnstructuredGrid;
  const char* const extensions = options.WritesSurface()
    ? "use .vtp (VTK XML polydata) or .vtk (legacy VTK) for --output-mode surface"
    : "use .vtu (VTK XML), .pvtu (VTK XML, a piece per MPI rank), .vtk (legacy VTK), .msh "
      "(Gmsh 4.1), .mesh (Medit), .inp (Abaqus), .feb (FEBio 4.0) or .exo (Exodus II)";
  if (!options.Output.empty() && !FindMeshFormat(options.Output, format))
  {
    throw UsageError("output '" + options.Output + "' has an unsupported extension; " + extensions);
  }
  if (!options.Output.empty() && options.WritesSurface() && IsFiniteElementFormat(format))
  {
    throw UsageError("output '" + options.Output +
      "': the finite-element formats hold volume meshes, but --output-mode surface writes a "
      "surface; " +
      extensions);
  }
  if (!options.LabelNames.empty() && options.LabelNames != "none" && !MaterialsAreLabels(options))
  {
    throw UsageError("--label-names names the image's labels, but the cut makes the body of "
                     "several labels one material (Material 1); give --materials separate "
                     "(every label its own material) or one label with --labels");
  }
  if (format == MeshFormat::PartitionedXML &&
    (!options.ReportDirectory.empty() || !options.Interfaces.empty()))
  {
    throw UsageError(std::string(options.ReportDirectory.empty() ? "--interfaces" : "--report") +
      " needs the whole mesh, but a .pvtu output is written in pieces; give a single-file output "
      "such as -o mesh.vtu (under MPI, rank 0 gathers the pieces into it)");
  }
  if (!options.ReportDirectory.empty() && options.WritesSurface())
  {
    throw UsageError("--report needs a volume mesh, but --output-mode surface writes the cut's "
                     "surface only");
  }
  if (options.MshFormatGiven && (options.Output.empty() || format != MeshFormat::Gmsh))
  {
    throw UsageError("--msh-format applies to a .msh output (-o FILE.msh)");
  }
  if (!options.Output.empty() && options.WritesSurface() &&
    (format == MeshFormat::XMLUnstructuredGrid || format == MeshFormat::PartitionedXML))
  {
    throw UsageError("output '" + options.Output +
      "': --output-mode surface writes a surface (polydata), not an unstructured grid; " +
      extensions);
  }
  if (!options.Output.empty() && !options.WritesSurface() && format == MeshFormat::XMLPolyData)
  {
    std::string reason = "the output is an unstructured grid";
    if (options.OutputMode == stmMarchingSimplices::SURFACE)
    {
      reason += std::string(" (--output-mode surface is ignored with ") +
        (separates ? "--stop-after " + std::string(StopStageName(options.StopAfter))
                   : std::string("--separating none")) +
        ")";
    }
    throw UsageError(
      "output '" + options.Output + "': .vtp holds polydata, but " + reason + "; " + extensions);
  }
  if (!options.Interfaces.empty())
  {
    MeshFormat interfaceFormat;
    if (!FindMeshFormat(options.Interfaces, interfaceFormat) ||
      (interfaceFormat != MeshFormat::XMLPolyData && interfaceFormat != MeshFormat::LegacyVTK))
    {
      throw UsageError("--interfaces '" + options.Interfaces +
        "': the interfaces are polydata; use .vtp (VTK XML polydata) or .vtk (legacy VTK)");
    }
    if (options.WritesSurface())
    {
      throw UsageError("--interfaces needs a volume mesh, but --output-mode surface writes the "
                       "cut's surface only; give --output-mode volume (the default)");
    }
    if (options.StopAfter < StopStage::Tessellate)
    {
      throw UsageError(std::string("--interfaces needs tetrahedra (triangles), but --stop-after ") +
        StopStageName(options.StopAfter) +
        " writes the spacetree's leaves; give --stop-after "
        "tessellate or a later stage");
    }
    if (options.Elements != stmSpacetreeTessellate::SIMPLICIAL)
    {
      throw UsageError(std::string("--interfaces needs tetrahedra (triangles), but --elements ") +
        KeywordName(options.Elements, ElementKinds) +
        " writes other cells; give --elements "
        "simplicial (the default)");
    }
  }
  return options;
}

//------------------------------------------------------------------------------------------------
// Temporary output files: written next to the target and renamed on success. A signal handler
// removes the file being written, so that Ctrl-C does not leave a stray temporary behind.

char PendingTemporaryPath[4096] = { 0 };

extern "C" void RemovePendingTemporaryAndExit(int signalNumber)
{
  if (PendingTemporaryPath[0] != '\0')
  {
    unlink(PendingTemporaryPath); // async-signal-safe
  }
  std::signal(signalNumber, SIG_DFL);
  std::raise(signalNumber);
}

class TemporaryFile
{
public:
  explicit TemporaryFile(const std::string& target)
    : Target(target)
    , Path(target + ".tmp-" + std::to_string(static_cast<long>(getpid())))
  {
    if (this->Path.size() < sizeof(PendingTemporaryPath))
    {
      std::strcpy(PendingTemporaryPath, this->Path.c_str());
    }
  }

  ~TemporaryFile()
  {
    PendingTemporaryPath[0] = '\0';
    if (!this->Committed)
    {
      std::remove(this->Path.c_str());
    }
  }

  const std::string& GetPath() const { return this->Path; }

  void Commit()
  {
    if (std::rename(this->Path.c_str(), this->Target.c_str()) != 0)
    {
      throw Failure(
        "cannot rename '" + this->Path + "' to '" + this->Target + "': " + std::strerror(errno));
    }
    this->Committed = true;
  }

private:
  std::string Target;
  std::string Path;
  bool Committed = false;

  TemporaryFile(const TemporaryFile&) = delete;
  void operator=(const TemporaryFile&) = delete;
};

/// Fail early, before minutes of meshing, if a result could not be written.
void CheckWritableTarget(const std::string& path, const std::string& what)
{
  struct stat info;
  if (stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode))
  {
    throw Failure(what + " '" + path + "' is a directory");
  }
  const std::string directory = DirectoryName(path);
  if (stat(directory.c_str(), &info) != 0 || !S_ISDIR(info.st_mode))
  {
    throw Failure(what + " '" + path + "': directory '" + directory + "' does not exist");
  }
  if (access(directory.c_str(), W_OK | X_OK) != 0)
  {
    throw Failure(what + " '" + path + "': directory '" + directory + "' is not writable");
  }
}

//------------------------------------------------------------------------------------------------
// Stage bookkeeping.

struct StageReport
{
  std::string Name;
  bool Skipped = false;
  double Seconds = 0.0;
  long long Leaves = -1;     // -1: not applicable
  long long ThinVoxels = -1; // the spacetree stage: voxels refined as thin parts
  long long Cells = -1;
  long long Points = -1;
  long long FileBytes = -1;
  double PeakRssMiB = 0.0;
  long long MinorFaultsAtEnd = -1; // the process's minor page faults when the stage ended
  std::string Description;         // the table's "output" column
  // The tessellate stage only (Tessellation true): the points stmSpacetreeTessellate added to the
  // leaf corners, the cells per type name, and for hybrid and leaves output the share of the
  // mesh volume (area in 2D) in hexahedra (quads); -1 where not computed.
  bool Tessellation = false;
  long long InsertedPoints = -1;
  std::vector<std::pair<std::string, long long>> CellsByType;
  double HexahedronVolumeFraction = -1.0;
  bool TwoDimensional = false;     // triangles and quads
  int BoundaryLayers = -1;         // the background layers output; -1: not reported
  bool ShowBoundaryLayers = false; // print them below the table (with a separating function)
  // The cut stage only (Cut true): the input cells split, the points added on cut edges, and
  // for volume output the cells inside and outside (-1 for surface output).
  bool Cut = false;
  long long SplitCells = -1;
  long long CutPoints = -1;
  long long InsideCells = -1;
  long long OutsideCells = -1;
  // The snap stage only (Snap true): the points moved onto the surface, and the snaps the
  // filter refused (they would have flattened a cell).
  bool Snap = false;
  long long SnappedPoints = -1;
  long long RefusedSnaps = -1;
  // The smooth stage only (Smooth true): the points moved and the moves undone for the quality
  // bounds; SurfaceCells the triangles (lines) of the surface it extracts for --output-mode
  // surface, -1 for volume output.
  bool Smooth = false;
  long long MovedPoints = -1;
  long long RejectedMoves = -1;
  long long ImprovedPoints = -1;
  long long SplitEdges = -1;
  long long KeptPoints = -1;
  long long SurfaceCells = -1;
};

/// The process's peak resident memory and its minor page faults so far (pages mapped in without
/// reading a file); 0 and -1 if the system does not say.
struct ResourceUsage
{
  double PeakRssMiB = 0.0;
  long long MinorPageFaults = -1;
};

ResourceUsage CurrentResourceUsage()
{
  struct rusage usage;
  if (getrusage(RUSAGE_SELF, &usage) != 0)
  {
    return {};
  }
  ResourceUsage current;
  current.PeakRssMiB = static_cast<double>(usage.ru_maxrss) / 1024.0; // Linux reports KiB
  current.MinorPageFaults = static_cast<long long>(usage.ru_minflt);
  return current;
}

double PeakRssMiB()
{
  return CurrentResourceUsage().PeakRssMiB;
}

void RecordResources(StageReport& report)
{
  const ResourceUsage usage = CurrentResourceUsage();
  report.PeakRssMiB = usage.PeakRssMiB;
  report.MinorFaultsAtEnd = usage.MinorPageFaults;
}

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start)
{
  return std::chrono::duration<double>(Clock::now() - start).count();
}

//------------------------------------------------------------------------------------------------
// Threads.

struct ThreadSetup
{
  std::string Backend;
  int Threads = 1;
};

ThreadSetup SetUpThreads(int requestedThreads)
{
  // Debian's VTK defaults to the Sequential backend; STDThread is compiled in and gives threads
  // without the user doing anything. A backend chosen through the environment wins.
  const char* backendFromEnvironment = std::getenv("VTK_SMP_BACKEND_IN_USE");
  if (!backendFromEnvironment || !*backendFromEnvironment)
  {
    if (!vtkSMPTools::SetBackend("STDThread"))
    {
      Diagnostics() << "stmesh: warning: VTK's STDThread backend is not available; running with "
                       "the "
                    << vtkSMPTools::GetBackend() << " backend\n";
    }
  }

  int threads = requestedThreads;
  const char* maxThreadsFromEnvironment = std::getenv("VTK_SMP_MAX_THREADS");
  if (threads == 0 && maxThreadsFromEnvironment && *maxThreadsFromEnvironment)
  {
    try
    {
      threads = static_cast<int>(
        ParseInteger(maxThreadsFromEnvironment, "VTK_SMP_MAX_THREADS", 1, MaxThreads));
    }
    catch (const UsageError& error)
    {
      // Not a command-line mistake, but still a configuration the user must fix.
      throw Failure(std::string("environment variable ") + error.what());
    }
  }
  vtkSMPTools::Initialize(threads); // 0: every core
  ThreadSetup setup;
  setup.Backend = vtkSMPTools::GetBackend() ? vtkSMPTools::GetBackend() : "unknown";
  setup.Threads = vtkSMPTools::GetEstimatedNumberOfThreads();
  return setup;
}

/// The cores this process may run on: its CPU affinity, else the machine's. An MPI launcher binds
/// each rank to a core or a few (Open MPI: one core per rank for up to two ranks), and threads
/// beyond those cores only take turns (`mpiexec -n 1 stmesh`, AAL brain mask: 22.7 s with 2
/// threads on its bound core, 12.8 s with `--bind-to none`).
int UsableCores()
{
#if defined(__linux__)
  cpu_set_t cores;
  CPU_ZERO(&cores);
  if (sched_getaffinity(0, sizeof(cores), &cores) == 0 && CPU_COUNT(&cores) > 0)
  {
    return CPU_COUNT(&cores);
  }
#endif
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

/// The threads of each rank: those given (--threads, VTK_SMP_MAX_THREADS), else the machine's
/// cores shared between the ranks on it, and no more than the cores this process may run on;
/// 0 (every core) when neither limits them. `note` tells how to give a rank that an MPI launcher
/// bound to fewer cores its share.
int ThreadsPerRank(int requestedThreads, int ranks, std::string& note)
{
  const char* maxThreadsFromEnvironment = std::getenv("VTK_SMP_MAX_THREADS");
  if (requestedThreads > 0 || (maxThreadsFromEnvironment && *maxThreadsFromEnvironment))
  {
    return requestedThreads;
  }
  const int machineCores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const LaunchEnvironment launch = ReadLaunchEnvironment();
  const int ranksHere =
    ranks < 2 ? 1 : (launch.RanksOnThisNode > 0 ? launch.RanksOnThisNode : ranks);
  const int share = std::max(1, machineCores / ranksHere);
  const int usable = std::min(UsableCores(), machineCores);
  if (usable < share && launch.Ranks > 0) // else a binding the user chose (taskset): no note
  {
    note = "stmesh: note: this process may run on " + std::to_string(usable) + " of the " +
      std::to_string(machineCores) + " cores (the MPI launcher bound it), so it uses " +
      std::to_string(usable) + " thread" + (usable == 1 ? "" : "s") + " instead of " +
      std::to_string(share) + "; `mpiexec --bind-to none` (Open MPI) lets " +
      (ranks < 2 ? "it" : "each rank") + " use " + std::to_string(share) + ", or pass --threads\n";
  }
  if (usable >= machineCores && ranksHere == 1)
  {
    return 0;
  }
  return std::min(usable, share);
}

//------------------------------------------------------------------------------------------------
// Reading (stmeshImageInput.h), and the checks of the label image's type.

/// The read stage's description of the image, and the check that labels are integers.
void DescribeReadImage(vtkImageData* image, const std::string& path, const ImageInfo& info,
  StageReport& report, bool labelImage = true)
{
  if (labelImage && !stmImageToSpacetree::IsLabelType(ImageValues(image, info)->GetDataType()))
  {
    throw Failure("reading '" + path + "': the image holds " + info.ScalarType +
      " values; stmesh needs an integer label image (a segmentation, not a gray-value image)");
  }
  std::ostringstream description;
  description << info.Dimensions[0] << " x " << info.Dimensions[1] << " x " << info.Dimensions[2]
              << " voxels, " << info.ScalarType;
  report.Description = description.str();
}

/// Read the label image (labelImage) or the gray image of --separating gray.
vtkSmartPointer<vtkImageData> ReadImage(
  const std::string& path, ImageInfo& info, StageReport& report, bool labelImage = true)
{
  vtkSmartPointer<vtkImageData> image =
    stmesh::ReadImage(path, labelImage ? ImageRole::Labels : ImageRole::Gray, info, report.Seconds);
  DescribeReadImage(image, path, info, report, labelImage);
  report.Points = static_cast<long long>(image->GetNumberOfPoints());
  RecordResources(report);
  return image;
}

/// Opens the label image for a run in pieces, in which each rank reads its own extent when the
/// spacetree filter asks for it.
stmesh::ImageSource OpenLabelImage(const std::string& path, ImageInfo& info, StageReport& report)
{
  stmesh::ImageSource source = stmesh::OpenImage(path, ImageRole::Labels, info, report.Seconds);
  DescribeReadImage(source.Sample, path, info, report);
  RecordResources(report);
  return source;
}

//------------------------------------------------------------------------------------------------
// --merge: the label array with the sources of every group replaced by its target.

/// Copies the labels into Output (an array of the same type), replacing every source of the
/// table (sorted by source) by its target, and records which sources occur.
struct RemapLabels
{
  const std::vector<std::pair<long long, long long>>* Table = nullptr;
  vtkDataArray* Output = nullptr;
  std::vector<char> Seen;

  template <typename ArrayT>
  void operator()(ArrayT* input)
  {
    using Value = vtk::GetAPIType<ArrayT>;
    ArrayT* output = vtkArrayDownCast<ArrayT>(this->Output);
    const auto in = vtk::DataArrayValueRange<1>(input);
    auto out = vtk::DataArrayValueRange<1>(output);
    const std::vector<std::pair<long long, long long>>& table = *this->Table;
    vtkSMPThreadLocal<std::vector<char>> seen;
    vtkSMPTools::For(0, static_cast<vtkIdType>(in.size()),
      [&](vtkIdType begin, vtkIdType end)
      {
        std::vector<char>& local = seen.Local();
        local.resize(table.size(), 0);
        bool cached = false;
        Value last{};
        Value replacement{};
        for (vtkIdType v = begin; v < end; ++v)
        {
          const Value value = in[v];
          if (!cached || value != last)
          {
            // Labels come in runs: look up only when the value changes.
            const long long label = static_cast<long long>(value);
            const auto found = std::lower_bound(table.begin(), table.end(),
              std::make_pair(label, std::numeric_limits<long long>::lowest()));
            replacement = value;
            if (found != table.end() && found->first == label)
            {
              replacement = static_cast<Value>(found->second);
              local[found - table.begin()] = 1;
            }
            last = value;
            cached = true;
          }
          out[v] = replacement;
        }
      });
    this->Seen.assign(table.size(), 0);
    for (const std::vector<char>& local : seen)
    {
      for (std::size_t i = 0; i < local.size(); ++i)
      {
        this->Seen[i] = static_cast<char>(this->Seen[i] | local[i]);
      }
    }
  }
};

/// The --merge table: (source, target) pairs sorted by source.
std::vector<std::pair<long long, long long>> MergeTable(const Options& options)
{
  std::vector<std::pair<long long, long long>> table;
  for (const MergeGroup& group : options.Merges)
  {
    for (const int source : group.Sources)
    {
      table.emplace_back(source, group.Target);
    }
  }
  std::sort(table.begin(), table.end());
  return table;
}

/// --merge: a copy of the image whose label array has the merged labels. A target that the
/// label type cannot hold widens the copy to int (long long for unsigned 32- and 64-bit labels).
/// seen[i] is set where the table's i-th source occurs in the image (MergeTable's order).
vtkSmartPointer<vtkImageData> MergeLabels(
  vtkImageData* image, const ImageInfo& info, const Options& options, std::vector<char>& seen)
{
  vtkDataArray* labels = ImageValues(image, info);
  const std::vector<std::pair<long long, long long>> table = MergeTable(options);
  vtkSmartPointer<vtkDataArray> source = labels;
  bool fits = true;
  for (const MergeGroup& group : options.Merges)
  {
    fits =
      fits && group.Target >= labels->GetDataTypeMin() && group.Target <= labels->GetDataTypeMax();
  }
  if (!fits)
  {
    const bool intHoldsAll =
      labels->GetDataTypeMin() >= VTK_INT_MIN && labels->GetDataTypeMax() <= VTK_INT_MAX;
    source = intHoldsAll ? vtkSmartPointer<vtkDataArray>(vtkSmartPointer<vtkIntArray>::New())
                         : vtkSmartPointer<vtkDataArray>(vtkSmartPointer<vtkLongLongArray>::New());
    source->DeepCopy(labels);
    source->SetName(labels->GetName());
  }
  vtkSmartPointer<vtkDataArray> merged = vtkSmartPointer<vtkDataArray>::Take(source->NewInstance());
  merged->SetNumberOfComponents(1);
  merged->SetNumberOfTuples(source->GetNumberOfTuples());
  merged->SetName(labels->GetName());
  RemapLabels remap;
  remap.Table = &table;
  remap.Output = merged;
  if (!vtkArrayDispatch::DispatchByValueType<vtkArrayDispatch::Integrals>::Execute(source, remap))
  {
    remap(source.GetPointer()); // generic fallback through the vtkDataArray API
  }
  seen.resize(table.size(), 0);
  for (std::size_t i = 0; i < table.size(); ++i)
  {
    seen[i] = static_cast<char>(seen[i] | remap.Seen[i]);
  }
  vtkSmartPointer<vtkImageData> copy = vtkSmartPointer<vtkImageData>::New();
  copy->ShallowCopy(image);
  vtkDataSetAttributes* data = info.CellLabels
    ? static_cast<vtkDataSetAttributes*>(copy->GetCellData())
    : static_cast<vtkDataSetAttributes*>(copy->GetPointData());
  data->SetScalars(merged);
  return copy;
}

/// A source of --merge that does not occur in the image fails, as an absent --labels label
/// does; seen: MergeLabels's flags over the whole image.
void CheckMergeSourcesSeen(
  const Options& options, const std::vector<char>& seen, const std::string& input)
{
  const std::vector<std::pair<long long, long long>> table = MergeTable(options);
  std::string absent;
  for (std::size_t i = 0; i < table.size(); ++i)
  {
    if (i >= seen.size() || !seen[i])
    {
      absent += (absent.empty() ? "" : ", ") + std::to_string(table[i].first);
    }
  }
  if (!absent.empty())
  {
    const bool one = absent.find(',') == std::string::npos;
    throw Failure(std::string("--merge: source label") + (one ? " " : "s ") + absent +
      (one ? " does" : " do") + " not occur in the image '" + input + "'");
  }
}

/// --merge in a run in pieces: the merge as a pipeline step between the reader and the
/// spacetree filter, which passes the filter's extent request on to the reader (as every
/// vtkProgrammableFilter does), so that each rank merges the labels of its own extent only.
struct PieceMerge
{
  vtkNew<vtkProgrammableFilter> Filter;
  const ImageInfo* Info = nullptr;
  const Options* MergeOptions = nullptr;
  std::vector<char> Seen; // of this rank's extent

  PieceMerge(vtkAlgorithmOutput* input, const ImageInfo& info, const Options& options)
    : Info(&info)
    , MergeOptions(&options)
    , Seen(MergeTable(options).size(), 0)
  {
    this->Filter->SetInputConnection(input);
    this->Filter->SetExecuteMethod(&PieceMerge::Execute, this);
    Watch(this->Filter);
  }

  static void Execute(void* self)
  {
    auto* merge = static_cast<PieceMerge*>(self);
    vtkImageData* piece = vtkImageData::SafeDownCast(merge->Filter->GetInput());
    vtkImageData* output = merge->Filter->GetImageDataOutput();
    if (!piece || !output)
    {
      return;
    }
    if (!ImageValues(piece, *merge->Info)) // an empty piece: a rank without root cells
    {
      output->ShallowCopy(piece);
      return;
    }
    output->ShallowCopy(MergeLabels(piece, *merge->Info, *merge->MergeOptions, merge->Seen));
  }
};

/// The label image, its labels merged by --merge.
vtkSmartPointer<vtkImageData> ReadMergedImage(
  const std::string& input, const Options& options, ImageInfo& info, StageReport& report)
{
  vtkSmartPointer<vtkImageData> image = ReadImage(input, info, report);
  if (!options.Merges.empty())
  {
    const Clock::time_point mergeStart = Clock::now();
    std::vector<char> seen;
    image = MergeLabels(image, info, options, seen);
    CheckMergeSourcesSeen(options, seen, input);
    report.Seconds += SecondsSince(mergeStart);
  }
  return image;
}

/// Whether each --merge source occurs on any rank (PieceMerge's flags of every rank).
std::vector<char> SeenOnAnyRank(const std::vector<char>& mine, const ParallelRun& parallel)
{
  const std::vector<long long> all =
    parallel.AllGather(std::vector<long long>(mine.begin(), mine.end()));
  std::vector<char> seen(mine.size(), 0);
  for (std::size_t i = 0; i < all.size(); ++i)
  {
    seen[i % seen.size()] = static_cast<char>(seen[i % seen.size()] | (all[i] != 0));
  }
  return seen;
}

//------------------------------------------------------------------------------------------------
// Meshing stages: each filter runs on a detached copy of the previous result, so that the
// previous filter (and, once unreferenced, its data) can be freed; this keeps the peak memory
// near two stages' worth instead of all of them.

/// The piece every stage is asked for: under MPI rank k of n meshes piece k of n (set by Run).
/// The stages after the spacetree then give a rank whose piece holds no body an empty output
/// quietly, as in pvbatch, and the smoothing's ranks improve their shared points together.
struct MeshingPiece
{
  int Piece = 0;
  int Pieces = 1;
};
MeshingPiece CurrentPiece;

/// Runs one filter on input port 0 and returns a copy of its output (a vtkUnstructuredGrid, or
/// the cut's surface as a vtkPolyData); adds its wall time to the report. The filter is asked
/// for piece CurrentPiece. A null input: the filter is connected to its input's algorithm.
vtkSmartPointer<vtkPointSet> RunFilter(
  vtkAlgorithm* filter, vtkDataObject* input, const std::string& context, StageReport& report)
{
  const int piece = CurrentPiece.Piece;
  const int pieces = CurrentPiece.Pieces;
  Watch(filter);
  if (input)
  {
    filter->SetInputDataObject(0, input);
  }
  const Clock::time_point start = Clock::now();
  filter->UpdatePiece(piece, pieces, 0);
  report.Seconds += SecondsSince(start);
  ThrowIfFailed(context);
  vtkPointSet* output = vtkPointSet::SafeDownCast(filter->GetOutputDataObject(0));
  if (!output)
  {
    throw Failure(context + ": the filter produced no output");
  }
  vtkSmartPointer<vtkPointSet> copy = vtkSmartPointer<vtkPointSet>::Take(output->NewInstance());
  copy->ShallowCopy(output);
  filter->SetInputDataObject(0, nullptr);
  report.Cells = static_cast<long long>(copy->GetNumberOfCells());
  report.Points = static_cast<long long>(copy->GetNumberOfPoints());
  RecordResources(report);
  return copy;
}

vtkSmartPointer<vtkUnstructuredGrid> RunStage(vtkAlgorithm* filter, vtkDataObject* input,
  const std::string& context, StageReport& report, bool isSpacetree)
{
  vtkSmartPointer<vtkUnstructuredGrid> copy =
    vtkUnstructuredGrid::SafeDownCast(RunFilter(filter, input, context, report));
  if (!copy)
  {
    throw Failure(context + ": the filter produced no unstructured grid");
  }
  std::ostringstream description;
  if (isSpacetree)
  {
    report.Leaves = report.Cells;
    description << report.Leaves << " leaves";
  }
  else
  {
    description << report.Cells << " cells, " << report.Points << " points";
  }
  report.Description = description.str();
  RecordResources(report);
  return copy;
}

//------------------------------------------------------------------------------------------------
// The spacetree options: regions, size criteria and balance levels.

/// The implicit function of a region. A slab is a plane with a band of its width around it for
/// the refinement region (bandWidth), and the intersection of its two bounding half-spaces for
/// the balance region, which has no band.
vtkSmartPointer<vtkImplicitFunction> MakeRegion(
  const RegionOption& region, bool slabAsBand, double& bandWidth)
{
  const std::vector<double>& v = region.Values;
  bandWidth = 0.0;
  if (region.Type == "box")
  {
    vtkNew<vtkBox> box;
    box->SetBounds(v[0], v[3], v[1], v[4], v[2], v[5]);
    return box.GetPointer();
  }
  if (region.Type == "sphere")
  {
    vtkNew<vtkSphere> sphere;
    sphere->SetCenter(v[0], v[1], v[2]);
    sphere->SetRadius(v[3]);
    return sphere.GetPointer();
  }
  if (region.Type == "cylinder")
  {
    vtkNew<vtkCylinder> cylinder;
    cylinder->SetCenter(v[0], v[1], v[2]);
    cylinder->SetAxis(v[3], v[4], v[5]); // normalised by vtkCylinder
    cylinder->SetRadius(v[6]);
    return cylinder.GetPointer();
  }
  // A slab. vtkPlane's value is the dot product with the normal as given: a unit normal makes
  // it the signed distance, so that the width is in physical units.
  const double length = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5]);
  const double normal[3] = { v[3] / length, v[4] / length, v[5] / length };
  const double halfWidth = 0.5 * v[6];
  if (slabAsBand)
  {
    vtkNew<vtkPlane> plane;
    plane->SetOrigin(v[0], v[1], v[2]);
    plane->SetNormal(normal[0], normal[1], normal[2]);
    bandWidth = v[6];
    return plane.GetPointer();
  }
  vtkNew<vtkImplicitBoolean> slab;
  slab->SetOperationTypeToIntersection(); // the largest value: inside both half-spaces
  for (const double side : { 1.0, -1.0 })
  {
    vtkNew<vtkPlane> plane;
    plane->SetOrigin(v[0] + side * halfWidth * normal[0], v[1] + side * halfWidth * normal[1],
      v[2] + side * halfWidth * normal[2]);
    plane->SetNormal(side * normal[0], side * normal[1], side * normal[2]);
    slab->AddFunction(plane);
  }
  return slab.GetPointer();
}

std::string DimensionText(const ImageInfo& info)
{
  return std::to_string(info.VoxelDimensions[0]) + " x " + std::to_string(info.VoxelDimensions[1]) +
    " x " + std::to_string(info.VoxelDimensions[2]) + " voxels";
}

/// Sets the spacetree options of the command line on the filter. The options that depend on the
/// image's dimension (two or three numbers) are checked here, as usage errors.
void ConfigureSpacetree(stmImageToSpacetree* spacetree, const Options& options, vtkImageData* image,
  const ImageInfo& info)
{
  for (int label : options.Labels)
  {
    spacetree->AddBodyLabel(label);
  }
  if (info.CellLabels)
  {
    // Known before the voxels arrive: under MPI the pieces' extents are requested by it.
    spacetree->SetInputArrayToProcess(
      0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_CELLS, vtkDataSetAttributes::SCALARS);
  }
  spacetree->SetMaxCellSize(options.MaxCellSize);
  spacetree->SetThinPartRefinement(options.ThinPartMode());
  const bool threeD = info.SpannedAxes.size() == 3;
  if (options.PatternCounts == 2 && threeD)
  {
    throw UsageError("--pattern: the image is 3D (" + DimensionText(info) +
      "); give three split counts per entry, such as 2x2x2");
  }
  spacetree->SetRefinementPattern(options.Pattern.c_str());
  if (!options.RootCellSize.empty())
  {
    int sizes[3] = { 0, 0, 0 };
    if (options.RootCellSize.size() == 3)
    {
      std::copy(options.RootCellSize.begin(), options.RootCellSize.end(), sizes);
    }
    else if (info.SpannedAxes.size() == 2)
    {
      // X,Y of a 2D image: the two axes it spans; the flat axis has one voxel.
      sizes[0] = sizes[1] = sizes[2] = 1;
      sizes[info.SpannedAxes[0]] = options.RootCellSize[0];
      sizes[info.SpannedAxes[1]] = options.RootCellSize[1];
    }
    else
    {
      throw UsageError(
        "--root-cell-size: the image is 3D (" + DimensionText(info) + "); give three sizes X,Y,Z");
    }
    spacetree->SetRootCellSize(sizes);
  }
  for (const auto& entry : options.LabelMaxCellSizes)
  {
    spacetree->SetLabelMaxCellSize(entry.first, entry.second);
  }
  if (!options.RefineRegion.Type.empty())
  {
    double bandWidth = 0.0;
    spacetree->SetRefinementRegion(MakeRegion(options.RefineRegion, true, bandWidth));
    spacetree->SetRegionMaxCellSize(options.RefineRegion.Size);
    spacetree->SetRegionBandWidth(bandWidth);
  }
  spacetree->SetGrading(options.Grading);
  if (!options.SizingArray.empty())
  {
    const std::string& name = options.SizingArray;
    vtkDataSetAttributes* labelData = info.CellLabels
      ? static_cast<vtkDataSetAttributes*>(image->GetCellData())
      : static_cast<vtkDataSetAttributes*>(image->GetPointData());
    vtkDataSetAttributes* otherData = info.CellLabels
      ? static_cast<vtkDataSetAttributes*>(image->GetPointData())
      : static_cast<vtkDataSetAttributes*>(image->GetCellData());
    const char* labelKind = info.CellLabels ? "cell" : "point";
    const char* otherKind = info.CellLabels ? "point" : "cell";
    if (!labelData->GetAbstractArray(name.c_str()))
    {
      if (otherData->GetAbstractArray(name.c_str()))
      {
        throw Failure("--sizing-array: '" + name + "' is " + otherKind +
          " data, but the labels are " + labelKind +
          " data; the sizing array needs the labels' association");
      }
      std::string names;
      for (int i = 0; i < labelData->GetNumberOfArrays(); ++i)
      {
        const char* arrayName = labelData->GetArrayName(i);
        names += std::string(names.empty() ? "" : ", ") + "'" + (arrayName ? arrayName : "") + "'";
      }
      throw Failure("--sizing-array: the image has no " + std::string(labelKind) +
        " array named '" + name + "' (its " + labelKind +
        " arrays: " + (names.empty() ? "none" : names) + ")");
    }
    if (!labelData->GetArray(name.c_str()))
    {
      throw Failure("--sizing-array: '" + name + "' is not a numeric array");
    }
    spacetree->SetUseSizingArray(true);
    spacetree->SetInputArrayToProcess(1, 0, 0,
      info.CellLabels ? vtkDataObject::FIELD_ASSOCIATION_CELLS
                      : vtkDataObject::FIELD_ASSOCIATION_POINTS,
      name.c_str());
  }
}

void ConfigureBalance(stmSpacetreeBalance* balance, const Options& options,
  vtkSmartPointer<vtkImplicitFunction>& region)
{
  balance->SetBalanceLevel(options.BalanceLevel);
  for (const auto& entry : options.LabelBalanceLevels)
  {
    balance->SetLabelBalanceLevel(entry.first, entry.second);
  }
  if (!options.BalanceRegion.Type.empty())
  {
    double bandWidth = 0.0;
    region = MakeRegion(options.BalanceRegion, false, bandWidth);
    balance->SetBalanceRegion(region);
    balance->SetRegionBalanceLevel(options.BalanceRegion.Level);
  }
}

/// Whether the centre of some leaf of a spacetree dataset (the mean of its corners) is in the
/// region, as stmSpacetreeBalance decides it.
bool RegionHoldsLeafCentre(vtkUnstructuredGrid* grid, vtkImplicitFunction* region)
{
  vtkPoints* points = grid->GetPoints();
  if (!points)
  {
    return false;
  }
  vtkNew<vtkIdList> corners;
  for (vtkIdType cell = 0; cell < grid->GetNumberOfCells(); ++cell)
  {
    grid->GetCellPoints(cell, corners);
    double centre[3] = { 0.0, 0.0, 0.0 };
    for (vtkIdType i = 0; i < corners->GetNumberOfIds(); ++i)
    {
      double x[3];
      points->GetPoint(corners->GetId(i), x);
      for (int c = 0; c < 3; ++c)
      {
        centre[c] += x[c] / static_cast<double>(corners->GetNumberOfIds());
      }
    }
    if (region->FunctionValue(centre) <= 0)
    {
      return true;
    }
  }
  return false;
}

/// The level table of a spacetree dataset: the cell edges per level, root first, and the
/// lattice units per voxel, per axis the spacetree spans.
struct LevelTable
{
  bool Present = false;
  std::vector<int> ImageAxes;
  std::vector<int> VoxelSubdivision;
  std::vector<std::vector<int>> CellSizes; // lattice units
};

LevelTable ReadLevelTable(vtkUnstructuredGrid* grid)
{
  LevelTable table;
  vtkFieldData* fd = grid->GetFieldData();
  vtkDataArray* sizes = fd->GetArray("SpacetreeCellSizes");
  vtkDataArray* subdivision = fd->GetArray("SpacetreeVoxelSubdivision");
  vtkDataArray* axes = fd->GetArray("SpacetreeImageAxes");
  if (!sizes || !subdivision || !axes)
  {
    return table;
  }
  const vtkIdType dimension = subdivision->GetNumberOfValues();
  if (dimension < 1 || axes->GetNumberOfValues() != dimension ||
    sizes->GetNumberOfValues() % dimension != 0)
  {
    return table;
  }
  for (vtkIdType axis = 0; axis < dimension; ++axis)
  {
    table.VoxelSubdivision.push_back(static_cast<int>(subdivision->GetVariantValue(axis).ToInt()));
    table.ImageAxes.push_back(static_cast<int>(axes->GetVariantValue(axis).ToInt()));
    if (table.VoxelSubdivision.back() < 1)
    {
      return LevelTable();
    }
  }
  for (vtkIdType level = 0; level < sizes->GetNumberOfValues() / dimension; ++level)
  {
    std::vector<int> size;
    for (vtkIdType axis = 0; axis < dimension; ++axis)
    {
      size.push_back(sizes->GetVariantValue(level * dimension + axis).ToInt());
    }
    table.CellSizes.push_back(size);
  }
  table.Present = true;
  return table;
}

//------------------------------------------------------------------------------------------------
// Writing.

long long FileSize(const std::string& path)
{
  struct stat info;
  return stat(path.c_str(), &info) == 0 ? static_cast<long long>(info.st_size) : -1;
}

/// The settings of every XML writer of stmesh's output.
void ConfigureXMLWriter(vtkXMLWriter* writer, const std::string& compressor)
{
  // Inline binary, never appended: Debian 12's libexpat fails on appended-mode files.
  writer->SetDataModeToBinary();
  // The compressor sets most of the write time (compressed on all threads by the stm writers):
  // LZ4 is the fastest; zlib at level 1 (about twice as fast as its default level 5, files ~2%
  // larger) makes files about 2.3 times smaller than LZ4.
  if (compressor == "zlib")
  {
    writer->SetCompressorTypeToZLib();
    writer->SetCompressionLevel(1);
  }
  else if (compressor == "lz4")
  {
    writer->SetCompressorTypeToLZ4();
  }
  else
  {
    writer->SetCompressorTypeToNone();
  }
  // Each compressed block pays for a new compressor stream: 1 MiB blocks instead of the
  // default 32 KiB make the AAL mesh's write about a third faster for the same file size.
  writer->SetBlockSize(1 << 20);
  // 64-bit headers lift the 4 GiB limit on one array.
  writer->SetHeaderTypeToUInt64();
}

/// Writes a mesh with an XML writer (stmXMLUnstructuredGridWriter or stmXMLPolyDataWriter: VTK's
/// files, encoded on all threads).
template <class Writer>
int WriteXML(vtkDataObject* mesh, const std::string& path, const std::string& compressor,
  unsigned long& errorCode)
{
  vtkNew<Writer> writer;
  Watch(writer);
  writer->SetInputData(mesh);
  writer->SetFileName(path.c_str());
  ConfigureXMLWriter(writer, compressor);
  const int written = writer->Write();
  errorCode = writer->GetErrorCode();
  return written;
}

/// Writes a mesh with a legacy writer (vtkUnstructuredGridWriter or vtkPolyDataWriter).
template <class Writer>
int WriteLegacy(vtkDataObject* mesh, const std::string& path, unsigned long& errorCode)
{
  vtkNew<Writer> writer;
  Watch(writer);
  writer->SetInputData(mesh);
  writer->SetFileName(path.c_str());
  writer->SetFileTypeToBinary();
  const int written = writer->Write();
  errorCode = writer->GetErrorCode();
  return written;
}

void WriteMesh(vtkPointSet* mesh, const std::string& path, MeshFormat format,
  const std::string& compressor, bool binaryMsh, StageReport& report);

/// Whether the output leaves out the cells of Material 0 (--background, or the format's
/// default: the finite-element formats drop them, a solver has no use for the layer of
/// background cells around the body).
bool DropsBackground(const Options& options, MeshFormat format)
{
  return options.Background == 0 || (options.Background < 0 && IsFiniteElementFormat(format));
}

/// The mesh without its cells of Material 0 and the points only they used (an unstructured
/// grid; a mesh without the array is returned as it is).
vtkSmartPointer<vtkPointSet> WithoutBackground(vtkPointSet* mesh)
{
  vtkDataArray* materials = mesh->GetCellData()->GetArray("Material");
  if (!materials || !vtkUnstructuredGrid::SafeDownCast(mesh))
  {
    return mesh;
  }
  vtkNew<vtkIdList> kept;
  for (vtkIdType cell = 0; cell < mesh->GetNumberOfCells(); ++cell)
  {
    if (materials->GetComponent(cell, 0) != 0.0)
    {
      kept->InsertNextId(cell);
    }
  }
  if (kept->GetNumberOfIds() == mesh->GetNumberOfCells())
  {
    return mesh;
  }
  vtkNew<vtkExtractCells> extract;
  Watch(extract);
  extract->SetInputData(mesh);
  extract->SetCellList(kept);
  extract->AssumeSortedAndUniqueIdsOn();
  extract->Update();
  ThrowIfFailed("leaving out the background cells");
  vtkSmartPointer<vtkPointSet> result = extract->GetOutput();
  result->GetFieldData()->ShallowCopy(mesh->GetFieldData());
  return result;
}

/// Writes a volume mesh with one of the module's finite-element writers.
template <class Writer>
int WriteFiniteElement(
  Writer* writer, vtkPointSet* mesh, const std::string& path, unsigned long& errorCode)
{
  Watch(writer);
  writer->SetInputData(mesh);
  writer->SetFileName(path.c_str());
  const int written = writer->Write();
  errorCode = writer->GetErrorCode();
  return written;
}

/// The "interfaces" stage: stmInterfaceSurface on the output mesh, written to --interfaces.
StageReport WriteInterfaces(vtkPointSet* mesh, const Options& options, bool twoDimensional)
{
  StageReport report;
  report.Name = "interfaces";
  report.TwoDimensional = twoDimensional;
  const Clock::time_point start = Clock::now();
  vtkNew<stmInterfaceSurface> interfaces;
  Watch(interfaces);
  interfaces->SetInputData(mesh);
  interfaces->Update();
  ThrowIfFailed("extracting the interfaces");
  vtkPolyData* surface = interfaces->GetOutput();
  const double extraction = SecondsSince(start);
  MeshFormat format = MeshFormat::XMLPolyData;
  FindMeshFormat(options.Interfaces, format); // checked with the command line
  WriteMesh(surface, options.Interfaces, format, options.Compressor, false, report);
  report.Seconds += extraction;
  report.Cells = surface->GetNumberOfCells();
  report.Points = surface->GetNumberOfPoints();
  report.Description = std::to_string(report.Cells) +
    (twoDimensional ? " segments, " : " facets, ") + report.Description;
  return report;
}

/// The write stage's table entry: the file's size and name.
void DescribeWrittenFile(const std::string& path, StageReport& report)
{
  RecordResources(report);
  std::ostringstream description;
  description << std::fixed << std::setprecision(1)
              << static_cast<double>(report.FileBytes) / (1024.0 * 1024.0) << " MiB "
              << FileName(path);
  report.Description = description.str();
}

/// Writes the mesh (a vtkUnstructuredGrid, or the cut's surface as a vtkPolyData).
void WriteMesh(vtkPointSet* mesh, const std::string& path, MeshFormat format,
  const std::string& compressor, bool binaryMsh, StageReport& report)
{
  const std::string context = "writing '" + path + "'";
  const bool surface = vtkPolyData::SafeDownCast(mesh) != nullptr;
  if (surface != (format == MeshFormat::XMLPolyData) && format != MeshFormat::LegacyVTK)
  {
    // The command line was checked already.
    throw Failure(context + ": the extension does not fit the " +
      (surface ? "surface (polydata)" : "unstructured grid"));
  }
  TemporaryFile temporary(path);
  const Clock::time_point start = Clock::now();
  int written = 0;
  unsigned long errorCode = 0;
  switch (format)
  {
    case MeshFormat::XMLUnstructuredGrid:
      written =
        WriteXML<stmXMLUnstructuredGridWriter>(mesh, temporary.GetPath(), compressor, errorCode);
      break;
    case MeshFormat::XMLPolyData:
      written = WriteXML<stmXMLPolyDataWriter>(mesh, temporary.GetPath(), compressor, errorCode);
      break;
    case MeshFormat::PartitionedXML:
      throw Failure(context + ": a .pvtu is written in pieces (WritePieces)");
    case MeshFormat::LegacyVTK:
      written = surface
        ? WriteLegacy<vtkPolyDataWriter>(mesh, temporary.GetPath(), errorCode)
        : WriteLegacy<vtkUnstructuredGridWriter>(mesh, temporary.GetPath(), errorCode);
      break;
    case MeshFormat::Gmsh:
    {
      vtkNew<stmGmshWriter> writer;
      writer->SetBinary(binaryMsh);
      written = WriteFiniteElement(writer.Get(), mesh, temporary.GetPath(), errorCode);
      break;
    }
    case MeshFormat::Medit:
    {
      vtkNew<stmMeditWriter> writer;
      written = WriteFiniteElement(writer.Get(), mesh, temporary.GetPath(), errorCode);
      break;
    }
    case MeshFormat::Abaqus:
    {
      vtkNew<stmAbaqusWriter> writer;
      written = WriteFiniteElement(writer.Get(), mesh, temporary.GetPath(), errorCode);
      break;
    }
    case MeshFormat::FEBio:
    {
      vtkNew<stmFEBioWriter> writer;
      written = WriteFiniteElement(writer.Get(), mesh, temporary.GetPath(), errorCode);
      break;
    }
    case MeshFormat::Exodus:
    {
      vtkNew<stmExodusWriter> writer;
      written = WriteFiniteElement(writer.Get(), mesh, temporary.GetPath(), errorCode);
      break;
    }
  }
  ThrowIfFailed(context);
  if (!written || errorCode != 0)
  {
    throw Failure(context + ": the writer failed (disk full or I/O error?)");
  }
  report.FileBytes = FileSize(temporary.GetPath());
  if (report.FileBytes <= 0)
  {
    throw Failure(context + ": the written file is missing or empty");
  }
  temporary.Commit();
  report.Seconds = SecondsSince(start);
  DescribeWrittenFile(path, report);
}

/// Writes this rank's piece of a .pvtu: the pieces go to a folder named after the file
/// (mesh.pvtu: mesh/mesh_0.vtu, mesh/mesh_1.vtu, ...), each written by its rank, and rank 0
/// writes mesh.pvtu. Not through a temporary file: the ranks write side by side.
void WritePieces(vtkPointSet* mesh, const std::string& path, const std::string& compressor,
  const ParallelRun& parallel, StageReport& report)
{
  const std::string context = "writing '" + path + "'";
  const Clock::time_point start = Clock::now();
  vtkNew<stmXMLPUnstructuredGridWriter> writer;
  Watch(writer);
  writer->SetInputData(mesh);
  writer->SetFileName(path.c_str());
  ConfigureXMLWriter(writer, compressor);
  writer->SetController(parallel.GetController());
  writer->SetNumberOfPieces(parallel.Ranks());
  writer->SetStartPiece(parallel.Rank());
  writer->SetEndPiece(parallel.Rank());
  writer->SetUseSubdirectory(true);
  const int written = writer->Write();
  ThrowIfFailed(context);
  if (!written || writer->GetErrorCode() != 0)
  {
    throw Failure(context + ": the writer failed (disk full or I/O error?)");
  }
  const std::string stem = path.substr(0, path.size() - 5); // without ".pvtu"
  const std::string piece =
    stem + "/" + FileName(stem) + "_" + std::to_string(parallel.Rank()) + ".vtu";
  report.Seconds = SecondsSince(start);
  if (mesh->GetNumberOfCells() == 0)
  {
    // A piece without body (a small body on many ranks): VTK's writer writes no file for it,
    // and the .pvtu names only the others.
    RecordResources(report);
    report.Description = "no cells: no piece file";
    return;
  }
  report.FileBytes = FileSize(piece);
  if (report.FileBytes <= 0)
  {
    throw Failure(context + ": the piece '" + piece + "' is missing or empty");
  }
  DescribeWrittenFile(piece, report);
}

//------------------------------------------------------------------------------------------------
// Material counts: cells per value of the "Material" cell array.

/// The cells per value of the cell array "Material" (of the surface: "OriginalMaterial").
std::map<long long, long long> CountCellsPerMaterial(vtkPointSet* mesh)
{
  std::map<long long, long long> counts;
  vtkDataArray* materials = mesh->GetCellData()->GetArray(
    vtkPolyData::SafeDownCast(mesh) ? "OriginalMaterial" : "Material");
  if (!materials)
  {
    return counts;
  }
  // The cells of a material come in runs: the last material's count is kept at hand.
  const vtkIdType count = materials->GetNumberOfTuples();
  long long lastMaterial = 0;
  long long* lastCount = nullptr;
  for (vtkIdType cell = 0; cell < count; ++cell)
  {
    const long long material = static_cast<long long>(materials->GetTuple1(cell));
    if (!lastCount || material != lastMaterial)
    {
      lastCount = &counts[material];
      lastMaterial = material;
    }
    ++*lastCount;
  }
  return counts;
}

/// The JSON key of the per-material counts names what is counted.
std::string MaterialCountKey(vtkPointSet* mesh, const Options& options, bool twoDimensional)
{
  if (options.StopAfter == StopStage::Spacetree || options.StopAfter == StopStage::Balance)
  {
    return "leaves_per_material";
  }
  if (options.WritesSurface())
  {
    // The facets of the surface per label of the cell they bound on the inside.
    return twoDimensional ? "lines_per_original_material" : "triangles_per_original_material";
  }
  if (options.Elements != stmSpacetreeTessellate::SIMPLICIAL)
  {
    return "cells_per_material"; // hybrid: several cell types; leaves: not the spacetree's
  }
  if (twoDimensional || (mesh->GetNumberOfCells() > 0 && mesh->GetCellType(0) == VTK_TRIANGLE))
  {
    return "triangles_per_material"; // a 2D image
  }
  return "tetrahedra_per_material";
}

//------------------------------------------------------------------------------------------------
// Tessellation statistics: cells per type and the volume share of the hexahedra (quads).

/// The names of the summary's cells_by_type, in this order; other types (none expected) by their
/// VTK type number.
const std::pair<int, const char*> CellTypeNames[] = { { VTK_TETRA, "tetra" },
  { VTK_PYRAMID, "pyramid" }, { VTK_HEXAHEDRON, "hexahedron" }, { VTK_TRIANGLE, "triangle" },
  { VTK_QUAD, "quad" } };

std::vector<std::pair<std::string, long long>> CountCellsByType(vtkUnstructuredGrid* grid)
{
  long long counts[256] = {};
  if (vtkUnsignedCharArray* types = grid->GetCellTypesArray())
  {
    const unsigned char* values = types->GetPointer(0);
    const vtkIdType count = types->GetNumberOfValues();
    for (vtkIdType cell = 0; cell < count; ++cell)
    {
      ++counts[values[cell]];
    }
  }
  std::vector<std::pair<std::string, long long>> present;
  for (const auto& entry : CellTypeNames)
  {
    if (counts[entry.first] > 0)
    {
      present.emplace_back(entry.second, counts[entry.first]);
      counts[entry.first] = 0;
    }
  }
  for (int type = 0; type < 256; ++type)
  {
    if (counts[type] > 0)
    {
      present.emplace_back("type_" + std::to_string(type), counts[type]);
    }
  }
  return present;
}

/// The measure (volume, or area of a 2D cell) of a tessellation cell given by its point ids in
/// VTK order. Every cell of the tessellation is the affine image of a lattice cell: hexahedra and
/// quads are parallelepipeds and parallelograms, pyramids have a parallelogram base, so the
/// measure follows from point 0 and its neighbours along the cell's edges, exactly.
template <class IdType, class PointFunction>
double CellMeasure(int type, const IdType* ids, const PointFunction& point)
{
  // Point 0 and its neighbours: 1 and 2 of a triangle or tetrahedron, 1 and the last base corner
  // (3) of a quad, pyramid or hexahedron, and the third edge (3 of a tetrahedron, 4 else).
  const bool simplex = type == VTK_TRIANGLE || type == VTK_TETRA;
  const bool solid = type == VTK_TETRA || type == VTK_PYRAMID || type == VTK_HEXAHEDRON;
  double p[4][3];
  point(ids[0], p[0]);
  point(ids[1], p[1]);
  point(ids[simplex ? 2 : 3], p[2]);
  if (solid)
  {
    point(ids[type == VTK_TETRA ? 3 : 4], p[3]);
  }
  double a[3], b[3], c[3];
  for (int k = 0; k < 3; ++k)
  {
    a[k] = p[1][k] - p[0][k];
    b[k] = p[2][k] - p[0][k];
    c[k] = solid ? p[3][k] - p[0][k] : 0.0;
  }
  const double cross[3] = { a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
    a[0] * b[1] - a[1] * b[0] };
  switch (type)
  {
    case VTK_TRIANGLE:
      return 0.5 * std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]);
    case VTK_QUAD:
      return std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]);
    case VTK_TETRA:
      return std::abs(cross[0] * c[0] + cross[1] * c[1] + cross[2] * c[2]) / 6.0;
    case VTK_PYRAMID:
      return std::abs(cross[0] * c[0] + cross[1] * c[1] + cross[2] * c[2]) / 3.0;
    case VTK_HEXAHEDRON:
      return std::abs(cross[0] * c[0] + cross[1] * c[1] + cross[2] * c[2]);
    default:
      return 0.0;
  }
}

/// Sums the measures of all cells and of the hexahedra and quads, in parallel over fixed blocks
/// of cells that are added up in order, so that the result does not depend on the threads.
template <class IdType, class PointFunction>
void SumMeasures(const IdType* offsets, const IdType* connectivity, const unsigned char* types,
  vtkIdType cells, const PointFunction& point, double& total, double& boxes)
{
  const vtkIdType blockSize = 1 << 16;
  const vtkIdType blocks = (cells + blockSize - 1) / blockSize;
  std::vector<double> blockTotals(static_cast<std::size_t>(blocks), 0.0);
  std::vector<double> blockBoxes(static_cast<std::size_t>(blocks), 0.0);
  vtkSMPTools::For(0, blocks,
    [&](vtkIdType beginBlock, vtkIdType endBlock)
    {
      for (vtkIdType block = beginBlock; block < endBlock; ++block)
      {
        double blockTotal = 0.0;
        double blockBox = 0.0;
        const vtkIdType end = std::min(cells, (block + 1) * blockSize);
        for (vtkIdType cell = block * blockSize; cell < end; ++cell)
        {
          const int type = types[cell];
          if (offsets[cell + 1] - offsets[cell] < 3)
          {
            continue;
          }
          const double measure = CellMeasure(type, connectivity + offsets[cell], point);
          blockTotal += measure;
          if (type == VTK_HEXAHEDRON || type == VTK_QUAD)
          {
            blockBox += measure;
          }
        }
        blockTotals[block] = blockTotal;
        blockBoxes[block] = blockBox;
      }
    });
  total = 0.0;
  boxes = 0.0;
  for (vtkIdType block = 0; block < blocks; ++block)
  {
    total += blockTotals[block];
    boxes += blockBoxes[block];
  }
}

/// Point coordinates, straight from the array when it is double (stmSpacetreeTessellate writes
/// double points), else through vtkPoints.
struct PointReader
{
  explicit PointReader(vtkPoints* points)
    : Points(points)
  {
    vtkDoubleArray* doubles = points ? vtkDoubleArray::FastDownCast(points->GetData()) : nullptr;
    this->Xyz = doubles ? doubles->GetPointer(0) : nullptr;
  }
  void operator()(vtkIdType id, double p[3]) const
  {
    if (this->Xyz)
    {
      std::copy(this->Xyz + 3 * id, this->Xyz + 3 * id + 3, p);
    }
    else
    {
      this->Points->GetPoint(id, p);
    }
  }
  vtkPoints* Points;
  const double* Xyz = nullptr;
};

/// The share of the mesh volume (area of a 2D mesh) in hexahedra (quads).
double HexahedronVolumeFraction(vtkUnstructuredGrid* grid)
{
  vtkPoints* points = grid->GetPoints();
  vtkCellArray* cellArray = grid->GetCells();
  vtkUnsignedCharArray* typeArray = grid->GetCellTypesArray();
  const vtkIdType cells = grid->GetNumberOfCells();
  if (!points || !cellArray || !typeArray || cells == 0)
  {
    return 0.0;
  }
  const unsigned char* types = typeArray->GetPointer(0);
  const PointReader point(points);
  double total = 0.0;
  double boxes = 0.0;
  if (cellArray->IsStorage64Bit())
  {
    SumMeasures(cellArray->GetOffsetsArray64()->GetPointer(0),
      cellArray->GetConnectivityArray64()->GetPointer(0), types, cells, point, total, boxes);
  }
  else
  {
    SumMeasures(cellArray->GetOffsetsArray32()->GetPointer(0),
      cellArray->GetConnectivityArray32()->GetPointer(0), types, cells, point, total, boxes);
  }
  return total > 0 ? boxes / total : 0.0;
}

//------------------------------------------------------------------------------------------------
// Report: the table on stdout and the JSON summary.

void PrintTable(const std::vector<StageReport>& stages, double totalSeconds)
{
  char line[256];
  std::snprintf(
    line, sizeof(line), "%-11s %9s  %-38s %12s\n", "stage", "seconds", "output", "peak RSS MiB");
  std::cout << line;
  for (const StageReport& stage : stages)
  {
    if (stage.Skipped)
    {
      std::snprintf(line, sizeof(line), "%-11s %9s  %-38s %12s\n", stage.Name.c_str(), "-",
        stage.Description.c_str(), "-");
    }
    else
    {
      std::snprintf(line, sizeof(line), "%-11s %9.3f  %-38s %12.1f\n", stage.Name.c_str(),
        stage.Seconds, stage.Description.c_str(), stage.PeakRssMiB);
    }
    std::cout << line;
  }
  std::snprintf(
    line, sizeof(line), "%-11s %9.3f  %-38s %12.1f\n", "total", totalSeconds, "", PeakRssMiB());
  std::cout << line;
  // The tessellation's figures below the table: cells per type, inserted points, and the
  // volume share of the hexahedra.
  for (const StageReport& stage : stages)
  {
    if (!stage.Tessellation || stage.Skipped)
    {
      continue;
    }
    std::cout << stage.Name << ":";
    const char* separator = " ";
    for (const auto& entry : stage.CellsByType)
    {
      std::cout << separator << entry.second << ' ' << entry.first;
      separator = ", ";
    }
    std::cout << "; " << stage.InsertedPoints << " inserted points";
    if (stage.HexahedronVolumeFraction >= 0)
    {
      std::cout << "; " << (stage.TwoDimensional ? "quad area" : "hexahedron volume")
                << " fraction " << std::fixed << std::setprecision(4)
                << stage.HexahedronVolumeFraction << std::defaultfloat;
    }
    if (stage.ShowBoundaryLayers)
    {
      std::cout << "; " << stage.BoundaryLayers << " boundary layer"
                << (stage.BoundaryLayers == 1 ? "" : "s");
    }
    std::cout << '\n';
  }
  // The snap's figures: snapped points and refused snaps.
  for (const StageReport& stage : stages)
  {
    if (stage.Snap && !stage.Skipped)
    {
      std::cout << stage.Name << ": " << stage.SnappedPoints << " snapped points, "
                << stage.RefusedSnaps << " refused snaps\n";
    }
  }
  // The cut's figures: split cells, cut points and the cells on each side.
  for (const StageReport& stage : stages)
  {
    if (!stage.Cut || stage.Skipped)
    {
      continue;
    }
    std::cout << stage.Name << ": " << stage.SplitCells << " split cells, " << stage.CutPoints
              << " cut points";
    if (stage.InsideCells >= 0)
    {
      std::cout << "; " << stage.InsideCells << " inside cells, " << stage.OutsideCells
                << " outside cells";
    }
    else
    {
      std::cout << "; a surface of " << stage.Cells << ' '
                << (stage.TwoDimensional ? "lines" : "triangles");
    }
    std::cout << '\n';
  }
  // The smoothing's figures: moved points, rejected moves, and the surface taken from it.
  for (const StageReport& stage : stages)
  {
    if (!stage.Smooth || stage.Skipped)
    {
      continue;
    }
    std::cout << stage.Name << ": " << stage.MovedPoints << " moved points, " << stage.RejectedMoves
              << " rejected moves";
    if (stage.ImprovedPoints > 0)
    {
      std::cout << ", " << stage.ImprovedPoints << " quality improvement moves";
    }
    if (stage.SplitEdges > 0)
    {
      std::cout << ", " << stage.SplitEdges << " split edges";
    }
    if (stage.KeptPoints > 0)
    {
      std::cout << ", " << stage.KeptPoints << " points kept for small parts";
    }
    if (stage.SurfaceCells >= 0)
    {
      std::cout << "; a surface of " << stage.SurfaceCells << ' '
                << (stage.TwoDimensional ? "lines" : "triangles");
    }
    std::cout << '\n';
  }
  std::cout.flush();
}

std::string JsonString(const std::string& text)
{
  std::string quoted = "\"";
  for (const char c : text)
  {
    switch (c)
    {
      case '"':
        quoted += "\\\"";
        break;
      case '\\':
        quoted += "\\\\";
        break;
      case '\n':
        quoted += "\\n";
        break;
      case '\t':
        quoted += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20)
        {
          char escaped[8];
          std::snprintf(escaped, sizeof(escaped), "\\u%04x", static_cast<unsigned char>(c));
          quoted += escaped;
        }
        else
        {
          quoted += c;
        }
    }
  }
  return quoted + "\"";
}

std::string JsonCount(long long value)
{
  return value < 0 ? std::string("null") : std::to_string(value);
}

/// A number as JSON: integers without a fraction, others with up to 10 significant digits.
std::string JsonNumber(double value)
{
  char text[32];
  if (value == std::floor(value) && std::abs(value) < 1e15)
  {
    std::snprintf(text, sizeof(text), "%.0f", value);
  }
  else
  {
    std::snprintf(text, sizeof(text), "%.10g", value);
  }
  return text;
}

/// The shortest text that reads back as the same double (1/3 is 0.3333333333333333).
std::string JsonShortestNumber(double value)
{
  char text[64];
  const std::to_chars_result result = std::to_chars(text, text + sizeof(text), value);
  return std::string(text, result.ptr);
}

template <class Number>
std::string JsonList(const std::vector<Number>& values)
{
  std::string text = "[";
  for (std::size_t i = 0; i < values.size(); ++i)
  {
    text += (i ? ", " : "") + JsonNumber(static_cast<double>(values[i]));
  }
  return text + "]";
}

/// {"3": 2, "7": 8}: values per label.
template <class Number>
std::string JsonLabelMap(const std::vector<std::pair<int, Number>>& entries)
{
  std::string text = "{";
  for (std::size_t i = 0; i < entries.size(); ++i)
  {
    text += (i ? ", " : "") + JsonString(std::to_string(entries[i].first)) + ": " +
      JsonNumber(static_cast<double>(entries[i].second));
  }
  return text + "}";
}

std::string JsonRegion(const RegionOption& region, bool balanceLevel)
{
  if (region.Type.empty())
  {
    return "null";
  }
  return "{\"type\": " + JsonString(region.Type) + ", \"values\": " + JsonList(region.Values) +
    (balanceLevel ? ", \"level\": " + std::to_string(region.Level)
                  : ", \"size\": " + JsonNumber(region.Size)) +
    "}";
}

/// The element shapes and the volume per material of a simplicial output mesh, measured with
/// the core's shape measures (Verdict's condition number, the true smallest dihedral angle).
struct MeshQuality
{
  bool Measured = false;
  long long Cells = 0;
  double WorstCondition = 0.0;
  double SmallestDihedral = 180.0;
  long long InvertedCells = 0;
  std::map<long long, double> VolumePerMaterial;
};

/// Tetrahedra, or triangles of a 2D mesh in the z = const plane; nothing for other outputs.
MeshQuality MeasureMeshQuality(vtkPointSet* mesh)
{
  MeshQuality quality;
  auto* grid = vtkUnstructuredGrid::SafeDownCast(mesh);
  if (!grid || grid->GetNumberOfCells() == 0)
  {
    return quality;
  }
  vtkCellArray* cells = grid->GetCells();
  const vtkIdType numberOfCells = grid->GetNumberOfCells();
  const int corners = cells->IsHomogeneous();
  const int firstType = grid->GetCellType(0);
  if (!((corners == 4 && firstType == VTK_TETRA) || (corners == 3 && firstType == VTK_TRIANGLE)))
  {
    return quality;
  }
  vtkDataArray* materials = grid->GetCellData()->GetArray("Material");
  // Triangles are measured in their plane, which need not be z = constant (an image of one
  // voxel along x or y is meshed in its own plane): in an orthonormal frame (u, v) with u x v
  // the mesh's normal, the sum of the triangles' area vectors. A triangle is inverted when it
  // turns against the mesh's orientation.
  double frame[2][3] = { { 1, 0, 0 }, { 0, 1, 0 } };
  if (corners == 3)
  {
    double normal[3] = { 0, 0, 0 };
    vtkNew<vtkIdList> ids;
    for (vtkIdType cell = 0; cell < numberOfCells; ++cell)
    {
      cells->GetCellAtId(cell, ids);
      double a[3], b[3], c[3], ab[3], ac[3], n[3];
      grid->GetPoint(ids->GetId(0), a);
      grid->GetPoint(ids->GetId(1), b);
      grid->GetPoint(ids->GetId(2), c);
      vtkMath::Subtract(b, a, ab);
      vtkMath::Subtract(c, a, ac);
      vtkMath::Cross(ab, ac, n);
      vtkMath::Add(normal, n, normal);
    }
    if (vtkMath::Normalize(normal) > 0.0)
    {
      // u: the axis least aligned with the normal, made orthogonal to it.
      int least = 0;
      for (int k = 1; k < 3; ++k)
      {
        least = std::abs(normal[k]) < std::abs(normal[least]) ? k : least;
      }
      double axis[3] = { 0, 0, 0 };
      axis[least] = 1.0;
      vtkMath::Cross(axis, normal, frame[0]);
      vtkMath::Normalize(frame[0]);
      vtkMath::Cross(normal, frame[0], frame[1]);
    }
  }
  // The smallest dihedral angle is the angle of the largest cosine (DihedralDegrees is
  // monotone): one acos per thread instead of one per cell. The cells of a material come in
  // runs, so the volume of the last material is kept at hand instead of looked up per cell.
  struct Partial
  {
    double Worst = 0.0;
    double LargestCosine = -1.0;
    long long Inverted = 0;
    std::map<long long, double> Volumes;
    long long LastMaterial = 0;
    double* LastVolume = nullptr;
  };
  vtkSMPThreadLocal<Partial> partials;
  // Double coordinates (what the pipeline makes) are read in place, others through GetPoint.
  vtkDoubleArray* doubleCoordinates = vtkDoubleArray::SafeDownCast(grid->GetPoints()->GetData());
  const double* xyz = doubleCoordinates ? doubleCoordinates->GetPointer(0) : nullptr;
  vtkSMPTools::For(0, numberOfCells,
    [&](vtkIdType begin, vtkIdType end)
    {
      Partial& partial = partials.Local();
      vtkNew<vtkIdList> ids;
      double coordinates[4][3];
      for (vtkIdType cell = begin; cell < end; ++cell)
      {
        vtkIdType cornerCount = 0;
        const vtkIdType* cornerIds = nullptr;
        cells->GetCellAtId(cell, cornerCount, cornerIds, ids);
        for (int v = 0; v < corners; ++v)
        {
          if (xyz)
          {
            std::copy_n(xyz + 3 * cornerIds[v], 3, coordinates[v]);
          }
          else
          {
            grid->GetPoint(cornerIds[v], coordinates[v]);
          }
        }
        double measure = 0.0;
        double condition = 0.0, cosine = 1.0;
        if (corners == 4)
        {
          const double* pointers[4] = { coordinates[0], coordinates[1], coordinates[2],
            coordinates[3] };
          const auto shape = stm::MeasureSimplexCosines<3>(pointers);
          measure = shape.Determinant / 6.0;
          condition = shape.Condition;
          cosine = shape.LargestDihedralCosine;
        }
        else
        {
          double planar[3][2];
          for (int v = 0; v < 3; ++v)
          {
            planar[v][0] = vtkMath::Dot(coordinates[v], frame[0]);
            planar[v][1] = vtkMath::Dot(coordinates[v], frame[1]);
          }
          const double* pointers[3] = { planar[0], planar[1], planar[2] };
          const auto shape = stm::MeasureSimplexCosines<2>(pointers);
          measure = shape.Determinant / 2.0;
          condition = shape.Condition;
          cosine = shape.LargestDihedralCosine;
        }
        partial.Inverted += measure > 0.0 ? 0 : 1;
        partial.Worst = std::max(partial.Worst, condition);
        partial.LargestCosine = std::max(partial.LargestCosine, cosine);
        const long long material =
          materials ? static_cast<long long>(materials->GetComponent(cell, 0)) : 0;
        if (!partial.LastVolume || material != partial.LastMaterial)
        {
          partial.LastVolume = &partial.Volumes[material];
          partial.LastMaterial = material;
        }
        *partial.LastVolume += measure;
      }
    });
  quality.Measured = true;
  quality.Cells = numberOfCells;
  for (const Partial& partial : partials)
  {
    quality.WorstCondition = std::max(quality.WorstCondition, partial.Worst);
    quality.SmallestDihedral =
      std::min(quality.SmallestDihedral, stm::DihedralDegrees(partial.LargestCosine));
    quality.InvertedCells += partial.Inverted;
    for (const auto& entry : partial.Volumes)
    {
      quality.VolumePerMaterial[entry.first] += entry.second;
    }
  }
  return quality;
}

/// The structure report of one material: the image's voxels that map to it, the mesh's volume of
/// it, and the image's connected components of it, of which the lost ones have no tested voxel
/// centre in a cell of the material.
struct MaterialReport
{
  long long Material = 0;
  long long Voxels = 0;
  double VoxelVolume = 0.0;
  double MeshVolume = 0.0;
  long long Components = 0;
  long long LostComponents = 0;
};

/// One lost component: its material, its size and its first voxel in memory order (i, j, k).
struct LostComponent
{
  long long Material = 0;
  long long Voxels = 0;
  int FirstVoxel[3] = { 0, 0, 0 };
};

struct StructureReport
{
  bool Made = false; // false for surface output: "materials": null
  std::vector<MaterialReport> Materials;
  std::vector<LostComponent> Lost; // in the order of their first voxels
  double Seconds = 0.0;
};

/// What each rank tells rank 0 once its piece is meshed.
struct RankFigures
{
  double Seconds = 0.0;
  long long Cells = 0; // its own cells, without ghosts
  long long Points = 0;
  double PeakRssMiB = 0.0;
  long long VoxelsRead = 0; // of the label image
};

struct RunSummary
{
  MeshQuality Quality;
  StructureReport Structure;
  std::string Input;
  std::string Output;
  bool DroppedBackground = false; // the cells of Material 0 left out of the output
  bool DefaultInput = false;
  ImageInfo Image;
  ThreadSetup Threads;
  stmesh::MemoryPolicy Memory;
  std::vector<StageReport> Stages;
  long long MinorFaultsAtStart = -1; // when the run began, after the libraries were loaded
  double TotalSeconds = 0.0;
  std::string MaterialKey;
  std::map<long long, long long> CellsPerMaterial;
  LevelTable Levels;
  int Ranks = 1;
  std::vector<RankFigures> RankTable; // rank 0's list of every rank, with several ranks
};

void WriteSummary(const std::string& path, const Options& options, const RunSummary& summary)
{
  std::ostringstream json;
  json << std::fixed;
  json << "{\n";
  json << "  \"program\": \"stmesh\",\n";
  json << "  \"version\": " << JsonString(STMESH_VERSION) << ",\n";
  json << "  \"input\": " << JsonString(summary.Input) << ",\n";
  json << "  \"default_input\": " << (summary.DefaultInput ? "true" : "false") << ",\n";
  json << "  \"input_format\": " << JsonString(summary.Image.Format) << ",\n";
  json << "  \"output\": " << JsonString(summary.Output) << ",\n";
  json << "  \"image\": {\"dimensions\": [" << summary.Image.Dimensions[0] << ", "
       << summary.Image.Dimensions[1] << ", " << summary.Image.Dimensions[2] << "], \"spacing\": ["
       << std::setprecision(6) << summary.Image.Spacing[0] << ", " << summary.Image.Spacing[1]
       << ", " << summary.Image.Spacing[2]
       << "], \"scalar_type\": " << JsonString(summary.Image.ScalarType) << "},\n";
  json << "  \"parameters\": {\"labels\": [";
  for (std::size_t i = 0; i < options.Labels.size(); ++i)
  {
    json << (i ? ", " : "") << options.Labels[i];
  }
  json << "], \"all_labels\": " << (options.Labels.empty() ? "true" : "false")
       << ", \"max_cell_size\": " << options.MaxCellSize
       << ", \"balance\": " << options.BalanceLevel
       << ", \"stop_after\": " << JsonString(StopStageName(options.StopAfter))
       << ", \"elements\": " << JsonString(KeywordName(options.Elements, ElementKinds))
       << ", \"templates\": " << JsonString(KeywordName(options.TemplateRule, TemplateRules))
       << ", \"cell_template\": " << JsonString(KeywordName(options.CellTemplate, CellTemplates))
       << ", \"boundary_layers\": " << options.BoundaryLayers
       << ", \"compressor\": " << JsonString(options.Compressor)
       << ", \"background\": " << JsonString(summary.DroppedBackground ? "drop" : "keep")
       << ", \"msh_format\": " << JsonString(options.BinaryMsh ? "binary" : "ascii")
       << ", \"pattern\": " << JsonString(options.Pattern) << ", \"root_cell_size\": "
       << (options.RootCellSize.empty() ? "null" : JsonList(options.RootCellSize))
       << ", \"max_cell_size_labels\": " << JsonLabelMap(options.LabelMaxCellSizes)
       << ", \"refine_region\": " << JsonRegion(options.RefineRegion, false)
       << ", \"grading\": " << (options.Grading > 0 ? JsonNumber(options.Grading) : "null")
       << ", \"sizing_array\": "
       << (options.SizingArray.empty() ? "null" : JsonString(options.SizingArray))
       << ", \"balance_labels\": " << JsonLabelMap(options.LabelBalanceLevels)
       << ", \"balance_region\": " << JsonRegion(options.BalanceRegion, true)
       << ", \"separating\": " << JsonString(options.Separating.Text)
       << ", \"materials\": " << JsonString(options.SeparateMaterials ? "separate" : "merged")
       << ", \"thin_parts\": " << JsonString(options.RefineThinParts ? "refine" : "ignore")
       << ", \"output_mode\": " << JsonString(KeywordName(options.OutputMode, OutputModes))
       << ", \"keep\": " << JsonString(KeywordName(options.KeepSide, KeptSides))
       << ", \"iso\": " << JsonNumber(options.IsoValue)
       << ", \"alpha\": " << JsonShortestNumber(options.Alpha)
       << ", \"snap\": " << JsonString(KeywordName(options.SnapRule, SnapRules))
       << ", \"smooth_iterations\": " << options.SmoothIterations
       << ", \"smooth_method\": " << JsonString(KeywordName(options.SmoothMethod, SmoothMethods))
       << ", \"merge\": [";
  for (std::size_t i = 0; i < options.Merges.size(); ++i)
  {
    json << (i ? ", " : "") << "{\"sources\": " << JsonList(options.Merges[i].Sources)
         << ", \"target\": " << options.Merges[i].Target << "}";
  }
  json << "], \"min_component_voxels\": " << options.MinComponentVoxels << ", \"interfaces\": "
       << (options.Interfaces.empty() ? std::string("null") : JsonString(options.Interfaces))
       << "},\n";
  json << "  \"threads\": " << summary.Threads.Threads << ",\n";
  json << "  \"smp_backend\": " << JsonString(summary.Threads.Backend) << ",\n";
  // Recorded because the allocator's settings change the run time by a third on virtual
  // machines (docs/performance.md, "Page faults on this virtual machine").
  const char* mallocTunables = std::getenv("GLIBC_TUNABLES");
  json << "  \"malloc_tunables\": " << JsonString(mallocTunables ? mallocTunables : "") << ",\n";
  json << "  \"keep_memory\": {\"option\": "
       << JsonString(stmesh::KeepMemoryOptionName(options.KeepMemory))
       << ", \"kept\": " << (summary.Memory.Keep ? "true" : "false")
       << ", \"reason\": " << JsonString(summary.Memory.Reason) << "},\n";
  // The spacetree's levels: cell edges in voxels per level, root first, along the image axes the
  // spacetree spans; fractional below the voxel (voxel_subdivision lattice units per voxel).
  const LevelTable& levels = summary.Levels;
  json << "  \"spacetree_axes\": " << (levels.Present ? JsonList(levels.ImageAxes) : "null")
       << ",\n";
  json << "  \"voxel_subdivision\": "
       << (levels.Present ? JsonList(levels.VoxelSubdivision) : "null") << ",\n";
  json << "  \"cell_sizes_voxels\": ";
  if (levels.Present)
  {
    json << "[";
    for (std::size_t level = 0; level < levels.CellSizes.size(); ++level)
    {
      std::vector<double> voxels;
      for (std::size_t axis = 0; axis < levels.CellSizes[level].size(); ++axis)
      {
        voxels.push_back(static_cast<double>(levels.CellSizes[level][axis]) /
          static_cast<double>(levels.VoxelSubdivision[axis]));
      }
      json << (level ? ", " : "") << JsonList(voxels);
    }
    json << "],\n";
  }
  else
  {
    json << "null,\n";
  }
  json << "  \"stages\": [\n";
  long long faultsBefore = summary.MinorFaultsAtStart;
  for (std::size_t i = 0; i < summary.Stages.size(); ++i)
  {
    const StageReport& stage = summary.Stages[i];
    const bool faultsKnown = stage.MinorFaultsAtEnd >= 0 && faultsBefore >= 0;
    json << "    {\"name\": " << JsonString(stage.Name)
         << ", \"skipped\": " << (stage.Skipped ? "true" : "false")
         << ", \"seconds\": " << std::setprecision(6) << stage.Seconds
         << ", \"cells\": " << JsonCount(stage.Cells) << ", \"points\": " << JsonCount(stage.Points)
         << ", \"leaves\": " << JsonCount(stage.Leaves)
         << ", \"file_bytes\": " << JsonCount(stage.FileBytes)
         << ", \"peak_rss_mib\": " << std::setprecision(3) << stage.PeakRssMiB
         << ", \"minor_page_faults\": "
         << JsonCount(faultsKnown ? stage.MinorFaultsAtEnd - faultsBefore : -1);
    if (stage.MinorFaultsAtEnd >= 0)
    {
      faultsBefore = stage.MinorFaultsAtEnd;
    }
    if (stage.ThinVoxels >= 0)
    {
      json << ", \"thin_voxels\": " << stage.ThinVoxels;
    }
    if (stage.Tessellation)
    {
      json << ", \"inserted_points\": " << JsonCount(stage.InsertedPoints)
           << ", \"cells_by_type\": {";
      for (std::size_t t = 0; t < stage.CellsByType.size(); ++t)
      {
        json << (t ? ", " : "") << JsonString(stage.CellsByType[t].first) << ": "
             << stage.CellsByType[t].second;
      }
      json << "}";
      if (stage.HexahedronVolumeFraction >= 0)
      {
        json << ", \"hexahedron_volume_fraction\": " << JsonNumber(stage.HexahedronVolumeFraction);
      }
      json << ", \"boundary_layers\": " << stage.BoundaryLayers;
    }
    if (stage.Cut)
    {
      json << ", \"split_cells\": " << JsonCount(stage.SplitCells)
           << ", \"cut_points\": " << JsonCount(stage.CutPoints);
      if (stage.InsideCells >= 0)
      {
        json << ", \"inside_cells\": " << stage.InsideCells
             << ", \"outside_cells\": " << stage.OutsideCells;
      }
    }
    if (stage.Snap)
    {
      json << ", \"snapped_points\": " << JsonCount(stage.SnappedPoints)
           << ", \"refused_snaps\": " << JsonCount(stage.RefusedSnaps);
    }
    if (stage.Smooth)
    {
      json << ", \"moved_points\": " << JsonCount(stage.MovedPoints)
           << ", \"rejected_moves\": " << JsonCount(stage.RejectedMoves)
           << ", \"improved_points\": " << JsonCount(stage.ImprovedPoints)
           << ", \"split_edges\": " << JsonCount(stage.SplitEdges)
           << ", \"kept_points\": " << JsonCount(stage.KeptPoints);
      if (stage.SurfaceCells >= 0)
      {
        json << ", \"surface_cells\": " << stage.SurfaceCells;
      }
    }
    json << "}" << (i + 1 < summary.Stages.size() ? "," : "") << "\n";
  }
  json << "  ],\n";
  if (summary.Quality.Measured)
  {
    // An inverted cell has an infinite condition number, which JSON cannot hold.
    const double worst = summary.Quality.WorstCondition;
    json << "  \"quality\": {\"worst_condition\": "
         << (std::isfinite(worst) ? JsonNumber(worst) : std::string("null"))
         << ", \"smallest_dihedral_degrees\": " << JsonNumber(summary.Quality.SmallestDihedral)
         << ", \"inverted_cells\": " << summary.Quality.InvertedCells
         << ", \"volume_per_material\": {";
    const char* separator = "";
    for (const auto& entry : summary.Quality.VolumePerMaterial)
    {
      json << separator << JsonString(std::to_string(entry.first)) << ": "
           << JsonNumber(entry.second);
      separator = ", ";
    }
    json << "}},\n";
  }
  json << "  \"materials\": ";
  if (summary.Structure.Made)
  {
    json << "[";
    const char* separator = "\n";
    for (const MaterialReport& entry : summary.Structure.Materials)
    {
      json << separator << "    {\"material\": " << entry.Material
           << ", \"voxels\": " << entry.Voxels
           << ", \"voxel_volume\": " << JsonShortestNumber(entry.VoxelVolume)
           << ", \"mesh_volume\": " << JsonShortestNumber(entry.MeshVolume)
           << ", \"volume_error\": "
           << (entry.Voxels > 0
                  ? JsonShortestNumber((entry.MeshVolume - entry.VoxelVolume) / entry.VoxelVolume)
                  : std::string("null"))
           << ", \"image_components\": " << entry.Components
           << ", \"lost_components\": " << entry.LostComponents << "}";
      separator = ",\n";
    }
    json << (summary.Structure.Materials.empty() ? "],\n" : "\n  ],\n");
    json << "  \"lost_components\": [";
    separator = "\n";
    for (const LostComponent& entry : summary.Structure.Lost)
    {
      json << separator << "    {\"material\": " << entry.Material
           << ", \"voxels\": " << entry.Voxels << ", \"first_voxel\": [" << entry.FirstVoxel[0]
           << ", " << entry.FirstVoxel[1] << ", " << entry.FirstVoxel[2] << "]}";
      separator = ",\n";
    }
    json << (summary.Structure.Lost.empty() ? "],\n" : "\n  ],\n");
    json << "  \"report_seconds\": " << std::setprecision(6) << summary.Structure.Seconds << ",\n";
  }
  else
  {
    json << "null,\n";
  }
  json << "  \"total_seconds\": " << std::setprecision(6) << summary.TotalSeconds << ",\n";
  json << "  \"ranks\": " << summary.Ranks << ",\n";
  if (!summary.RankTable.empty())
  {
    // Each rank's meshing, until its piece was gathered or written.
    json << "  \"rank_figures\": [";
    for (std::size_t rank = 0; rank < summary.RankTable.size(); ++rank)
    {
      const RankFigures& figures = summary.RankTable[rank];
      json << (rank ? ",\n    " : "\n    ") << "{\"seconds\": " << std::setprecision(6)
           << figures.Seconds << ", \"cells\": " << figures.Cells
           << ", \"points\": " << figures.Points << ", \"peak_rss_mib\": " << std::setprecision(3)
           << figures.PeakRssMiB << ", \"voxels_read\": " << figures.VoxelsRead << "}";
    }
    json << "\n  ],\n";
  }
  json << "  \"peak_rss_mib\": " << std::setprecision(3) << PeakRssMiB() << ",\n";
  json << "  " << JsonString(summary.MaterialKey) << ": {";
  bool first = true;
  for (const auto& entry : summary.CellsPerMaterial)
  {
    json << (first ? "" : ", ") << JsonString(std::to_string(entry.first)) << ": " << entry.second;
    first = false;
  }
  json << "}\n";
  json << "}\n";

  TemporaryFile temporary(path);
  {
    std::ofstream file(temporary.GetPath(), std::ios::out | std::ios::trunc);
    file << json.str();
    file.close();
    if (!file)
    {
      throw Failure("cannot write summary '" + path + "': " + std::strerror(errno));
    }
  }
  temporary.Commit();
}

//------------------------------------------------------------------------------------------------

/// The default output: the input's base name without its image extension, plus ".vtu" (".vtp"
/// for the cut's surface), in the current directory.
std::string DefaultOutputName(const std::string& input, bool surface)
{
  std::string name = FileName(input);
  if (const ImageFormatInfo* format = FindImageFormat(input))
  {
    name.resize(name.size() - std::strlen(format->Extension));
  }
  return name + (surface ? ".vtp" : ".vtu");
}

/// --output-mode, --keep and --iso only act on the cut stage, and --keep only on volume output:
/// say so when they are given but have no effect.
void WarnAboutIgnoredCutOptions(const Options& options)
{
  // The labels' functions go into the tessellation; the gray image and the sphere only into
  // the cut.
  const SeparatingKind kind = options.Separating.Kind;
  const bool separates = kind != SeparatingKind::None;
  if (options.SeparatingGiven && separates &&
    (options.StopAfter == StopStage::Spacetree || options.StopAfter == StopStage::Balance ||
      (options.StopAfter == StopStage::Tessellate &&
        (kind == SeparatingKind::Gray || kind == SeparatingKind::Sphere))))
  {
    Diagnostics() << "stmesh: warning: --separating " << options.Separating.Text
                  << " is ignored with --stop-after " << StopStageName(options.StopAfter)
                  << (options.StopAfter == StopStage::Tessellate
                         ? " (the tessellation carries the labels' function)"
                         : "")
                  << '\n';
  }
  const std::string ignoredWith = separates
    ? "with --stop-after " + std::string(StopStageName(options.StopAfter))
    : std::string("with --separating none");
  for (const std::string& name : options.CutOnlyOptions)
  {
    // The snap stage also moves points onto f = iso.
    const bool used = options.Cuts() || (name == "--iso" && options.Snaps());
    if (!used)
    {
      Diagnostics() << "stmesh: warning: " << name << " applies to the cut stage only; ignored "
                    << ignoredWith << '\n';
    }
    else if (name == "--keep" && options.WritesSurface())
    {
      Diagnostics() << "stmesh: warning: --keep applies to volume output only; ignored with "
                       "--output-mode surface\n";
    }
  }
  if (options.ThinPartsGiven && options.RefineThinParts &&
    (!options.Cuts() || options.Separating.Kind != SeparatingKind::Labels))
  {
    Diagnostics() << "stmesh: warning: --thin-parts applies to a cut at the labels function "
                     "only; ignored "
                  << (options.Cuts() ? "with --separating " + options.Separating.Text : ignoredWith)
                  << '\n';
  }
  if (options.SeparateMaterials && !options.Cuts())
  {
    Diagnostics() << "stmesh: warning: --materials applies to the cut stage only; ignored "
                  << ignoredWith << " (the staircase keeps every label)\n";
  }
  for (const std::string& name : options.SnapOnlyOptions)
  {
    if (!options.ReachesSnap())
    {
      Diagnostics() << "stmesh: warning: " << name << " applies to the snap stage only; ignored "
                    << ignoredWith << '\n';
    }
    else if (options.SeparateMaterials && options.SnapRule != NoSnap)
    {
      Diagnostics() << "stmesh: warning: " << name
                    << " is ignored with --materials separate, which snaps by the quality rule "
                       "in its cut stage (--snap none turns snapping off)\n";
    }
    else if (name == "--alpha" && options.SnapRule != stmVertexSnap::THRESHOLD)
    {
      // The quality-driven rule weighs every cut edge's nearer end by the elements it makes.
      Diagnostics() << "stmesh: warning: --alpha is ignored with --snap "
                    << KeywordName(options.SnapRule, SnapRules) << '\n';
    }
  }
  if (options.MinComponentVoxelsGiven && options.WritesSurface())
  {
    Diagnostics() << "stmesh: warning: --min-component-voxels applies to the structure report of "
                     "volume output only; ignored with --output-mode surface\n";
  }
  for (const std::string& name : options.SmoothOnlyOptions)
  {
    if (!options.ReachesSmooth())
    {
      Diagnostics() << "stmesh: warning: " << name << " applies to the smooth stage only; ignored "
                    << ignoredWith << '\n';
    }
    else if (name == "--smooth-method" && options.SmoothIterations == 0)
    {
      Diagnostics() << "stmesh: warning: --smooth-method is ignored with --smooth-iterations 0\n";
    }
  }
}

/// The "Material" of the cut's inside cells: the body label if --labels gives exactly one, else 1.
int InsideMaterial(const Options& options)
{
  return options.Labels.size() == 1 ? options.Labels[0] : 1;
}

/// What --separating gray and sphere give the snap stage besides the function values: the
/// function whose gradient moves points onto the surface.
struct SeparatingSource
{
  vtkSmartPointer<vtkSphere> Sphere;
  vtkSmartPointer<vtkImageData> Gray;
  /// Under MPI the gray image's reader instead, of which the stages ask for the voxels around
  /// their piece's points.
  vtkSmartPointer<vtkAlgorithm> GrayReader;
};

/// stmSeparatingFunction for --separating gray and sphere (the gray image is read here); the
/// labels' functions come with the tessellation, which is returned unchanged.
vtkSmartPointer<vtkUnstructuredGrid> ApplySeparatingFunction(
  vtkSmartPointer<vtkUnstructuredGrid> grid, const Options& options, SeparatingSource& source,
  StageReport& report)
{
  const SeparatingOption& separating = options.Separating;
  if (separating.Kind != SeparatingKind::Gray && separating.Kind != SeparatingKind::Sphere)
  {
    return grid;
  }
  vtkNew<stmSeparatingFunction> function;
  if (separating.Kind == SeparatingKind::Sphere)
  {
    source.Sphere = vtkSmartPointer<vtkSphere>::New();
    source.Sphere->SetCenter(separating.Sphere[0], separating.Sphere[1], separating.Sphere[2]);
    source.Sphere->SetRadius(separating.Sphere[3]);
    function->SetMode(stmSeparatingFunction::IMPLICIT_FUNCTION);
    function->SetImplicitFunction(source.Sphere);
  }
  else
  {
    ImageInfo grayInfo;
    StageReport grayReport;
    if (CurrentPiece.Pieces > 1)
    {
      source.GrayReader =
        stmesh::OpenImage(separating.GrayImage, ImageRole::Gray, grayInfo, grayReport.Seconds)
          .Reader;
      function->SetInputConnection(1, source.GrayReader->GetOutputPort());
    }
    else
    {
      source.Gray = ReadImage(separating.GrayImage, grayInfo, grayReport, false);
      function->SetInputDataObject(1, source.Gray);
    }
    report.Seconds += grayReport.Seconds;
    function->SetMode(stmSeparatingFunction::GRAY_IMAGE);
    function->SetThreshold(separating.GrayIso);
    function->SetInsideAboveThreshold(true);
  }
  vtkSmartPointer<vtkUnstructuredGrid> withFunction = vtkUnstructuredGrid::SafeDownCast(
    RunFilter(function, grid, "computing the separating function", report));
  if (!withFunction)
  {
    throw Failure("computing the separating function: the filter produced no mesh");
  }
  function->SetInputDataObject(1, nullptr);
  return withFunction;
}

/// The snap stage (paper, section 3.3): stmVertexSnap moves the points next to the surface onto
/// it, along the cut edge for the labels' functions (which are only known at the points) and
/// along the gradient of the sphere or the gray image, which are known everywhere.
vtkSmartPointer<vtkUnstructuredGrid> RunSnap(vtkSmartPointer<vtkUnstructuredGrid> grid,
  const Options& options, const SeparatingSource& source, StageReport& report)
{
  vtkNew<stmVertexSnap> snap;
  snap->SetAlpha(options.Alpha);
  snap->SetSnapRule(options.SnapRule);
  snap->SetIsoValue(options.IsoValue);
  vtkNew<vtkTrivialProducer> grayProducer;
  if (source.Sphere)
  {
    snap->SetProjection(stmVertexSnap::FUNCTION);
    snap->SetImplicitFunction(source.Sphere);
  }
  else if (source.Gray || source.GrayReader)
  {
    if (source.Gray)
    {
      grayProducer->SetOutput(source.Gray);
    }
    snap->SetProjection(stmVertexSnap::FUNCTION);
    snap->SetGrayImageConnection(
      source.GrayReader ? source.GrayReader->GetOutputPort() : grayProducer->GetOutputPort());
    snap->SetThreshold(options.Separating.GrayIso);
    snap->SetInsideAboveThreshold(true); // as stmSeparatingFunction above
  }
  else
  {
    snap->SetProjection(stmVertexSnap::EDGE);
  }
  vtkSmartPointer<vtkUnstructuredGrid> snapped =
    RunStage(snap, grid, "snapping points to the separating surface", report, false);
  report.Snap = true;
  report.SnappedPoints = static_cast<long long>(snap->GetNumberOfSnappedPoints());
  report.RefusedSnaps = static_cast<long long>(snap->GetNumberOfRefusedSnaps());
  return snapped;
}

/// The mesh's "Material" for a second stmMarchingSimplices run on an already cut mesh: the
/// labels ("OriginalMaterial"), so that this run keeps them as its "OriginalMaterial". The
/// all-zero cells, the only ones whose side comes from "Material", get the same side from the
/// labels as in the first run, which read the same labels.
vtkSmartPointer<vtkUnstructuredGrid> WithLabelsAsMaterial(vtkUnstructuredGrid* grid)
{
  vtkSmartPointer<vtkUnstructuredGrid> copy = vtkSmartPointer<vtkUnstructuredGrid>::New();
  copy->ShallowCopy(grid);
  vtkDataArray* labels = grid->GetCellData()->GetArray("OriginalMaterial");
  if (!labels)
  {
    return copy;
  }
  vtkSmartPointer<vtkDataArray> material =
    vtkSmartPointer<vtkDataArray>::Take(labels->NewInstance());
  material->ShallowCopy(labels);
  material->SetName("Material");
  copy->GetCellData()->RemoveArray("OriginalMaterial");
  copy->GetCellData()->RemoveArray("Material");
  copy->GetCellData()->AddArray(material);
  return copy;
}

/// The cut stage of --materials separate: stmMultiMaterialCut, every label its own material,
/// the background (0) peeled last, snapping before each material unless --snap none. The
/// inside cells are those of the body's labels.
vtkSmartPointer<vtkPointSet> RunMultiMaterialCut(
  vtkSmartPointer<vtkUnstructuredGrid> grid, const Options& options, StageReport& report)
{
  vtkNew<stmMultiMaterialCut> cut;
  cut->SetBackgroundMaterial(0);
  cut->SetVertexSnapping(options.SnapRule != NoSnap);
  vtkSmartPointer<vtkPointSet> mesh =
    RunFilter(cut, grid, "cutting the mesh at the material interfaces", report);
  grid = nullptr;
  report.Cut = true;
  report.SplitCells = static_cast<long long>(cut->GetNumberOfSplitCells());
  report.CutPoints = static_cast<long long>(cut->GetNumberOfCutPoints());
  report.InsideCells = 0;
  report.OutsideCells = 0;
  if (vtkDataArray* materials = mesh->GetCellData()->GetArray("Material"))
  {
    for (vtkIdType cell = 0; cell < materials->GetNumberOfTuples(); ++cell)
    {
      ++(materials->GetTuple1(cell) != 0 ? report.InsideCells : report.OutsideCells);
    }
  }
  std::ostringstream description;
  description << report.Cells << " cells, " << report.Points << " points, "
              << cut->GetNumberOfMaterials() << " materials";
  if (cut->GetVertexSnapping())
  {
    description << ", " << cut->GetNumberOfSnappedPoints() << " snaps";
  }
  report.Description = description.str();
  return mesh;
}

/// The cut stage: stmMarchingSimplices. With a smooth stage after it, the cut keeps both sides
/// in volume mode, and the side (--keep) or the surface is taken after smoothing.
vtkSmartPointer<vtkPointSet> RunCut(
  vtkSmartPointer<vtkUnstructuredGrid> grid, const Options& options, StageReport& report)
{
  if (options.SeparateMaterials)
  {
    return RunMultiMaterialCut(std::move(grid), options, report);
  }
  const bool smoothingFollows = options.Smooths();
  const int outputMode = smoothingFollows ? stmMarchingSimplices::VOLUME : options.OutputMode;
  const int keepSide = smoothingFollows ? stmMarchingSimplices::BOTH : options.KeepSide;
  vtkNew<stmMarchingSimplices> cut;
  cut->SetOutputMode(outputMode);
  cut->SetKeepSide(keepSide);
  cut->SetIsoValue(options.IsoValue);
  cut->SetInsideMaterial(InsideMaterial(options));
  cut->SetOutsideMaterial(0); // the background label
  vtkSmartPointer<vtkPointSet> mesh = RunFilter(cut, grid, "cutting the mesh", report);
  grid = nullptr;
  report.Cut = true;
  report.SplitCells = static_cast<long long>(cut->GetNumberOfSplitCells());
  report.CutPoints = static_cast<long long>(cut->GetNumberOfCutPoints());
  if (outputMode == stmMarchingSimplices::VOLUME)
  {
    report.InsideCells = 0;
    report.OutsideCells = 0;
    if (vtkDataArray* materials = mesh->GetCellData()->GetArray("Material"))
    {
      const double inside = InsideMaterial(options);
      for (vtkIdType cell = 0; cell < materials->GetNumberOfTuples(); ++cell)
      {
        ++(materials->GetTuple1(cell) == inside ? report.InsideCells : report.OutsideCells);
      }
    }
  }
  std::ostringstream description;
  description << report.Cells << " cells, " << report.Points << " points";
  report.Description = description.str();
  // An empty side usually means a sphere or an iso-value that misses the body. Under MPI a
  // piece may lack a side (a small body on many ranks): the sides of all pieces count, and
  // rank 0 warns.
  long long counts[3] = { report.Cells, report.InsideCells, report.OutsideCells };
  if (CurrentPiece.Pieces > 1)
  {
    const long long mine[3] = { counts[0], counts[1], counts[2] };
    vtkMultiProcessController::GetGlobalController()->AllReduce(
      mine, counts, 3, vtkCommunicator::SUM_OP);
    if (CurrentPiece.Piece != 0)
    {
      return mesh;
    }
  }
  std::string emptiness;
  if (outputMode == stmMarchingSimplices::SURFACE && counts[0] == 0)
  {
    emptiness = "does not cross the mesh: the surface is empty";
  }
  else if (counts[1] == 0 && options.KeepSide != stmMarchingSimplices::OUTSIDE)
  {
    emptiness = "encloses no part of the mesh: the cut has no inside cells";
  }
  else if (counts[2] == 0 && options.KeepSide != stmMarchingSimplices::INSIDE)
  {
    emptiness = "encloses the whole mesh: the cut has no outside cells";
  }
  if (!emptiness.empty())
  {
    Diagnostics() << "stmesh: warning: the separating surface (--separating "
                  << options.Separating.Text << (options.IsoValue != 0 ? ", --iso" : "") << ") "
                  << emptiness << '\n';
  }
  return mesh;
}

/// The smooth stage (paper, section 3.4): stmBoundarySmooth on the cut mesh of both sides, then
/// the side --keep asks for or the surface, by stmMarchingSimplices on the smoothed mesh. The
/// cut points and the snapped points carry f = iso exactly, so that run splits nothing: its
/// surface is the smoothed interface and its sides are the smoothed cut's cells. The sphere is
/// known exactly, so the smoothed surface points go back onto it.
vtkSmartPointer<vtkPointSet> RunSmooth(vtkSmartPointer<vtkUnstructuredGrid> grid,
  const Options& options, const SeparatingSource& source, StageReport& report)
{
  vtkNew<stmBoundarySmooth> smooth;
  smooth->SetNumberOfIterations(options.SmoothIterations);
  smooth->SetMethod(options.SmoothMethod);
  smooth->SetBackgroundMaterial(0); // the cut's outside
  // Every label its own material: each gets back its voxels' volume, which the junction lines
  // of the cut cost the small labels.
  smooth->SetRestoreOriginalVolumes(options.SeparateMaterials);
  if (source.Sphere && options.IsoValue == 0)
  {
    // The sphere's zero set; with --iso the surface is another sphere, which vtkSphere is not.
    smooth->SetProjectToFunction(true);
    smooth->SetImplicitFunction(source.Sphere);
  }
  grid = RunStage(smooth, grid, "smoothing the surface", report, false);
  report.Smooth = true;
  report.MovedPoints = static_cast<long long>(smooth->GetNumberOfMovedPoints());
  report.RejectedMoves = static_cast<long long>(smooth->GetNumberOfRejectedMoves());
  report.ImprovedPoints = static_cast<long long>(smooth->GetNumberOfImprovedPoints());
  report.SplitEdges = static_cast<long long>(smooth->GetNumberOfSplitEdges());
  report.KeptPoints = static_cast<long long>(smooth->GetNumberOfKeptPoints());
  if (!options.WritesSurface() && options.KeepSide == stmMarchingSimplices::BOTH)
  {
    return grid;
  }
  vtkNew<stmMarchingSimplices> extract;
  extract->SetOutputMode(options.OutputMode);
  extract->SetKeepSide(options.KeepSide);
  extract->SetIsoValue(options.IsoValue);
  extract->SetInsideMaterial(InsideMaterial(options));
  extract->SetOutsideMaterial(0);
  const std::string context = options.WritesSurface() ? "extracting the smoothed surface"
                                                      : "keeping one side of the smoothed mesh";
  vtkSmartPointer<vtkPointSet> mesh =
    RunFilter(extract, WithLabelsAsMaterial(grid), context, report);
  if (extract->GetNumberOfSplitCells() != 0)
  {
    throw Failure(context +
      ": internal error: " + std::to_string(extract->GetNumberOfSplitCells()) +
      " cells of the cut mesh were cut again (a cut or snapped point is off the surface)");
  }
  if (options.WritesSurface())
  {
    report.SurfaceCells = report.Cells;
  }
  std::ostringstream description;
  description << report.Cells << " cells, " << report.Points << " points";
  report.Description = description.str();
  return mesh;
}

//------------------------------------------------------------------------------------------------
// The structure report: per material, the image's voxels and connected components against the
// output mesh's volume and cells. Made after the timed stages.

/// What the report needs of the (merged) label image: its labels and the affine map from
/// physical coordinates to voxel coordinates, in which voxel (i, j, k) has its centre at
/// (i, j, k).
struct ReportImage
{
  vtkSmartPointer<vtkDataArray> Labels;
  int Dimensions[3] = { 1, 1, 1 }; // voxels per axis
  std::vector<int> SpannedAxes;
  double VoxelMeasure = 0.0;         // volume (area in 2D) of one voxel
  double PhysicalToVoxel[3][4] = {}; // rows: voxel coordinate = row . (x, y, z, 1)
  double VoxelToPhysical[3][4] = {};
};

ReportImage MakeReportImage(vtkImageData* image, const ImageInfo& info)
{
  ReportImage result;
  result.Labels = ImageValues(image, info);
  result.SpannedAxes = info.SpannedAxes;
  result.VoxelMeasure = 1.0;
  for (const int axis : info.SpannedAxes)
  {
    result.VoxelMeasure *= std::abs(info.Spacing[axis]);
  }
  int extent[6];
  image->GetExtent(extent);
  double offset[3];
  for (int axis = 0; axis < 3; ++axis)
  {
    result.Dimensions[axis] = info.VoxelDimensions[axis];
    // Cell labels: the voxel centre is half a point spacing above its lower corner.
    offset[axis] = extent[2 * axis] + (info.CellLabels && info.Dimensions[axis] > 1 ? 0.5 : 0.0);
  }
  vtkMatrix4x4* toIndex = image->GetPhysicalToIndexMatrix();
  vtkMatrix4x4* toPhysical = image->GetIndexToPhysicalMatrix();
  for (int row = 0; row < 3; ++row)
  {
    for (int column = 0; column < 4; ++column)
    {
      result.PhysicalToVoxel[row][column] = toIndex->GetElement(row, column);
      result.VoxelToPhysical[row][column] = toPhysical->GetElement(row, column);
    }
    result.PhysicalToVoxel[row][3] -= offset[row];
  }
  for (int row = 0; row < 3; ++row)
  {
    for (int axis = 0; axis < 3; ++axis)
    {
      result.VoxelToPhysical[row][3] += toPhysical->GetElement(row, axis) * offset[axis];
    }
  }
  return result;
}

/// A maximal run of voxels of one material along the x axis of an image row.
struct VoxelRun
{
  long long Material;
  int Start; // x of the first voxel; the run ends where the row's next run starts
};

/// The runs of every row (j, k) of the image, rows in memory order, in parallel over slices;
/// each label is mapped to its material by MaterialOf (called when the label changes).
struct ExtractRuns
{
  const int* Dimensions = nullptr;
  std::function<long long(long long)> MaterialOf;
  std::vector<std::vector<VoxelRun>> SliceRuns;    // per slice k
  std::vector<std::vector<vtkIdType>> SliceCounts; // per slice k: runs per row j

  template <typename ArrayT>
  void operator()(ArrayT* array)
  {
    using Value = vtk::GetAPIType<ArrayT>;
    const auto values = vtk::DataArrayValueRange<1>(array);
    const int nx = this->Dimensions[0];
    const int ny = this->Dimensions[1];
    const int nz = this->Dimensions[2];
    this->SliceRuns.assign(nz, {});
    this->SliceCounts.assign(nz, {});
    vtkSMPTools::For(0, nz,
      [&](vtkIdType beginSlice, vtkIdType endSlice)
      {
        for (vtkIdType k = beginSlice; k < endSlice; ++k)
        {
          std::vector<VoxelRun>& runs = this->SliceRuns[k];
          std::vector<vtkIdType>& counts = this->SliceCounts[k];
          counts.assign(ny, 0);
          bool cached = false;
          Value lastLabel{};
          long long material = 0;
          for (int j = 0; j < ny; ++j)
          {
            const vtkIdType rowStart = (static_cast<vtkIdType>(k) * ny + j) * nx;
            const std::size_t before = runs.size();
            for (int i = 0; i < nx; ++i)
            {
              const Value label = values[rowStart + i];
              if (!cached || label != lastLabel)
              {
                material = this->MaterialOf(static_cast<long long>(label));
                lastLabel = label;
                cached = true;
              }
              if (i == 0 || runs.back().Material != material)
              {
                runs.push_back({ material, i });
              }
            }
            counts[j] = static_cast<vtkIdType>(runs.size() - before);
          }
        }
      });
  }
};

vtkIdType FindRoot(std::vector<vtkIdType>& parent, vtkIdType run)
{
  while (parent[run] != run)
  {
    parent[run] = parent[parent[run]]; // path halving
    run = parent[run];
  }
  return run;
}

/// Joins the runs of row a with the overlapping runs of the same material of row b (both
/// given by their first run and the row's end run index).
void JoinRows(const std::vector<VoxelRun>& runs, vtkIdType aBegin, vtkIdType aEnd, vtkIdType bBegin,
  vtkIdType bEnd, int nx, std::vector<vtkIdType>& parent)
{
  vtkIdType a = aBegin;
  vtkIdType b = bBegin;
  while (a < aEnd && b < bEnd)
  {
    const int aStop = a + 1 < aEnd ? runs[a + 1].Start : nx;
    const int bStop = b + 1 < bEnd ? runs[b + 1].Start : nx;
    if (runs[a].Material == runs[b].Material)
    {
      const vtkIdType ra = FindRoot(parent, a);
      const vtkIdType rb = FindRoot(parent, b);
      if (ra != rb)
      {
        parent[std::max(ra, rb)] = std::min(ra, rb);
      }
    }
    if (aStop <= bStop)
    {
      ++a;
    }
    if (bStop <= aStop)
    {
      ++b;
    }
  }
}

/// Whether point p (voxel coordinates) lies in the closed cell of the given type and points
/// (voxel coordinates), the cells being affine images of lattice cells; axes are the image
/// axes the mesh spans (2 for a 2D mesh, whose flat coordinate is ignored). -1: a cell type
/// this test does not know.
int ContainsPoint(int type, const double (*q)[3], const double p[3], const std::vector<int>& axes)
{
  const double eps = 1e-9;
  if (axes.size() == 2)
  {
    const int x = axes[0];
    const int y = axes[1];
    if (type != VTK_TRIANGLE && type != VTK_QUAD)
    {
      return -1;
    }
    const double a[2] = { q[1][x] - q[0][x], q[1][y] - q[0][y] };
    const int second = type == VTK_TRIANGLE ? 2 : 3;
    const double b[2] = { q[second][x] - q[0][x], q[second][y] - q[0][y] };
    const double d[2] = { p[x] - q[0][x], p[y] - q[0][y] };
    const double det = a[0] * b[1] - a[1] * b[0];
    if (det == 0.0)
    {
      return 0;
    }
    const double u = (d[0] * b[1] - d[1] * b[0]) / det;
    const double v = (a[0] * d[1] - a[1] * d[0]) / det;
    if (type == VTK_TRIANGLE)
    {
      return u >= -eps && v >= -eps && u + v <= 1 + eps;
    }
    return u >= -eps && v >= -eps && u <= 1 + eps && v <= 1 + eps;
  }
  if (type != VTK_TETRA && type != VTK_HEXAHEDRON && type != VTK_PYRAMID)
  {
    return -1;
  }
  // Point 0 and its neighbours along the cell's edges, as in CellMeasure.
  const int second = type == VTK_TETRA ? 2 : 3;
  const int third = type == VTK_TETRA ? 3 : 4;
  double e[3][3], d[3];
  for (int c = 0; c < 3; ++c)
  {
    e[0][c] = q[1][c] - q[0][c];
    e[1][c] = q[second][c] - q[0][c];
    e[2][c] = q[third][c] - q[0][c];
    d[c] = p[c] - q[0][c];
  }
  const auto triple = [](const double* r, const double* s, const double* t)
  {
    return r[0] * (s[1] * t[2] - s[2] * t[1]) - r[1] * (s[0] * t[2] - s[2] * t[0]) +
      r[2] * (s[0] * t[1] - s[1] * t[0]);
  };
  const double det = triple(e[0], e[1], e[2]);
  if (det == 0.0)
  {
    return 0;
  }
  const double u = triple(d, e[1], e[2]) / det;
  const double v = triple(e[0], d, e[2]) / det;
  const double w = triple(e[0], e[1], d) / det;
  switch (type)
  {
    case VTK_TETRA:
      return u >= -eps && v >= -eps && w >= -eps && u + v + w <= 1 + eps;
    case VTK_HEXAHEDRON:
      return u >= -eps && v >= -eps && w >= -eps && u <= 1 + eps && v <= 1 + eps && w <= 1 + eps;
    default: // pyramid: the base shrinks linearly towards the apex
      return w >= -eps && w <= 1 + eps && u >= -eps && v >= -eps && u <= 1 - w + eps &&
        v <= 1 - w + eps;
  }
}

/// Calls body(offsets, connectivity) with the raw arrays of a cell array, 32- or 64-bit.
template <class Body>
void WithCellArrays(vtkCellArray* cellArray, const Body& body)
{
  if (cellArray->IsStorage64Bit())
  {
    body(cellArray->GetOffsetsArray64()->GetPointer(0),
      cellArray->GetConnectivityArray64()->GetPointer(0));
  }
  else
  {
    body(cellArray->GetOffsetsArray32()->GetPointer(0),
      cellArray->GetConnectivityArray32()->GetPointer(0));
  }
}

/// The structure report of a volume mesh against the (merged) label image.
StructureReport MakeStructureReport(
  vtkPointSet* mesh, const ReportImage& image, const Options& options)
{
  StructureReport report;
  auto* grid = vtkUnstructuredGrid::SafeDownCast(mesh);
  if (!grid || !image.Labels || image.SpannedAxes.size() < 2)
  {
    return report;
  }
  report.Made = true;
  const int nx = image.Dimensions[0];
  const int ny = image.Dimensions[1];
  const int nz = image.Dimensions[2];

  // How the mesh's Material is defined: with a cut of one body the body labels are the inside
  // material, without one (or with --materials separate) they keep their label; every other
  // label is the background, 0.
  std::vector<long long> body(options.Labels.begin(), options.Labels.end());
  std::sort(body.begin(), body.end());
  const bool cut = options.Cuts() && !options.SeparateMaterials;
  const long long inside = InsideMaterial(options);
  ExtractRuns extract;
  extract.Dimensions = image.Dimensions;
  extract.MaterialOf = [&body, cut, inside](long long label) -> long long
  {
    const bool inBody =
      label != 0 && (body.empty() || std::binary_search(body.begin(), body.end(), label));
    return inBody ? (cut ? inside : label) : 0;
  };
  if (!vtkArrayDispatch::DispatchByValueType<vtkArrayDispatch::Integrals>::Execute(
        image.Labels.GetPointer(), extract))
  {
    extract(image.Labels.GetPointer());
  }
  const vtkIdType rows = static_cast<vtkIdType>(ny) * nz;
  std::vector<vtkIdType> rowBegin(static_cast<std::size_t>(rows) + 1, 0);
  std::vector<VoxelRun> runs;
  {
    std::size_t total = 0;
    for (const auto& slice : extract.SliceRuns)
    {
      total += slice.size();
    }
    runs.reserve(total);
    vtkIdType row = 0;
    for (int k = 0; k < nz; ++k)
    {
      for (int j = 0; j < ny; ++j, ++row)
      {
        rowBegin[row + 1] = rowBegin[row] + extract.SliceCounts[k][j];
      }
      runs.insert(runs.end(), extract.SliceRuns[k].begin(), extract.SliceRuns[k].end());
      std::vector<VoxelRun>().swap(extract.SliceRuns[k]);
    }
  }
  const vtkIdType numberOfRuns = static_cast<vtkIdType>(runs.size());
  const auto runLength = [&](vtkIdType run, vtkIdType row)
  { return (run + 1 < rowBegin[row + 1] ? runs[run + 1].Start : nx) - runs[run].Start; };

  // Connected components (6-connected; 4 in 2D, the flat axis having one voxel): one
  // union-find pass over the runs, each run joined with the overlapping runs of the rows
  // below it in y and in z.
  std::vector<vtkIdType> parent(static_cast<std::size_t>(numberOfRuns));
  std::iota(parent.begin(), parent.end(), vtkIdType(0));
  for (vtkIdType row = 0; row < rows; ++row)
  {
    const vtkIdType j = row % ny;
    if (j > 0)
    {
      JoinRows(
        runs, rowBegin[row], rowBegin[row + 1], rowBegin[row - 1], rowBegin[row], nx, parent);
    }
    if (row >= ny)
    {
      JoinRows(runs, rowBegin[row], rowBegin[row + 1], rowBegin[row - ny], rowBegin[row - ny + 1],
        nx, parent);
    }
  }
  // Component ids in order of their first run; sizes and materials.
  std::vector<vtkIdType> runComponent(static_cast<std::size_t>(numberOfRuns));
  std::vector<long long> componentSize;
  std::vector<long long> componentMaterial;
  for (vtkIdType row = 0; row < rows; ++row)
  {
    for (vtkIdType run = rowBegin[row]; run < rowBegin[row + 1]; ++run)
    {
      const vtkIdType root = FindRoot(parent, run);
      if (root == run)
      {
        runComponent[run] = static_cast<vtkIdType>(componentSize.size());
        componentSize.push_back(0);
        componentMaterial.push_back(runs[run].Material);
      }
      else
      {
        runComponent[run] = runComponent[root]; // root < run: numbered already
      }
      componentSize[runComponent[run]] += runLength(run, row);
    }
  }
  std::vector<vtkIdType>().swap(parent);
  const vtkIdType numberOfComponents = static_cast<vtkIdType>(componentSize.size());

  // The mesh's materials and their volumes (areas), summed in fixed blocks of cells in order.
  vtkDataArray* materialArray = grid->GetCellData()->GetArray("Material");
  const vtkIdType cells = grid->GetNumberOfCells();
  std::vector<long long> cellMaterial(static_cast<std::size_t>(cells), 0);
  if (materialArray)
  {
    vtkSMPTools::For(0, cells,
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType cell = begin; cell < end; ++cell)
        {
          cellMaterial[cell] = static_cast<long long>(materialArray->GetComponent(cell, 0));
        }
      });
  }
  // The distinct values: a set per thread, consulted only when the value changes.
  vtkSMPThreadLocal<std::set<long long>> localMaterials;
  vtkSMPTools::For(0, cells,
    [&](vtkIdType begin, vtkIdType end)
    {
      std::set<long long>& local = localMaterials.Local();
      for (vtkIdType cell = begin; cell < end; ++cell)
      {
        if (cell == begin || cellMaterial[cell] != cellMaterial[cell - 1])
        {
          local.insert(cellMaterial[cell]);
        }
      }
    });
  std::set<long long> meshMaterials;
  for (const std::set<long long>& local : localMaterials)
  {
    meshMaterials.insert(local.begin(), local.end());
  }
  // Listed: the mesh's materials and the image's body materials (the background only when
  // the mesh has it: the mesh covers it only in its boundary layers).
  std::set<long long> listedSet = meshMaterials;
  for (vtkIdType component = 0; component < numberOfComponents; ++component)
  {
    if (componentMaterial[component] != 0)
    {
      listedSet.insert(componentMaterial[component]);
    }
  }
  const std::vector<long long> listed(listedSet.begin(), listedSet.end());
  const auto materialIndex = [&listed](long long material) -> int
  {
    const auto found = std::lower_bound(listed.begin(), listed.end(), material);
    return found != listed.end() && *found == material ? static_cast<int>(found - listed.begin())
                                                       : -1;
  };
  const std::size_t materials = listed.size();
  std::vector<int> cellIndex(static_cast<std::size_t>(cells));
  vtkSMPTools::For(0, cells,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType cell = begin; cell < end; ++cell)
      {
        cellIndex[cell] = cell > begin && cellMaterial[cell] == cellMaterial[cell - 1]
          ? cellIndex[cell - 1]
          : materialIndex(cellMaterial[cell]);
      }
    });
  std::vector<long long>().swap(cellMaterial);

  vtkPoints* points = grid->GetPoints();
  const vtkIdType numberOfPoints = points ? points->GetNumberOfPoints() : 0;
  std::vector<double> volumes(materials, 0.0);
  const PointReader point(points);
  vtkUnsignedCharArray* typeArray = grid->GetCellTypesArray();
  const unsigned char* types = typeArray ? typeArray->GetPointer(0) : nullptr;
  if (cells > 0 && types)
  {
    const vtkIdType blockSize = 1 << 16;
    const vtkIdType blocks = (cells + blockSize - 1) / blockSize;
    std::vector<double> blockVolumes(static_cast<std::size_t>(blocks) * materials, 0.0);
    WithCellArrays(grid->GetCells(),
      [&](const auto* offsets, const auto* connectivity)
      {
        vtkSMPTools::For(0, blocks,
          [&](vtkIdType beginBlock, vtkIdType endBlock)
          {
            for (vtkIdType block = beginBlock; block < endBlock; ++block)
            {
              const vtkIdType end = std::min(cells, (block + 1) * blockSize);
              for (vtkIdType cell = block * blockSize; cell < end; ++cell)
              {
                if (offsets[cell + 1] - offsets[cell] < 3)
                {
                  continue;
                }
                blockVolumes[block * materials + cellIndex[cell]] +=
                  CellMeasure(types[cell], connectivity + offsets[cell], point);
              }
            }
          });
      });
    for (vtkIdType block = 0; block < blocks; ++block)
    {
      for (std::size_t m = 0; m < materials; ++m)
      {
        volumes[m] += blockVolumes[block * materials + m];
      }
    }
  }

  // The voxel centres to test: every voxel of a component under 1000 voxels, else 1000 evenly
  // spread over the component in memory order; only components of listed materials with at
  // least --min-component-voxels voxels.
  const long long sampleLimit = 1000;
  std::vector<char> counted(static_cast<std::size_t>(numberOfComponents), 0);
  std::vector<int> componentIndex(static_cast<std::size_t>(numberOfComponents), -1);
  std::vector<long long> voxels(materials, 0);
  std::vector<long long> componentsPerMaterial(materials, 0);
  for (vtkIdType component = 0; component < numberOfComponents; ++component)
  {
    const int m = materialIndex(componentMaterial[component]);
    componentIndex[component] = m;
    if (m < 0)
    {
      continue;
    }
    voxels[m] += componentSize[component];
    if (componentSize[component] >= options.MinComponentVoxels)
    {
      counted[component] = 1;
      ++componentsPerMaterial[m];
    }
  }
  // Runs per component, in memory order (counting sort).
  std::vector<vtkIdType> componentRunBegin(static_cast<std::size_t>(numberOfComponents) + 1, 0);
  for (vtkIdType run = 0; run < numberOfRuns; ++run)
  {
    ++componentRunBegin[runComponent[run] + 1];
  }
  std::partial_sum(componentRunBegin.begin(), componentRunBegin.end(), componentRunBegin.begin());
  std::vector<vtkIdType> componentRuns(static_cast<std::size_t>(numberOfRuns));
  std::vector<vtkIdType> runRow(static_cast<std::size_t>(numberOfRuns));
  {
    std::vector<vtkIdType> fill(componentRunBegin.begin(), componentRunBegin.end() - 1);
    for (vtkIdType row = 0; row < rows; ++row)
    {
      for (vtkIdType run = rowBegin[row]; run < rowBegin[row + 1]; ++run)
      {
        componentRuns[fill[runComponent[run]]++] = run;
        runRow[run] = row;
      }
    }
  }
  std::vector<std::pair<vtkIdType, vtkIdType>> samples; // (voxel index, component)
  std::vector<vtkIdType> firstVoxel(static_cast<std::size_t>(numberOfComponents), 0);
  for (vtkIdType component = 0; component < numberOfComponents; ++component)
  {
    if (!counted[component])
    {
      continue;
    }
    {
      const vtkIdType run = componentRuns[componentRunBegin[component]];
      firstVoxel[component] = runRow[run] * nx + runs[run].Start;
    }
    const long long size = componentSize[component];
    const long long count = std::min(size, sampleLimit);
    long long t = 0;
    long long next = 0; // the ordinal of sample t: floor(t * size / count)
    long long ordinal = 0;
    for (vtkIdType r = componentRunBegin[component];
         r < componentRunBegin[component + 1] && t < count; ++r)
    {
      const vtkIdType run = componentRuns[r];
      const vtkIdType row = runRow[run];
      const long long length = runLength(run, row);
      while (t < count && next < ordinal + length)
      {
        samples.emplace_back(row * nx + runs[run].Start + (next - ordinal), component);
        ++t;
        next = t * size / count;
      }
      ordinal += length;
    }
  }
  std::sort(samples.begin(), samples.end());
  std::vector<unsigned char> sampled(static_cast<std::size_t>(rows) * nx, 0);
  for (const auto& sample : samples)
  {
    sampled[sample.first] = 1;
  }
  std::vector<VoxelRun>().swap(runs);

  // Which components have a tested centre in a cell of their material: every cell visits the
  // sampled voxels in its bounding box (in voxel coordinates) and tests them exactly; cells of
  // a material whose components are all found are skipped. A vtkStaticCellLocator answers the
  // same question, but building one for the 6.5 million tetrahedra of the AAL mesh takes 6 to
  // 8 s on two cores; the tested points lie on the image lattice, which makes this scan over
  // the cells take about 0.1 s.
  std::unique_ptr<std::atomic<unsigned char>[]> present(
    new std::atomic<unsigned char>[static_cast<std::size_t>(numberOfComponents)]);
  std::unique_ptr<std::atomic<long long>[]> missing(new std::atomic<long long>[materials]);
  for (vtkIdType component = 0; component < numberOfComponents; ++component)
  {
    present[component].store(0, std::memory_order_relaxed);
  }
  for (std::size_t m = 0; m < materials; ++m)
  {
    missing[m].store(componentsPerMaterial[m], std::memory_order_relaxed);
  }
  std::vector<double> voxelPoints(static_cast<std::size_t>(numberOfPoints) * 3);
  vtkSMPTools::For(0, numberOfPoints,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType id = begin; id < end; ++id)
      {
        double x[3];
        points->GetPoint(id, x);
        for (int row = 0; row < 3; ++row)
        {
          const double* m = image.PhysicalToVoxel[row];
          voxelPoints[3 * id + row] = m[0] * x[0] + m[1] * x[1] + m[2] * x[2] + m[3];
        }
      }
    });
  if (!samples.empty() && cells > 0 && types)
  {
    grid->GetCellType(0); // builds the cell types before the threads read them
    vtkNew<vtkGenericCell> warmUp;
    grid->GetCell(0, warmUp);
    const std::vector<int>& axes = image.SpannedAxes;
    vtkSMPThreadLocal<vtkSmartPointer<vtkGenericCell>> genericCells;
    WithCellArrays(grid->GetCells(),
      [&](const auto* offsets, const auto* connectivity)
      {
        vtkSMPTools::For(0, cells,
          [&](vtkIdType begin, vtkIdType end)
          {
            double q[8][3];
            for (vtkIdType cell = begin; cell < end; ++cell)
            {
              const int m = cellIndex[cell];
              if (missing[m].load(std::memory_order_relaxed) == 0)
              {
                continue;
              }
              const vtkIdType corners = static_cast<vtkIdType>(offsets[cell + 1] - offsets[cell]);
              if (corners < 3)
              {
                continue;
              }
              const auto* ids = connectivity + offsets[cell];
              double lo[3] = { 0.0, 0.0, 0.0 };
              double hi[3] = { 0.0, 0.0, 0.0 };
              for (vtkIdType v = 0; v < corners; ++v)
              {
                const double* p = &voxelPoints[3 * static_cast<vtkIdType>(ids[v])];
                for (int c = 0; c < 3; ++c)
                {
                  if (v < 8)
                  {
                    q[v][c] = p[c];
                  }
                  lo[c] = v == 0 ? p[c] : std::min(lo[c], p[c]);
                  hi[c] = v == 0 ? p[c] : std::max(hi[c], p[c]);
                }
              }
              int first[3] = { 0, 0, 0 };
              int last[3] = { 0, 0, 0 };
              bool empty = false;
              for (const int axis : axes)
              {
                const double tolerance = 1e-9 * (1.0 + std::abs(lo[axis]) + std::abs(hi[axis]));
                const double from = std::max(std::ceil(lo[axis] - tolerance), 0.0);
                const double to =
                  std::min(std::floor(hi[axis] + tolerance), image.Dimensions[axis] - 1.0);
                empty = empty || from > to;
                first[axis] = static_cast<int>(from);
                last[axis] = static_cast<int>(to);
              }
              if (empty)
              {
                continue;
              }
              const int type = types[cell];
              for (int k = first[2]; k <= last[2]; ++k)
              {
                for (int j = first[1]; j <= last[1]; ++j)
                {
                  const vtkIdType rowStart = (static_cast<vtkIdType>(k) * ny + j) * nx;
                  for (int i = first[0]; i <= last[0]; ++i)
                  {
                    if (!sampled[rowStart + i])
                    {
                      continue;
                    }
                    const vtkIdType voxel = rowStart + i;
                    const auto found = std::lower_bound(
                      samples.begin(), samples.end(), std::make_pair(voxel, vtkIdType(0)));
                    const vtkIdType component = found->second;
                    if (componentIndex[component] != m ||
                      present[component].load(std::memory_order_relaxed))
                    {
                      continue;
                    }
                    const double centre[3] = { static_cast<double>(i), static_cast<double>(j),
                      static_cast<double>(k) };
                    int inside = corners <= 8 ? ContainsPoint(type, q, centre, axes) : -1;
                    if (inside < 0)
                    {
                      // Another cell type: VTK's own test, in physical coordinates.
                      vtkSmartPointer<vtkGenericCell>& genericCell = genericCells.Local();
                      if (!genericCell)
                      {
                        genericCell = vtkSmartPointer<vtkGenericCell>::New();
                      }
                      grid->GetCell(cell, genericCell);
                      double x[3], closest[3], pcoords[3], distance2 = 0.0;
                      std::vector<double> weights(static_cast<std::size_t>(corners) + 8);
                      int subId = 0;
                      for (int row = 0; row < 3; ++row)
                      {
                        const double* t = image.VoxelToPhysical[row];
                        x[row] = t[0] * centre[0] + t[1] * centre[1] + t[2] * centre[2] + t[3];
                      }
                      inside = genericCell->EvaluatePosition(
                                 x, closest, subId, pcoords, distance2, weights.data()) == 1 &&
                        distance2 <= 1e-12;
                    }
                    if (inside > 0 && !present[component].exchange(1))
                    {
                      missing[m].fetch_sub(1, std::memory_order_relaxed);
                    }
                  }
                }
              }
            }
          });
      });
  }

  std::vector<long long> lost(materials, 0);
  for (vtkIdType component = 0; component < numberOfComponents; ++component)
  {
    if (counted[component] && !present[component].load())
    {
      ++lost[componentIndex[component]];
      LostComponent entry;
      entry.Material = componentMaterial[component];
      entry.Voxels = componentSize[component];
      entry.FirstVoxel[0] = static_cast<int>(firstVoxel[component] % nx);
      entry.FirstVoxel[1] = static_cast<int>(firstVoxel[component] / nx % ny);
      entry.FirstVoxel[2] = static_cast<int>(firstVoxel[component] / nx / ny);
      report.Lost.push_back(entry);
    }
  }
  for (std::size_t m = 0; m < materials; ++m)
  {
    MaterialReport entry;
    entry.Material = listed[m];
    entry.Voxels = voxels[m];
    entry.VoxelVolume = static_cast<double>(voxels[m]) * image.VoxelMeasure;
    entry.MeshVolume = volumes[m];
    entry.Components = componentsPerMaterial[m];
    entry.LostComponents = lost[m];
    report.Materials.push_back(entry);
  }
  return report;
}

/// The line below the table: the body materials' totals (the background, whose mesh covers
/// only the boundary layers, is left out of the counts).
void PrintStructureReport(const StructureReport& report)
{
  long long materials = 0;
  long long lost = 0;
  long long components = 0;
  const MaterialReport* worst = nullptr;
  double worstError = 0.0;
  for (const MaterialReport& entry : report.Materials)
  {
    if (entry.Material == 0)
    {
      continue;
    }
    ++materials;
    lost += entry.LostComponents;
    components += entry.Components;
    if (entry.Voxels > 0)
    {
      const double error = (entry.MeshVolume - entry.VoxelVolume) / entry.VoxelVolume;
      if (!worst || std::abs(error) > std::abs(worstError))
      {
        worst = &entry;
        worstError = error;
      }
    }
  }
  std::cout << "materials: " << materials << " material" << (materials == 1 ? "" : "s") << ", "
            << lost << " lost component" << (lost == 1 ? "" : "s") << " (of " << components
            << "), largest volume error ";
  if (worst)
  {
    // Rounded to two decimals; an error that rounds to zero prints as 0.00, not -0.00.
    const double percent = std::abs(100.0 * worstError) < 0.005 ? 0.0 : 100.0 * worstError;
    std::cout << std::fixed << std::setprecision(2) << percent << std::defaultfloat
              << "% (material " << worst->Material << ")";
  }
  else
  {
    std::cout << "n/a";
  }
  std::cout << '\n';
  // The first few lost body components, where to look (all of them are in --summary).
  const std::size_t shown = 10;
  std::size_t listed = 0;
  for (const LostComponent& entry : report.Lost)
  {
    if (entry.Material == 0)
    {
      continue;
    }
    if (listed == shown)
    {
      std::cout << "lost: ... (" << lost - static_cast<long long>(shown)
                << " more in the --summary file)\n";
      break;
    }
    std::cout << "lost: material " << entry.Material << ", " << entry.Voxels << " voxel"
              << (entry.Voxels == 1 ? "" : "s") << " from voxel (" << entry.FirstVoxel[0] << ", "
              << entry.FirstVoxel[1] << ", " << entry.FirstVoxel[2] << ")\n";
    ++listed;
  }
}

/// The package directories where python3 finds spacetreemesh.report: the build tree's and, for
/// an installed stmesh, the one beside its bin directory.
std::string ReportPythonPath()
{
  std::string path = STMESH_BUILD_PYTHON_PATH;
  char executable[4096];
  const ssize_t length = readlink("/proc/self/exe", executable, sizeof(executable) - 1);
  if (length > 0)
  {
    executable[length] = '\0';
    path += ":" + DirectoryName(DirectoryName(executable)) + "/" + STMESH_INSTALLED_PYTHON_SITE;
  }
  const char* existing = std::getenv("PYTHONPATH");
  return existing && *existing ? path + ":" + existing : path;
}

/// The "report" stage (--report DIR): the summary and, for a finite-element output, the mesh as
/// .vtu go into DIR, then python3 -m spacetreemesh.report draws the pictures and the page.
void WriteReport(vtkPointSet* mesh, const std::string& output, MeshFormat format,
  const Options& options, RunSummary& summary)
{
  const std::string& directory = options.ReportDirectory;
  const Clock::time_point start = Clock::now();
  if (mkdir(directory.c_str(), 0777) != 0 && errno != EEXIST)
  {
    throw Failure(
      "--report: cannot make the directory '" + directory + "': " + std::strerror(errno));
  }
  std::string meshPath = output;
  if (format != MeshFormat::XMLUnstructuredGrid && format != MeshFormat::LegacyVTK)
  {
    meshPath = directory + "/mesh.vtu";
    StageReport ignored;
    WriteMesh(mesh, meshPath, MeshFormat::XMLUnstructuredGrid, options.Compressor, false, ignored);
  }
  const std::string summaryPath = directory + "/summary.json";
  WriteSummary(summaryPath, options, summary);
  const char* chosen = std::getenv("STMESH_PYTHON");
  const std::string python = chosen && *chosen ? chosen : "/usr/bin/python3";
  const std::string pythonPath = ReportPythonPath();
  std::vector<std::string> arguments = { python, "-m", "spacetreemesh.report", meshPath, directory,
    "--summary", summaryPath, "--title", "stmesh: " + FileName(output) };
  std::cout << "report:  " << python << " -m spacetreemesh.report " << meshPath << ' ' << directory
            << std::endl;
  const pid_t child = fork();
  if (child == 0)
  {
    setenv("PYTHONPATH", pythonPath.c_str(), 1);
    std::vector<char*> argv;
    for (std::string& argument : arguments)
    {
      argv.push_back(&argument[0]);
    }
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    std::fprintf(
      stderr, "stmesh: error: --report: cannot run %s: %s\n", argv[0], std::strerror(errno));
    _exit(127);
  }
  int status = 0;
  if (child < 0 || waitpid(child, &status, 0) != child || !WIFEXITED(status) ||
    WEXITSTATUS(status) != 0)
  {
    throw Failure("--report: " + python +
      " -m spacetreemesh.report failed (it needs Debian's "
      "python3-paraview and python3-matplotlib; the mesh itself was written to '" +
      output + "')");
  }
  StageReport report;
  report.Name = "report";
  report.Seconds = SecondsSince(start);
  report.Description = directory + "/index.html";
  summary.Stages.push_back(report);
  std::cout << "report:  " << directory << "/index.html (" << std::fixed << std::setprecision(1)
            << report.Seconds << " s)" << std::defaultfloat << '\n';
}

//------------------------------------------------------------------------------------------------
// Several MPI ranks (stmeshParallel.h): the figures of all pieces on rank 0.

std::vector<RankFigures> GatherRankFigures(const RankFigures& mine, const ParallelRun& parallel)
{
  std::vector<RankFigures> all;
  for (const std::vector<double>& values :
    parallel.GatherOnFirstRank({ mine.Seconds, static_cast<double>(mine.Cells),
      static_cast<double>(mine.Points), mine.PeakRssMiB, static_cast<double>(mine.VoxelsRead) }))
  {
    all.push_back({ values[0], static_cast<long long>(values[1]), static_cast<long long>(values[2]),
      values[3], static_cast<long long>(values[4]) });
  }
  return all;
}

void PrintRankTable(const std::vector<RankFigures>& ranks)
{
  std::cout << "ranks:   " << ranks.size()
            << " MPI ranks; each rank's meshing (before the gather or write), its own cells:\n";
  for (std::size_t rank = 0; rank < ranks.size(); ++rank)
  {
    char line[200];
    std::snprintf(line, sizeof(line),
      "  rank %-4zu %9.3f s %12lld cells %12lld points %10.1f MiB %12lld voxels read\n", rank,
      ranks[rank].Seconds, ranks[rank].Cells, ranks[rank].Points, ranks[rank].PeakRssMiB,
      ranks[rank].VoxelsRead);
    std::cout << line;
  }
}

/// The sum over all ranks of a map per rank, on rank 0 (the other ranks keep their own).
template <class Value>
std::map<long long, Value> SumOnFirstRank(
  const std::map<long long, Value>& mine, const ParallelRun& parallel)
{
  std::vector<double> values;
  for (const auto& entry : mine)
  {
    values.push_back(static_cast<double>(entry.first));
    values.push_back(static_cast<double>(entry.second));
  }
  const std::vector<std::vector<double>> perRank = parallel.GatherOnFirstRank(values);
  if (parallel.Rank() != 0)
  {
    return mine;
  }
  std::map<long long, Value> sum;
  for (const std::vector<double>& rankValues : perRank)
  {
    for (std::size_t i = 0; i + 1 < rankValues.size(); i += 2)
    {
      sum[static_cast<long long>(rankValues[i])] += static_cast<Value>(rankValues[i + 1]);
    }
  }
  return sum;
}

/// The quality of the pieces together, on rank 0 (the other ranks keep their own).
MeshQuality CombineQuality(const MeshQuality& mine, const ParallelRun& parallel)
{
  const std::vector<std::vector<double>> perRank =
    parallel.GatherOnFirstRank({ mine.Measured ? 1.0 : 0.0, static_cast<double>(mine.Cells),
      mine.WorstCondition, mine.SmallestDihedral, static_cast<double>(mine.InvertedCells) });
  MeshQuality combined;
  combined.VolumePerMaterial = SumOnFirstRank(mine.VolumePerMaterial, parallel);
  if (parallel.Rank() != 0)
  {
    return mine;
  }
  for (const std::vector<double>& values : perRank)
  {
    if (values[0] == 0.0)
    {
      continue; // an empty piece
    }
    combined.Measured = true;
    combined.Cells += static_cast<long long>(values[1]);
    combined.WorstCondition = std::max(combined.WorstCondition, values[2]);
    combined.SmallestDihedral = std::min(combined.SmallestDihedral, values[3]);
    combined.InvertedCells += static_cast<long long>(values[4]);
  }
  return combined;
}

void PrintQuality(const MeshQuality& quality, bool twoDimensional)
{
  std::cout << "quality: worst condition number " << std::fixed << std::setprecision(3)
            << quality.WorstCondition << ", smallest "
            << (twoDimensional ? "angle " : "dihedral angle ") << std::setprecision(2)
            << quality.SmallestDihedral << " degrees, " << quality.InvertedCells
            << " inverted cells; " << (twoDimensional ? "area" : "volume") << " per material";
  for (const auto& entry : quality.VolumePerMaterial)
  {
    // One decimal for voxel-sized units; significant digits for spacings such as 1e-6 or 1e6,
    // where one decimal would print 0.0 or 21 digits.
    const double magnitude = std::abs(entry.second);
    const bool fixedFits = magnitude == 0.0 || (magnitude >= 0.1 && magnitude < 1e7);
    std::cout << ' ' << entry.first << ": ";
    if (fixedFits)
    {
      std::cout << std::fixed << std::setprecision(1) << entry.second;
    }
    else
    {
      std::cout << std::defaultfloat << std::setprecision(4) << entry.second;
    }
  }
  std::cout << std::defaultfloat << '\n';
}

/// The checks of the options that need the whole image on one rank.
void CheckOptionsForRanks(const Options& options, int ranks)
{
  if (ranks < 2)
  {
    return;
  }
  const std::string several = "with " + std::to_string(ranks) + " MPI ranks";
  if (options.Grading > 0.0)
  {
    throw UsageError("--grading cannot be used " + several +
      ": a graded spacetree reaches farther than the two root cells of ghosts each rank meshes "
      "beyond its piece");
  }
  if (options.WritesSurface())
  {
    throw UsageError(
      "--output-mode surface cannot be used " + several + "; write the volume mesh (the default)");
  }
}

int Run(const Options& options, const ParallelRun& parallel)
{
  CurrentPiece = { parallel.Rank(), parallel.Ranks() };
  RunSummary summary;
  summary.MinorFaultsAtStart = CurrentResourceUsage().MinorPageFaults;
  std::string input = options.Input;
  if (input.empty())
  {
    input = DefaultInput;
    summary.DefaultInput = true;
    std::cout << "stmesh: no INPUT given; meshing the default image " << input << '\n';
    if (access(input.c_str(), F_OK) != 0)
    {
      throw Failure(std::string("the default image ") + input +
        " does not exist; install the Debian package mricron-data or give an INPUT");
    }
  }
  const std::string output =
    options.Output.empty() ? DefaultOutputName(input, options.WritesSurface()) : options.Output;
  MeshFormat meshFormat;
  if (!FindMeshFormat(output, meshFormat))
  {
    // Only reachable for a derived name; the command line was checked already.
    throw Failure("output '" + output + "' has an unsupported extension");
  }
  if (!FindImageFormat(input))
  {
    throw Failure("input '" + input + "' has an unsupported extension; stmesh reads " +
      SupportedInputExtensions);
  }
  CheckReadableFile(input);
  // The label table is read first, so that a bad one fails before the meshing.
  vtkNew<stmLabelTable> labelTable;
  if (!options.LabelNames.empty() && options.LabelNames != "none")
  {
    if (!labelTable->ReadFile(options.LabelNames.c_str()))
    {
      throw Failure(std::string("--label-names: ") + labelTable->GetLastError());
    }
  }
  else if (options.LabelNames.empty() && MaterialsAreLabels(options))
  {
    // An atlas's label table beside it, as MRIcron ships them (aal.nii.gz: aal.nii.txt).
    std::string beside =
      EndsWith(ToLower(input), ".gz") ? input.substr(0, input.size() - 3) : input;
    beside += ".txt";
    if (access(beside.c_str(), R_OK) == 0)
    {
      if (labelTable->ReadFile(beside.c_str()))
      {
        std::cout << "names:   " << beside << " (" << labelTable->GetNumberOfLabels()
                  << " labels, found beside the input; --label-names none ignores it)\n";
      }
      else
      {
        Diagnostics() << "stmesh: warning: the label table beside the input is ignored: "
                      << labelTable->GetLastError() << '\n';
        labelTable->RemoveAllLabels();
      }
    }
  }
  if (options.ReachesSnap() && options.Separating.Kind == SeparatingKind::Gray)
  {
    CheckReadableFile(options.Separating.GrayImage, ImageRole::Gray);
  }
  CheckWritableTarget(output, "output");
  if (!options.Interfaces.empty())
  {
    CheckWritableTarget(options.Interfaces, "--interfaces");
  }
  if (!options.SummaryPath.empty())
  {
    CheckWritableTarget(options.SummaryPath, "summary");
  }
  summary.Input = AbsolutePath(input);
  summary.Output = AbsolutePath(output);
  if (!options.SummaryPath.empty() && AbsolutePath(options.SummaryPath) == summary.Output)
  {
    throw Failure("the summary and the output are the same file '" + output + "'");
  }
  CheckOptionsForRanks(options, parallel.Ranks());
  summary.Ranks = parallel.Ranks();
  std::string threadNote;
  summary.Threads = SetUpThreads(ThreadsPerRank(options.Threads, parallel.Ranks(), threadNote));
  if (!threadNote.empty() && parallel.Rank() == 0)
  {
    Diagnostics() << threadNote;
  }
  WarnAboutIgnoredCutOptions(options);

  std::cout << "input:   " << input << '\n';
  std::cout << "output:  " << output << '\n';
  std::cout << "threads: " << summary.Threads.Threads << " (" << summary.Threads.Backend
            << " backend)" << (parallel.Ranks() > 1 ? " per rank" : "") << '\n';
  if (parallel.Ranks() > 1)
  {
    std::cout << "ranks:   " << parallel.Ranks()
              << " MPI ranks, each meshing its root cells with ghost root cells around them; "
                 "the table shows rank 0's piece\n";
  }
  std::cout.flush();

  const Clock::time_point start = Clock::now();

  StageReport readReport;
  readReport.Name = "read";
  // Under MPI each rank reads its own extent of the image (and merges its labels), when the
  // spacetree filter asks the reader for it; the table's read stage then samples the file.
  const bool readsPieces = parallel.Ranks() > 1;
  stmesh::ImageSource imageSource;
  std::unique_ptr<PieceMerge> pieceMerge;
  vtkSmartPointer<vtkImageData> image;
  if (readsPieces)
  {
    imageSource = OpenLabelImage(input, summary.Image, readReport);
    image = imageSource.Sample;
    if (!options.Merges.empty())
    {
      pieceMerge = std::unique_ptr<PieceMerge>(
        new PieceMerge(imageSource.Reader->GetOutputPort(), summary.Image, options));
    }
  }
  else
  {
    image = ReadMergedImage(input, options, summary.Image, readReport);
  }
  // Decided once the image's size is known; the image itself is already allocated.
  {
    const int* voxels = summary.Image.VoxelDimensions;
    summary.Memory = stmesh::ChooseMemoryPolicy(options.KeepMemory,
      static_cast<double>(voxels[0]) * voxels[1] * voxels[2], AvailableMemoryBytes(),
      std::getenv("GLIBC_TUNABLES"));
    stmesh::ApplyMemoryPolicy(summary.Memory);
  }
  // The structure report needs the (merged) labels after the meshing; a surface has none.
  ReportImage reportImage;
  const bool inPieces = meshFormat == MeshFormat::PartitionedXML;
  const bool reportsStructure = !options.WritesSurface() && !inPieces;
  if (reportsStructure && !readsPieces)
  {
    reportImage = MakeReportImage(image, summary.Image);
  }

  StageReport spacetreeReport;
  spacetreeReport.Name = "spacetree";
  vtkSmartPointer<vtkUnstructuredGrid> grid;
  {
    vtkNew<stmImageToSpacetree> spacetree;
    ConfigureSpacetree(spacetree, options, image, summary.Image);
    spacetree->SetSplitIntoPieces(parallel.Ranks() > 1);
    if (readsPieces)
    {
      spacetree->SetInputConnection(
        pieceMerge ? pieceMerge->Filter->GetOutputPort() : imageSource.Reader->GetOutputPort());
      grid = RunStage(spacetree, nullptr, "reading '" + input + "' and building the spacetree",
        spacetreeReport, true);
      readReport.Points = stmesh::CheckImagePiece(imageSource, summary.Image, input);
      readReport.Description += ", each rank's piece in the spacetree stage";
      if (pieceMerge)
      {
        CheckMergeSourcesSeen(options, SeenOnAnyRank(pieceMerge->Seen, parallel), input);
      }
    }
    else
    {
      grid = RunStage(spacetree, image, "building the spacetree", spacetreeReport, true);
    }
    spacetreeReport.ThinVoxels = static_cast<long long>(spacetree->GetNumberOfThinVoxels());
    if (spacetree->GetNumberOfThinVoxels() > 0)
    {
      spacetreeReport.Description +=
        ", " + std::to_string(spacetree->GetNumberOfThinVoxels()) + " thin voxels refined";
    }
    if (spacetree->GetNumberOfMinorityCornerVoxels() > 0)
    {
      spacetreeReport.Description += ", " +
        std::to_string(spacetree->GetNumberOfMinorityCornerVoxels()) +
        " corner voxels at voxel size";
    }
  }
  // The image is no longer needed: free it before the next stages.
  image = nullptr;
  pieceMerge.reset();
  imageSource = stmesh::ImageSource();
  summary.Stages.push_back(readReport);
  summary.Stages.push_back(spacetreeReport);
  summary.Levels = ReadLevelTable(grid);

  if (options.StopAfter != StopStage::Spacetree)
  {
    StageReport balanceReport;
    balanceReport.Name = "balance";
    if (options.BalanceLevel == 0)
    {
      balanceReport.Skipped = true;
      balanceReport.Description = "skipped (--balance 0)";
    }
    else
    {
      vtkNew<stmSpacetreeBalance> balance;
      vtkSmartPointer<vtkImplicitFunction> region;
      ConfigureBalance(balance, options, region);
      grid = RunStage(balance, grid, "balancing the spacetree", balanceReport, true);
      if (region && !RegionHoldsLeafCentre(grid, region))
      {
        Diagnostics() << "stmesh: warning: --balance-region contains no leaf centre of the "
                         "balanced spacetree (it lies outside the image or is smaller than the "
                         "leaves there); it had no effect\n";
      }
    }
    summary.Stages.push_back(balanceReport);
  }

  bool twoDimensional = false;
  if (options.StopAfter >= StopStage::Tessellate)
  {
    StageReport tessellateReport;
    tessellateReport.Name = "tessellate";
    vtkNew<stmSpacetreeTessellate> tessellate;
    tessellate->SetOutputType(options.Elements);
    tessellate->SetTemplateRule(options.TemplateRule);
    tessellate->SetCellTemplate(options.CellTemplate);
    tessellate->SetBoundaryLayers(options.BoundaryLayers);
    // The labels' function also for the gray image and the sphere: it brings the background
    // layers around the body in which their surfaces usually lie.
    switch (options.Separating.Kind)
    {
      case SeparatingKind::None:
        tessellate->SetSeparatingFunction(stmSpacetreeTessellate::NO_FUNCTION);
        break;
      case SeparatingKind::Smooth:
        tessellate->SetSeparatingFunction(stmSpacetreeTessellate::SMOOTHED_LABELS);
        tessellate->SetSmoothingSigma(options.Separating.Sigma);
        break;
      default:
        tessellate->SetSeparatingFunction(stmSpacetreeTessellate::LABELS);
        break;
    }
    if (options.Elements != stmSpacetreeTessellate::SIMPLICIAL)
    {
      for (const std::string& name : options.SimplicialOnlyOptions)
      {
        Diagnostics() << "stmesh: warning: " << name
                      << " applies to simplicial output only; ignored with --elements "
                      << KeywordName(options.Elements, ElementKinds) << '\n';
      }
    }
    grid = RunStage(tessellate, grid, "tessellating the spacetree", tessellateReport, false);
    tessellateReport.Tessellation = true;
    tessellateReport.InsertedPoints =
      static_cast<long long>(tessellate->GetNumberOfInsertedPoints());
    tessellateReport.CellsByType = CountCellsByType(grid);
    tessellateReport.TwoDimensional =
      std::any_of(tessellateReport.CellsByType.begin(), tessellateReport.CellsByType.end(),
        [](const std::pair<std::string, long long>& entry)
        { return entry.first == "triangle" || entry.first == "quad"; });
    if (options.Elements != stmSpacetreeTessellate::SIMPLICIAL)
    {
      tessellateReport.HexahedronVolumeFraction = HexahedronVolumeFraction(grid);
    }
    tessellateReport.BoundaryLayers = tessellate->GetNumberOfBoundaryLayers();
    tessellateReport.ShowBoundaryLayers = options.Separating.Kind != SeparatingKind::None;
    twoDimensional = tessellateReport.TwoDimensional;
    summary.Stages.push_back(tessellateReport);
  }

  // The gray image's or the sphere's function: computed as the snap stage begins (the snap
  // needs it), its time counted in the first stage that runs after the tessellation.
  SeparatingSource source;
  double functionSeconds = 0.0;
  if (options.ReachesSnap())
  {
    StageReport functionReport;
    grid = ApplySeparatingFunction(std::move(grid), options, source, functionReport);
    functionSeconds = functionReport.Seconds;

    StageReport snapReport;
    snapReport.Name = "snap";
    if (!options.Snaps())
    {
      snapReport.Skipped = true;
      snapReport.Description = options.SeparateMaterials && options.SnapRule != NoSnap
        ? "in the cut stage (--materials separate)"
        : "skipped (--snap none)";
    }
    else
    {
      snapReport.Seconds = functionSeconds;
      functionSeconds = 0.0;
      grid = RunSnap(std::move(grid), options, source, snapReport);
    }
    summary.Stages.push_back(snapReport);
  }

  vtkSmartPointer<vtkPointSet> mesh = grid;
  grid = nullptr;
  if (options.Cuts())
  {
    StageReport cutReport;
    cutReport.Name = "cut";
    cutReport.Seconds = functionSeconds;
    cutReport.TwoDimensional = twoDimensional;
    vtkSmartPointer<vtkUnstructuredGrid> tessellation = vtkUnstructuredGrid::SafeDownCast(mesh);
    mesh = nullptr; // RunCut frees the tessellation once it is cut
    mesh = RunCut(std::move(tessellation), options, cutReport);
    summary.Stages.push_back(cutReport);
  }

  if (options.ReachesSmooth())
  {
    StageReport smoothReport;
    smoothReport.Name = "smooth";
    smoothReport.TwoDimensional = twoDimensional;
    if (!options.Smooths())
    {
      smoothReport.Skipped = true;
      smoothReport.Description = "skipped (--smooth-iterations 0)";
    }
    else
    {
      vtkSmartPointer<vtkUnstructuredGrid> cutMesh = vtkUnstructuredGrid::SafeDownCast(mesh);
      mesh = nullptr;
      mesh = RunSmooth(std::move(cutMesh), options, source, smoothReport);
    }
    summary.Stages.push_back(smoothReport);
  }

  if (parallel.Ranks() > 1)
  {
    // A piece's ghost cells copy its neighbours' cells, held in place by the smoothing: they
    // are not part of the output.
    mesh = WithoutGhostCells(mesh);
    RankFigures figures;
    figures.Seconds = SecondsSince(start); // before the first exchange waits for the others
    figures.Cells = static_cast<long long>(mesh->GetNumberOfCells());
    figures.Points = static_cast<long long>(mesh->GetNumberOfPoints());
    figures.PeakRssMiB = PeakRssMiB();
    figures.VoxelsRead = readReport.Points;
    if (parallel.Sum(figures.Cells) == 0)
    {
      throw Failure("no rank meshed a cell: the body of interest is empty");
    }
    summary.RankTable = GatherRankFigures(figures, parallel);
    if (!inPieces)
    {
      StageReport gatherReport;
      gatherReport.Name = "gather";
      const Clock::time_point gatherStart = Clock::now();
      mesh = GatherOnFirstRank(mesh);
      gatherReport.Seconds = SecondsSince(gatherStart);
      gatherReport.Cells = static_cast<long long>(mesh->GetNumberOfCells());
      gatherReport.Points = static_cast<long long>(mesh->GetNumberOfPoints());
      gatherReport.Description = std::to_string(gatherReport.Cells) + " cells, " +
        std::to_string(gatherReport.Points) + " points on rank 0";
      RecordResources(gatherReport);
      summary.Stages.push_back(gatherReport);
      if (parallel.Rank() != 0)
      {
        return 0;
      }
    }
  }

  StageReport writeReport;
  writeReport.Name = "write";
  // Leaving out the background is part of the write stage.
  const Clock::time_point writeStart = Clock::now();
  summary.DroppedBackground = DropsBackground(options, meshFormat);
  if (summary.DroppedBackground)
  {
    mesh = WithoutBackground(mesh);
  }
  if (labelTable->GetNumberOfLabels() > 0)
  {
    labelTable->WriteFieldData(mesh->GetFieldData());
  }
  if (inPieces)
  {
    mesh = WithGlobalIds(mesh, parallel);
    const double preparation = SecondsSince(writeStart);
    WritePieces(mesh, output, options.Compressor, parallel, writeReport);
    writeReport.Seconds += preparation;
  }
  else
  {
    const double preparation = SecondsSince(writeStart);
    WriteMesh(mesh, output, meshFormat, options.Compressor, options.BinaryMsh, writeReport);
    writeReport.Seconds += preparation;
  }
  summary.Stages.push_back(writeReport);
  if (!options.Interfaces.empty())
  {
    summary.Stages.push_back(WriteInterfaces(mesh, options, twoDimensional));
  }
  summary.TotalSeconds = SecondsSince(start);

  summary.MaterialKey = MaterialCountKey(mesh, options, twoDimensional);
  summary.CellsPerMaterial = CountCellsPerMaterial(mesh);
  if (inPieces)
  {
    summary.CellsPerMaterial = SumOnFirstRank(summary.CellsPerMaterial, parallel);
  }

  PrintTable(summary.Stages, summary.TotalSeconds);
  if (summary.RankTable.size() > 1)
  {
    PrintRankTable(summary.RankTable);
  }
  // Measured after the timing: it is a report on the output, not a stage of the meshing.
  summary.Quality = MeasureMeshQuality(mesh);
  if (inPieces)
  {
    summary.Quality = CombineQuality(summary.Quality, parallel);
  }
  if (summary.Quality.Measured)
  {
    PrintQuality(summary.Quality, twoDimensional);
  }
  if (inPieces)
  {
    std::cout << "structure: not checked for a mesh in pieces; write one file (such as "
                 "-o mesh.vtu) for the report of lost components\n";
  }
  if (reportsStructure)
  {
    if (readsPieces)
    {
      // Rank 0 alone, once the others sent it their pieces.
      StageReport wholeRead;
      reportImage =
        MakeReportImage(ReadMergedImage(input, options, summary.Image, wholeRead), summary.Image);
    }
    const Clock::time_point reportStart = Clock::now();
    summary.Structure = MakeStructureReport(mesh, reportImage, options);
    summary.Structure.Seconds = SecondsSince(reportStart);
    reportImage = ReportImage();
    if (summary.Structure.Made)
    {
      PrintStructureReport(summary.Structure);
    }
  }
  if (!options.ReportDirectory.empty())
  {
    WriteReport(mesh, output, meshFormat, options, summary);
  }
  if (!options.SummaryPath.empty() && parallel.Rank() == 0)
  {
    WriteSummary(options.SummaryPath, options, summary);
    std::cout << "summary: " << options.SummaryPath << '\n';
  }
  return 0;
}

/// Prints the message, each line an "stmesh: error:" line; with several ranks, on rank 0 for
/// a mistake on the command line (every rank finds it) and with the rank's number otherwise.
void PrintErrorLines(const std::string& message, const ParallelRun& parallel, bool sameOnEveryRank)
{
  if (parallel.Ranks() > 1 && sameOnEveryRank && parallel.Rank() != 0)
  {
    return;
  }
  const std::string prefix = parallel.Ranks() > 1 && !sameOnEveryRank
    ? "stmesh: error: rank " + std::to_string(parallel.Rank()) + ": "
    : "stmesh: error: ";
  std::istringstream lines(message);
  std::string line;
  bool printed = false;
  while (std::getline(lines, line))
  {
    std::cerr << prefix << line << '\n';
    printed = true;
  }
  if (!printed)
  {
    std::cerr << prefix << "unknown error\n";
  }
}

/// The exit status of a failed run; with several ranks the others may wait for this one in an
/// exchange, so all of them end here.
int Failed(int status, ParallelRun& parallel)
{
  if (parallel.Ranks() > 1)
  {
    parallel.Abort(status);
  }
  return status;
}

/// MPI is started under an MPI launcher, with --mpi, and for a .pvtu output (written by
/// vtkXMLPUnstructuredGridWriter with MPI's controller, also by a single rank).
bool NeedsMPI(const Options& options)
{
  MeshFormat format;
  return options.Mpi || ReadLaunchEnvironment().Ranks > 0 ||
    (FindMeshFormat(options.Output, format) && format == MeshFormat::PartitionedXML);
}
} // namespace

int main(int argc, char* argv[])
{
  // Before MPI starts, a command-line mistake is printed by the launcher's rank 0 only.
  const LaunchEnvironment launch = ReadLaunchEnvironment();
  ParallelRun parallel;
  try
  {
    stmesh::InstallErrorCapture();
    for (int signalNumber : { SIGINT, SIGTERM, SIGHUP })
    {
      std::signal(signalNumber, RemovePendingTemporaryAndExit);
    }

    const Options options = ParseCommandLine(argc, argv);
    if (options.ShowHelp)
    {
      std::cout << UsageText;
      return 0;
    }
    if (options.ShowVersion)
    {
      std::cout << "stmesh (SpacetreeMesh) " << STMESH_VERSION << ", VTK "
                << vtkVersion::GetVTKVersion() << '\n';
      return 0;
    }
    if (NeedsMPI(options))
    {
      parallel.Start(&argc, &argv);
      if (parallel.Rank() != 0)
      {
        std::cout.setstate(std::ios::badbit); // rank 0 prints the run's table
      }
    }
    const int status = Run(options, parallel);
    std::cout.flush();
    return status;
  }
  catch (const UsageError& error)
  {
    if (launch.Rank == 0 && parallel.Rank() == 0)
    {
      PrintErrorLines(error.what(), parallel, true);
      std::cerr << "Try 'stmesh --help' for more information.\n";
    }
    return 2;
  }
  catch (const std::bad_alloc&)
  {
    PrintErrorLines("out of memory (try a larger --max-cell-size, fewer --labels or a higher "
                    "--balance level)",
      parallel, false);
    return Failed(1, parallel);
  }
  catch (const std::exception& error)
  {
    PrintErrorLines(error.what(), parallel, false);
    return Failed(1, parallel);
  }
  catch (...)
  {
    PrintErrorLines("unexpected internal error", parallel, false);
    return Failed(1, parallel);
  }
}
