// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   how the filters answer requests for pieces (pvbatch and pvserver under MPI), private
 *          to the module
 *
 * Under MPI every rank asks its pipeline for piece k of n. Meshing a piece of an image on its own
 * is wrong: each rank would mesh its slab with a boundary where the slabs meet, and the union
 * would have a seam of doubled points and facets. Until the stages exchange what they share
 * (issue 11), piece 0 meshes the whole image and the other pieces are empty: the stages that read
 * images ask for the whole image on piece 0 and for nothing on the others, and every stage gives
 * an empty input on a piece other than the first an empty output, quietly. With one piece (a
 * serial run) an empty input stays an error.
 */

#ifndef stmPieces_h
#define stmPieces_h

#include "vtkDataSet.h"
#include "vtkInformation.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include <string>

namespace stmPieces
{
/// The piece a request asks for (0 when it names none).
inline int RequestedPiece(vtkInformation* info)
{
  using Pipeline = vtkStreamingDemandDrivenPipeline;
  return info && info->Has(Pipeline::UPDATE_PIECE_NUMBER())
    ? info->Get(Pipeline::UPDATE_PIECE_NUMBER())
    : 0;
}

/// Asks the image on `imageInfo` (an input's information) for the whole image when
/// `requestInfo` (the output's request) is for piece 0, and for nothing otherwise.
inline void RequestWholeImageOnFirstPiece(vtkInformation* requestInfo, vtkInformation* imageInfo)
{
  using Pipeline = vtkStreamingDemandDrivenPipeline;
  if (!imageInfo)
  {
    return;
  }
  if (RequestedPiece(requestInfo) == 0)
  {
    imageInfo->Set(Pipeline::UPDATE_PIECE_NUMBER(), 0);
    imageInfo->Set(Pipeline::UPDATE_NUMBER_OF_PIECES(), 1);
    if (imageInfo->Has(Pipeline::WHOLE_EXTENT()))
    {
      imageInfo->Set(Pipeline::UPDATE_EXTENT(), imageInfo->Get(Pipeline::WHOLE_EXTENT()), 6);
    }
    return;
  }
  static const int nothing[6] = { 0, -1, 0, -1, 0, -1 };
  imageInfo->Set(Pipeline::UPDATE_EXTENT(), nothing, 6);
}

/// What a stage after ImageToSpacetree does with the request on `info` (its input's
/// information) and its input: false for piece 0, which it runs as usual; true for a later piece,
/// which gets an empty output. That is quiet when the input is empty, as ImageToSpacetree and
/// every stage after it make it; a later piece with cells is a mesh distributed by other means,
/// which the stages cannot mesh piece by piece yet, and `error` says so (else it stays empty).
inline bool IsLaterPiece(vtkInformation* info, vtkDataSet* input, std::string& error)
{
  const int piece = RequestedPiece(info);
  if (piece == 0)
  {
    return false;
  }
  if (input && input->GetNumberOfCells() > 0)
  {
    error = "piece " + std::to_string(piece) + " of the input has " +
      std::to_string(input->GetNumberOfCells()) +
      " cells: SpacetreeMesh does not mesh distributed data piece by piece yet; gather the mesh "
      "on one rank first, or start the pipeline from the image (ImageToSpacetree meshes it on "
      "the first rank)";
  }
  return true;
}
} // namespace stmPieces

#endif
