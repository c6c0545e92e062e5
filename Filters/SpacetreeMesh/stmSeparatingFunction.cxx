// SPDX-License-Identifier: BSD-3-Clause
#include "stmSeparatingFunction.h"

#include "stmGrayImagePieces.h"
#include "stmPieces.h"
#include "stmSurfaceFunction.h"

#include "vtkDataArray.h"
#include "vtkDoubleArray.h"
#include "vtkImageData.h"
#include "vtkImplicitFunction.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkPointSet.h"
#include "vtkPoints.h"
#include "vtkSMPTools.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

vtkStandardNewMacro(stmSeparatingFunction);
vtkCxxSetObjectMacro(stmSeparatingFunction, ImplicitFunction, vtkImplicitFunction);

stmSeparatingFunction::stmSeparatingFunction()
  : GrayPieces(new stmGrayImagePieces)
{
  this->SetNumberOfInputPorts(2);
}

stmSeparatingFunction::~stmSeparatingFunction()
{
  this->SetImplicitFunction(nullptr);
}

void stmSeparatingFunction::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Mode: " << (this->Mode == IMPLICIT_FUNCTION ? "ImplicitFunction" : "GrayImage")
     << "\n";
  os << indent << "ImplicitFunction: " << (this->ImplicitFunction ? "" : "(none)\n");
  if (this->ImplicitFunction)
  {
    os << "\n";
    this->ImplicitFunction->PrintSelf(os, indent.GetNextIndent());
  }
  os << indent << "Threshold: " << this->Threshold << "\n";
  os << indent << "InsideAboveThreshold: " << (this->InsideAboveThreshold ? "On" : "Off") << "\n";
}

vtkMTimeType stmSeparatingFunction::GetMTime()
{
  vtkMTimeType time = this->Superclass::GetMTime();
  if (this->ImplicitFunction)
  {
    time = std::max(time, this->ImplicitFunction->GetMTime());
  }
  return time;
}

int stmSeparatingFunction::FillInputPortInformation(int port, vtkInformation* info)
{
  if (port == 1)
  {
    info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
    return 1;
  }
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkPointSet");
  return 1;
}

int stmSeparatingFunction::ComputeInputUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  this->GrayPieces->Request(
    outputVector->GetInformationObject(0), inputVector[1]->GetInformationObject(0));
  return 1;
}

namespace
{
/// f at every point from the gray image (stmSurfaceFunction: trilinear on the image's point
/// grid, minus the threshold, negated for a bright inside).
bool SampleGrayImage(vtkImageData* image, const int* wholeExtent, double threshold,
  bool insideAbove, vtkPoints* points, double* f, std::string& error)
{
  stmSurfaceFunction function;
  if (!function.SetGrayImage(image, wholeExtent, threshold, insideAbove, error))
  {
    return false;
  }
  vtkSMPTools::For(0, points->GetNumberOfPoints(),
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType p = begin; p < end; ++p)
      {
        double x[3];
        points->GetPoint(p, x);
        f[p] = function.Evaluate(x);
      }
    });
  return true;
}
} // namespace

int stmSeparatingFunction::RequestData(vtkInformation* pipelineRequest,
  vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  stmGrayImagePieces::Scope grayPass(this->GrayPieces.get(), pipelineRequest);
  vtkPointSet* input = vtkPointSet::GetData(inputVector[0], 0);
  vtkPointSet* output = vtkPointSet::GetData(outputVector, 0);
  vtkInformation* inInfo = inputVector[0]->GetInformationObject(0);
  if (inInfo && inInfo->Get(vtkAlgorithm::ABORTED()))
  {
    output->Initialize();
    return 1;
  }
  auto fail = [&](const std::string& message)
  {
    output->Initialize();
    vtkErrorMacro(<< "SeparatingFunction failed: " << message);
    return 0;
  };
  std::string pieceError;
  if (stmPieces::SkipsPiece(inInfo, input, pieceError))
  {
    output->Initialize();
    return pieceError.empty() ? 1 : fail(pieceError);
  }
  if (!input || !input->GetPoints() || input->GetNumberOfPoints() == 0)
  {
    return fail("the input has no points");
  }
  output->ShallowCopy(input);
  const vtkIdType count = input->GetNumberOfPoints();
  vtkNew<vtkDoubleArray> function;
  function->SetName("SeparatingFunction");
  function->SetNumberOfValues(count);
  double* f = function->GetPointer(0);
  this->UpdateProgress(0.1);
  if (this->Mode == IMPLICIT_FUNCTION)
  {
    if (!this->ImplicitFunction)
    {
      return fail("no implicit function is set (Mode is Implicit Function)");
    }
    vtkImplicitFunction* implicit = this->ImplicitFunction;
    vtkPoints* points = input->GetPoints();
    // vtkImplicitFunction::FunctionValue is not documented as thread-safe: evaluate serially,
    // polling abort every block.
    const vtkIdType block = 65536;
    for (vtkIdType first = 0; first < count; first += block)
    {
      if (this->CheckAbort())
      {
        output->Initialize();
        return 1;
      }
      const vtkIdType last = std::min(count, first + block);
      for (vtkIdType p = first; p < last; ++p)
      {
        double x[3];
        points->GetPoint(p, x);
        f[p] = implicit->FunctionValue(x);
      }
      this->UpdateProgress(0.1 + 0.8 * static_cast<double>(last) / static_cast<double>(count));
    }
  }
  else
  {
    vtkImageData* image = vtkImageData::GetData(inputVector[1], 0);
    if (!image)
    {
      return fail("no gray image on input port 1 (Mode is Gray Image)");
    }
    vtkInformation* grayInfo = inputVector[1]->GetInformationObject(0);
    if (this->GrayPieces->IsFirstPass(
          pipelineRequest, outputVector->GetInformationObject(0), grayInfo, image, input))
    {
      // The second pass samples the voxels around the piece's points.
      output->Initialize();
      grayPass.KeepGoing();
      return 1;
    }
    std::string error;
    if (!SampleGrayImage(image, stmGrayImagePieces::WholeExtent(grayInfo), this->Threshold,
          this->InsideAboveThreshold, input->GetPoints(), f, error))
    {
      return fail(error);
    }
  }
  output->GetPointData()->SetScalars(function);
  this->UpdateProgress(1.0);
  return 1;
}
