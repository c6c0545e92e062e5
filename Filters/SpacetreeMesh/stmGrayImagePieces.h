// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmGrayImagePieces
 * @brief   how a stage that samples a gray image at a piece's points (stmSeparatingFunction,
 *          stmVertexSnap) reads only the voxels it needs, private to the module
 *
 * The voxels a piece needs are those within one voxel of its points (stmSurfaceFunction closes
 * the image at its boundary, so no value depends on voxels farther away), but the points are
 * known only once the mesh has arrived, after the request for the image was made. So a request
 * for more than one piece runs in two passes, by the executive's CONTINUE_EXECUTING: the first
 * asks for what the gray image holds already (or its first voxel), for its geometry, finds the
 * box around the mesh's points and asks to be run again; the second asks for that box and
 * samples it. A piece with no points (the later
 * pieces of the default mode) has no second pass. A request for one piece (a serial run) reads
 * the whole image in one pass, as before.
 */

#ifndef stmGrayImagePieces_h
#define stmGrayImagePieces_h

#include "stmPieces.h"

#include "vtkDataObject.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkPointSet.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include <algorithm>
#include <cmath>

class stmGrayImagePieces
{
public:
  /// RequestUpdateExtent: the gray image's request (`grayInfo`, input port 1's information) for
  /// the output's request `outInfo`.
  void Request(vtkInformation* outInfo, vtkInformation* grayInfo) const
  {
    using Pipeline = vtkStreamingDemandDrivenPipeline;
    if (!grayInfo)
    {
      return;
    }
    if (!TwoPasses(outInfo) || !grayInfo->Has(Pipeline::WHOLE_EXTENT()))
    {
      stmPieces::RequestWholeImage(grayInfo);
      return;
    }
    if (this->HasBox)
    {
      stmPieces::RequestImageExtent(grayInfo, this->Box);
      return;
    }
    // The first pass needs only the image's geometry: what it holds already if that lies in
    // the image (nothing is read again), else its first voxel.
    int whole[6];
    grayInfo->Get(Pipeline::WHOLE_EXTENT(), whole);
    int held[6] = { 0, -1, 0, -1, 0, -1 };
    if (vtkImageData* image = vtkImageData::GetData(grayInfo))
    {
      image->GetExtent(held);
    }
    bool within = true;
    for (int axis = 0; axis < 3; ++axis)
    {
      within = within && whole[2 * axis] <= held[2 * axis] &&
        held[2 * axis] <= held[2 * axis + 1] && held[2 * axis + 1] <= whole[2 * axis + 1];
    }
    if (!within)
    {
      for (int axis = 0; axis < 3; ++axis)
      {
        held[2 * axis] = held[2 * axis + 1] = whole[2 * axis];
      }
    }
    stmPieces::RequestImageExtent(grayInfo, held);
  }

  /// RequestData, before the gray image is sampled: true when this is the first of two passes,
  /// which has asked for the box around `points` (a piece's, not empty); the caller then returns
  /// with an empty output. `gray` is what arrived (one voxel of the image, its geometry).
  bool IsFirstPass(vtkInformation* request, vtkInformation* outInfo, vtkInformation* grayInfo,
    vtkImageData* gray, vtkPointSet* points)
  {
    using Pipeline = vtkStreamingDemandDrivenPipeline;
    if (this->HasBox || !TwoPasses(outInfo) || !grayInfo || !gray || !points ||
      points->GetNumberOfPoints() == 0 || !grayInfo->Has(Pipeline::WHOLE_EXTENT()))
    {
      return false;
    }
    int whole[6];
    grayInfo->Get(Pipeline::WHOLE_EXTENT(), whole);
    double bounds[6];
    points->GetBounds(bounds);
    double low[3] = { VTK_DOUBLE_MAX, VTK_DOUBLE_MAX, VTK_DOUBLE_MAX };
    double high[3] = { VTK_DOUBLE_MIN, VTK_DOUBLE_MIN, VTK_DOUBLE_MIN };
    for (int corner = 0; corner < 8; ++corner)
    {
      const double x[3] = { bounds[corner & 1], bounds[2 + ((corner >> 1) & 1)],
        bounds[4 + ((corner >> 2) & 1)] };
      double index[3];
      gray->TransformPhysicalPointToContinuousIndex(x, index);
      for (int axis = 0; axis < 3; ++axis)
      {
        low[axis] = std::min(low[axis], index[axis]);
        high[axis] = std::max(high[axis], index[axis]);
      }
    }
    // Trilinear interpolation at index i reads voxels floor(i) and floor(i) + 1; one more on
    // each side covers rounding in the transform. Clamped into the image, the box still holds
    // the nearest voxel of every point beyond it.
    for (int axis = 0; axis < 3; ++axis)
    {
      const auto clamp = [&](double value)
      {
        value = std::min(std::max(value, static_cast<double>(whole[2 * axis])),
          static_cast<double>(whole[2 * axis + 1]));
        return static_cast<int>(value);
      };
      this->Box[2 * axis] = clamp(std::floor(low[axis]) - 1.0);
      this->Box[2 * axis + 1] = clamp(std::floor(high[axis]) + 2.0);
    }
    this->HasBox = true;
    request->Set(Pipeline::CONTINUE_EXECUTING(), 1);
    return true;
  }

  /// RequestData, at its end (every return) after the first pass: the next request starts over.
  void Finish(vtkInformation* request)
  {
    if (this->HasBox)
    {
      this->HasBox = false;
      request->Remove(vtkStreamingDemandDrivenPipeline::CONTINUE_EXECUTING());
    }
  }

  /// RequestData's guard: calls Finish on every return but the first pass's (KeepGoing).
  class Scope
  {
  public:
    Scope(stmGrayImagePieces* pieces, vtkInformation* request)
      : Pieces(pieces)
      , Request(request)
    {
    }
    ~Scope()
    {
      if (this->Pieces)
      {
        this->Pieces->Finish(this->Request);
      }
    }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;
    void KeepGoing() { this->Pieces = nullptr; }

  private:
    stmGrayImagePieces* Pieces;
    vtkInformation* Request;
  };

  /// The whole extent of the image on `grayInfo`, or null.
  static const int* WholeExtent(vtkInformation* grayInfo)
  {
    using Pipeline = vtkStreamingDemandDrivenPipeline;
    return grayInfo && grayInfo->Has(Pipeline::WHOLE_EXTENT())
      ? grayInfo->Get(Pipeline::WHOLE_EXTENT())
      : nullptr;
  }

private:
  static bool TwoPasses(vtkInformation* outInfo)
  {
    return stmPieces::RequestedNumberOfPieces(outInfo) > 1;
  }

  bool HasBox = false;
  int Box[6] = { 0, -1, 0, -1, 0, -1 };
};

#endif
