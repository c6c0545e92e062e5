// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   how the filters answer requests for pieces (pvbatch and pvserver under MPI), private
 *          to the module
 *
 * Under MPI every rank asks its pipeline for piece k of n. Meshing the slabs a reader splits an
 * image into, each on its own, is wrong: the union would have a seam of doubled points and
 * facets where the slabs meet. So by default piece 0 meshes the whole image and the other
 * pieces are empty: the stages that read images ask for the whole image on piece 0 and for
 * nothing on the others, and every stage gives an empty input on such a piece an empty output,
 * quietly. With one piece (a serial run) an empty input stays an error.
 *
 * With stmImageToSpacetree::SplitIntoPieces, piece k builds the root cells of box k of n
 * (stm::PieceRootBox) from its voxels and those of two layers of ghost root cells around it;
 * the tree and every mesh made of it carry the field array PieceMarkerName and vtkGhostType on
 * the ghost layer's leaves and cells, and the later stages mesh such a piece like a whole image.
 * The cuts keep of the ghost cells only the rings their request asks for, at least the one ring
 * the smoothing reads (stmCutInput::KeepGhostRings).
 */

#ifndef stmPieces_h
#define stmPieces_h

#include "vtkCellData.h"
#include "vtkDataSet.h"
#include "vtkDataSetAttributes.h"
#include "vtkFieldData.h"
#include "vtkInformation.h"
#include "vtkIntArray.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkSmartPointer.h"
#include "vtkStreamingDemandDrivenPipeline.h"
#include "vtkUnsignedCharArray.h"

#include <algorithm>
#include <cstdint>
#include <string>

namespace stmPieces
{
/// The global controller when the request on `info` (the output's information) asks for piece
/// k of n on rank k of n ranks, n > 1: each rank then meshes its own piece. Null otherwise
/// (one process, or a pipeline that asks one rank for several pieces).
inline vtkMultiProcessController* ControllerOfPieces(vtkInformation* info)
{
  using Pipeline = vtkStreamingDemandDrivenPipeline;
  vtkMultiProcessController* controller = vtkMultiProcessController::GetGlobalController();
  if (!controller || controller->GetNumberOfProcesses() < 2 || !info ||
    !info->Has(Pipeline::UPDATE_NUMBER_OF_PIECES()) || !info->Has(Pipeline::UPDATE_PIECE_NUMBER()))
  {
    return nullptr;
  }
  return info->Get(Pipeline::UPDATE_NUMBER_OF_PIECES()) == controller->GetNumberOfProcesses() &&
      info->Get(Pipeline::UPDATE_PIECE_NUMBER()) == controller->GetLocalProcessId()
    ? controller
    : nullptr;
}

/// The piece a request asks for (0 when it names none).
inline int RequestedPiece(vtkInformation* info)
{
  using Pipeline = vtkStreamingDemandDrivenPipeline;
  return info && info->Has(Pipeline::UPDATE_PIECE_NUMBER())
    ? info->Get(Pipeline::UPDATE_PIECE_NUMBER())
    : 0;
}

/// Asks the image on `imageInfo` (an input's information) for `extent` (not null) as piece 0
/// of 1, so that an image reader does not split it further.
inline void RequestImageExtent(vtkInformation* imageInfo, const int* extent)
{
  using Pipeline = vtkStreamingDemandDrivenPipeline;
  imageInfo->Set(Pipeline::UPDATE_PIECE_NUMBER(), 0);
  imageInfo->Set(Pipeline::UPDATE_NUMBER_OF_PIECES(), 1);
  if (extent)
  {
    imageInfo->Set(Pipeline::UPDATE_EXTENT(), extent, 6);
  }
}

/// Asks the image on `imageInfo` for all of it (its whole extent, where known).
inline void RequestWholeImage(vtkInformation* imageInfo)
{
  using Pipeline = vtkStreamingDemandDrivenPipeline;
  if (imageInfo)
  {
    RequestImageExtent(imageInfo,
      imageInfo->Has(Pipeline::WHOLE_EXTENT()) ? imageInfo->Get(Pipeline::WHOLE_EXTENT())
                                               : nullptr);
  }
}

/// Asks the image on `imageInfo` for the whole image when `requestInfo` (the output's request)
/// is for piece 0, and for nothing otherwise.
inline void RequestWholeImageOnFirstPiece(vtkInformation* requestInfo, vtkInformation* imageInfo)
{
  using Pipeline = vtkStreamingDemandDrivenPipeline;
  if (!imageInfo || RequestedPiece(requestInfo) == 0)
  {
    RequestWholeImage(imageInfo);
    return;
  }
  static const int nothing[6] = { 0, -1, 0, -1, 0, -1 };
  imageInfo->Set(Pipeline::UPDATE_EXTENT(), nothing, 6);
}

/// Field array of a tree or mesh that is a piece of a larger image's (SplitIntoPieces).
constexpr const char* PieceMarkerName = "SpacetreeMeshPiece";

/// Cell array of the tessellation and the meshes cut from it: per cell the colour of the root
/// cell it lies in (stm::RootColouring), by which stmBoundarySmooth orders its moves alike in a
/// whole mesh and in every piece of it. The smoothing removes it from its output.
constexpr const char* RootColourName = "RootColour";

/// Field array of a piece of stmMultiMaterialCut's output, rows (material, part): the piece's
/// OriginalMaterialVolumes as exact parts (stm::ExactSum::Parts), which the pieces' smoothing
/// adds up to the whole mesh's volumes bit for bit. The smoothing removes it from its output.
constexpr const char* VolumePartsName = "OriginalMaterialVolumeParts";

/// The number of pieces a request asks for (1 when it names none).
inline int RequestedNumberOfPieces(vtkInformation* info)
{
  using Pipeline = vtkStreamingDemandDrivenPipeline;
  return info && info->Has(Pipeline::UPDATE_NUMBER_OF_PIECES())
    ? info->Get(Pipeline::UPDATE_NUMBER_OF_PIECES())
    : 1;
}

/// Marks a dataset as a piece made with SplitIntoPieces, so that the later stages mesh it
/// although the pipeline asks for a piece other than the first (SkipsPiece).
inline void MarkPiece(vtkFieldData* fieldData)
{
  vtkNew<vtkIntArray> marker;
  marker->SetName(PieceMarkerName);
  marker->InsertNextValue(1);
  fieldData->AddArray(marker);
}

/// Whether a dataset is a piece made with SplitIntoPieces.
inline bool IsMarkedPiece(vtkDataSet* data)
{
  return data && data->GetFieldData() && data->GetFieldData()->GetArray(PieceMarkerName);
}

/// Marks `output` as a piece when `input` is one: for the stages whose output field data the
/// executive does not pass on.
inline void PassPieceMarker(vtkDataSet* input, vtkDataSet* output)
{
  if (output && IsMarkedPiece(input))
  {
    MarkPiece(output->GetFieldData());
  }
}

/// A piece's vtkGhostType per cell (non-zero: a ghost), or null for a dataset without it.
inline const unsigned char* GhostCellFlags(vtkDataSet* data)
{
  auto* ghosts = data ? vtkUnsignedCharArray::SafeDownCast(
                          data->GetCellData()->GetArray(vtkDataSetAttributes::GhostArrayName()))
                      : nullptr;
  return ghosts ? ghosts->GetPointer(0) : nullptr;
}

/// Whether `data` is a piece with at least one ghost cell (the exchanging stages' condition).
inline bool HasGhostCells(vtkDataSet* data)
{
  const unsigned char* ghosts = GhostCellFlags(data);
  return ghosts &&
    std::any_of(ghosts, ghosts + data->GetNumberOfCells(), [](unsigned char g) { return g != 0; });
}

/// A new vtkGhostType array of `count` values, to be filled.
inline vtkSmartPointer<vtkUnsignedCharArray> NewGhostArray(vtkIdType count)
{
  auto ghosts = vtkSmartPointer<vtkUnsignedCharArray>::New();
  ghosts->SetName(vtkDataSetAttributes::GhostArrayName());
  ghosts->SetNumberOfValues(count);
  return ghosts;
}

/// For the facets of a surface taken from the cells of `input`: vtkGhostType per facet, that of
/// the cell facet f was taken from (sourceCells[f]), so that every facet is owned by exactly one
/// piece (the facets at a ghost layer's outer end are ghosts too). Nothing for an input without
/// ghost cells.
inline void AddFacetGhosts(
  vtkDataSet* input, const std::int64_t* sourceCells, vtkIdType facets, vtkDataSet* output)
{
  const unsigned char* cellGhosts = GhostCellFlags(input);
  if (!cellGhosts)
  {
    return;
  }
  vtkSmartPointer<vtkUnsignedCharArray> facetGhosts = NewGhostArray(facets);
  for (vtkIdType f = 0; f < facets; ++f)
  {
    facetGhosts->SetValue(f, cellGhosts[sourceCells[f]]);
  }
  output->GetCellData()->AddArray(facetGhosts);
}

/// What a stage after ImageToSpacetree does with the request on `info` (its input's
/// information) and its input: true when it gives an empty output, quietly when `error` stays
/// empty. An empty input gives an empty output quietly when the request is for one of several
/// pieces (another piece holds the mesh). A piece with cells is meshed when it is the first or
/// a piece made with SplitIntoPieces; a later piece with cells and no marker is a mesh
/// distributed by other means, which the stages cannot mesh piece by piece (snapping and
/// smoothing look across the pieces' boundary), and `error` says so.
inline bool SkipsPiece(vtkInformation* info, vtkDataSet* input, std::string& error)
{
  const int piece = RequestedPiece(info);
  if (!input || input->GetNumberOfCells() == 0)
  {
    return piece > 0 || RequestedNumberOfPieces(info) > 1;
  }
  if (piece == 0 || IsMarkedPiece(input))
  {
    return false;
  }
  error = "piece " + std::to_string(piece) + " of the input has " +
    std::to_string(input->GetNumberOfCells()) +
    " cells: SpacetreeMesh meshes a distributed image piece by piece only from ImageToSpacetree "
    "with Split Into Pieces on; gather the mesh on one rank first, or start the pipeline from "
    "the image";
  return true;
}
} // namespace stmPieces

#endif
