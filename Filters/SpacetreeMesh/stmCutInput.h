// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   the input checks shared by the filters that work on a separating function of a
 *          simplicial mesh (private to the module)
 *
 * stmMarchingSimplices, stmVertexSnap and stmBoundarySmooth accept the same meshes (only
 * tetrahedra or only triangles), and the first two find the separating function the same way,
 * so that a pipeline that works with one works with the others.
 */

#ifndef stmCutInput_h
#define stmCutInput_h

#include "stmPieces.h"
#include "stmSMPExecutor.h"

#include "Common/GhostRings.h"

#include "vtkAOSDataArrayTemplate.h"
#include "vtkAlgorithm.h"
#include "vtkArrayDispatch.h"
#include "vtkCellArray.h"
#include "vtkCellData.h"
#include "vtkCellType.h"
#include "vtkDataArray.h"
#include "vtkDataArrayRange.h"
#include "vtkDataObject.h"
#include "vtkDataSetAttributes.h"
#include "vtkIdList.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkNew.h"
#include "vtkPointData.h"
#include "vtkPoints.h"
#include "vtkSMPTools.h"
#include "vtkSmartPointer.h"
#include "vtkTypeInt32Array.h"
#include "vtkTypeInt64Array.h"
#include "vtkUnsignedCharArray.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

namespace stmCutInput
{
/// The one dispatch of the simplicial filters: run(std::integral_constant<int, Dim>, ids) with
/// the cells' connectivity as stored (32- or 64-bit ids) and Dim 3 for tetrahedra, else 2.
template <class Run>
auto DispatchSimplices(vtkCellArray* cells, int dimension, Run&& run)
{
  using Three = std::integral_constant<int, 3>;
  using Two = std::integral_constant<int, 2>;
  if (cells->IsStorage64Bit())
  {
    const vtkTypeInt64* ids = cells->GetConnectivityArray64()->GetPointer(0);
    return dimension == 3 ? run(Three(), ids) : run(Two(), ids);
  }
  const vtkTypeInt32* ids = cells->GetConnectivityArray32()->GetPointer(0);
  return dimension == 3 ? run(Three(), ids) : run(Two(), ids);
}

/// A cell array of cells with `corners` points each whose connectivity is `connectivity`
/// itself, not a copy (a vtkTypeInt32Array or vtkTypeInt64Array): only the offsets are made.
template <class Storage>
vtkSmartPointer<vtkCellArray> FixedSizeCellsSharing(Storage* connectivity, int corners)
{
  using Value = typename Storage::ValueType;
  const vtkIdType cells = connectivity->GetNumberOfValues() / corners;
  vtkNew<Storage> offsets;
  offsets->SetNumberOfValues(cells + 1);
  Value* offsetValues = offsets->GetPointer(0);
  vtkSMPTools::For(0, cells + 1,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType c = begin; c < end; ++c)
      {
        offsetValues[c] = static_cast<Value>(c * corners);
      }
    });
  vtkNew<vtkCellArray> cellArray;
  cellArray->SetData(offsets, connectivity);
  return cellArray;
}

/// The rings of ghost cells a cut keeps of a piece (stm::GhostRings): those the request on
/// `outputInfo` asks for (UPDATE_NUMBER_OF_GHOST_LEVELS, VTK's ghost levels), and at least one,
/// the cells that share a point with the own cells: a smoothing of the output then holds every
/// point the piece shares with its neighbours, and its own points move as with every ghost cell.
inline int KeptGhostRings(vtkInformation* outputInfo)
{
  using Pipeline = vtkStreamingDemandDrivenPipeline;
  const int requested = outputInfo && outputInfo->Has(Pipeline::UPDATE_NUMBER_OF_GHOST_LEVELS())
    ? outputInfo->Get(Pipeline::UPDATE_NUMBER_OF_GHOST_LEVELS())
    : 0;
  return std::max(1, requested);
}

/// Moves the tuples i of `array` with kept(i), i < count, to the front in their order, in place,
/// and frees the rest.
template <class Kept>
void KeepTuples(vtkAbstractArray* array, vtkIdType count, Kept&& kept)
{
  vtkIdType next = 0;
  auto* data = vtkDataArray::SafeDownCast(array);
  if (data && data->HasStandardMemoryLayout())
  {
    auto* bytes = static_cast<char*>(data->GetVoidPointer(0));
    // A copy of a known size is a move of a register or two, not a call.
    auto move = [&](auto tupleBytes)
    {
      constexpr std::size_t size = decltype(tupleBytes)::value;
      const std::size_t bytesPerTuple = size > 0
        ? size
        : static_cast<std::size_t>(data->GetDataTypeSize() * data->GetNumberOfComponents());
      for (vtkIdType i = 0; i < count; ++i)
      {
        if (kept(i))
        {
          if (next != i)
          {
            std::memcpy(bytes + next * bytesPerTuple, bytes + i * bytesPerTuple,
              size > 0 ? size : bytesPerTuple);
          }
          ++next;
        }
      }
    };
    switch (data->GetDataTypeSize() * data->GetNumberOfComponents())
    {
      case 1:
        move(std::integral_constant<std::size_t, 1>());
        break;
      case 4:
        move(std::integral_constant<std::size_t, 4>());
        break;
      case 8:
        move(std::integral_constant<std::size_t, 8>());
        break;
      case 24:
        move(std::integral_constant<std::size_t, 24>());
        break;
      default:
        move(std::integral_constant<std::size_t, 0>());
    }
  }
  else
  {
    for (vtkIdType i = 0; i < count; ++i)
    {
      if (kept(i))
      {
        if (next != i)
        {
          array->SetTuple(next, i, array);
        }
        ++next;
      }
    }
  }
  array->SetNumberOfTuples(next);
  array->Squeeze();
  array->Modified();
}

/// Drops, in place, the ghost cells of a piece's cut mesh (triangles or tetrahedra) beyond
/// `rings` rings of its own cells, and the points only they used. The piece meshed two root
/// cells of ghosts for its snapping and cut; the smoothing after the cut reads one ring, and
/// the rest of the layer (AAL upsampled 2x, rank 0 of 2: 1.6 of 12.3 million cells) cost it
/// memory and time. Points and cells keep their order. Nothing for a mesh without ghost cells.
inline void KeepGhostRings(
  vtkUnstructuredGrid* mesh, int dimension, int rings, vtkAlgorithm* algorithm)
{
  const unsigned char* ghosts = stmPieces::GhostCellFlags(mesh);
  vtkCellArray* cells = mesh ? mesh->GetCells() : nullptr;
  if (!ghosts || !cells || mesh->GetNumberOfCells() == 0)
  {
    return;
  }
  const vtkIdType numberOfCells = mesh->GetNumberOfCells();
  const vtkIdType numberOfPoints = mesh->GetNumberOfPoints();
  const int corners = dimension + 1;
  auto keep = [&](auto* storage)
  {
    using Value = typename std::remove_pointer_t<decltype(storage)>::ValueType;
    Value* ids = storage->GetPointer(0);
    stmSMPExecutor executor(algorithm);
    const std::vector<std::uint8_t> cellRings =
      stm::GhostRings(ids, corners, numberOfCells, numberOfPoints, ghosts, rings, executor);
    if (executor.ShouldAbort())
    {
      return; // the rings are incomplete: the mesh stays whole, and the abort is the caller's
    }
    auto cellKept = [&](vtkIdType c) { return cellRings[c] != stm::NotInAnyRing; };
    // Per point, its new id, or -1 for a point of dropped cells only.
    std::vector<vtkIdType> newPointIds(static_cast<std::size_t>(numberOfPoints), -1);
    vtkIdType kept = 0;
    for (vtkIdType c = 0; c < numberOfCells; ++c)
    {
      if (cellKept(c))
      {
        ++kept;
        for (int v = 0; v < corners; ++v)
        {
          newPointIds[static_cast<std::size_t>(ids[c * corners + v])] = 0;
        }
      }
    }
    if (kept == numberOfCells)
    {
      return;
    }
    vtkIdType keptPoints = 0;
    for (vtkIdType& id : newPointIds)
    {
      id = id == 0 ? keptPoints++ : id;
    }
    vtkIdType next = 0;
    for (vtkIdType c = 0; c < numberOfCells; ++c)
    {
      if (cellKept(c))
      {
        for (int v = 0; v < corners; ++v)
        {
          ids[next * corners + v] =
            static_cast<Value>(newPointIds[static_cast<std::size_t>(ids[c * corners + v])]);
        }
        ++next;
      }
    }
    // The connectivity array itself, shrunk, with new offsets.
    storage->SetNumberOfValues(kept * corners);
    storage->Squeeze();
    vtkSmartPointer<vtkCellArray> keptCellArray = FixedSizeCellsSharing(storage, corners);
    mesh->SetCells(dimension == 3 ? VTK_TETRA : VTK_TRIANGLE, keptCellArray);
    vtkCellData* cellData = mesh->GetCellData();
    for (int a = 0; a < cellData->GetNumberOfArrays(); ++a)
    {
      KeepTuples(cellData->GetAbstractArray(a), numberOfCells, cellKept);
    }
    auto pointKept = [&](vtkIdType p) { return newPointIds[p] >= 0; };
    KeepTuples(mesh->GetPoints()->GetData(), numberOfPoints, pointKept);
    mesh->GetPoints()->Modified();
    vtkPointData* pointData = mesh->GetPointData();
    for (int a = 0; a < pointData->GetNumberOfArrays(); ++a)
    {
      KeepTuples(pointData->GetAbstractArray(a), numberOfPoints, pointKept);
    }
    mesh->Modified();
  };
  if (cells->IsStorage64Bit())
  {
    keep(cells->GetConnectivityArray64());
  }
  else
  {
    keep(cells->GetConnectivityArray32());
  }
}

/// A cell array of cells with `corners` points each from their point ids (any integer type),
/// stored with OutId ids (32- or 64-bit), copied in parallel.
template <class OutId, class SourceId>
vtkSmartPointer<vtkCellArray> FixedSizeCells(const std::vector<SourceId>& ids, int corners)
{
  using Storage =
    typename std::conditional<sizeof(OutId) == 4, vtkTypeInt32Array, vtkTypeInt64Array>::type;
  using Value = typename Storage::ValueType;
  vtkNew<Storage> connectivity;
  connectivity->SetNumberOfValues(static_cast<vtkIdType>(ids.size()));
  Value* idValues = connectivity->GetPointer(0);
  vtkSMPTools::For(0, static_cast<vtkIdType>(ids.size()),
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType i = begin; i < end; ++i)
      {
        idValues[i] = static_cast<Value>(ids[i]);
      }
    });
  return FixedSizeCellsSharing(connectivity.GetPointer(), corners);
}

/// The cell array `name` ("Material" by default) as 64-bit integers (in parallel); empty
/// without it.
inline std::vector<std::int64_t> CellMaterials(
  vtkUnstructuredGrid* input, const char* name = "Material")
{
  std::vector<std::int64_t> materials;
  vtkDataArray* material = input->GetCellData()->GetArray(name);
  if (!material)
  {
    return materials;
  }
  materials.resize(static_cast<std::size_t>(input->GetNumberOfCells()));
  vtkSMPTools::For(0, input->GetNumberOfCells(),
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType c = begin; c < end; ++c)
      {
        materials[c] = static_cast<std::int64_t>(material->GetComponent(c, 0));
      }
    });
  return materials;
}

/// Returns run(materials) with the cells' "Material" array as the core reads it: the array's
/// own values when it holds one component of 32- or 64-bit integers (no copy of 8 bytes per
/// cell), else a 64-bit copy of its first component; nullptr when there is no such array.
template <class Run>
auto WithCellMaterials(vtkUnstructuredGrid* input, Run&& run)
{
  vtkDataArray* array = input->GetCellData()->GetArray("Material");
  if (array && array->GetNumberOfComponents() == 1 && array->GetNumberOfTuples() > 0)
  {
    if (auto* narrow = vtkAOSDataArrayTemplate<vtkTypeInt32>::FastDownCast(array))
    {
      return run(static_cast<const vtkTypeInt32*>(narrow->GetPointer(0)));
    }
    if (auto* wide = vtkAOSDataArrayTemplate<vtkTypeInt64>::FastDownCast(array))
    {
      return run(static_cast<const vtkTypeInt64*>(wide->GetPointer(0)));
    }
  }
  const std::vector<std::int64_t> copy = CellMaterials(input);
  return run(copy.empty() ? static_cast<const std::int64_t*>(nullptr) : copy.data());
}

/// The dimension of a mesh of only tetrahedra (3) or only triangles (2); 0 otherwise, with the
/// offending cell type. The mesh must have cells.
inline int SimplexDimension(vtkUnstructuredGrid* input, int& offendingType)
{
  vtkUnsignedCharArray* types = input->GetCellTypesArray();
  const vtkIdType cells = input->GetNumberOfCells();
  const unsigned char first = types->GetValue(0);
  offendingType = first;
  if (first != VTK_TETRA && first != VTK_TRIANGLE)
  {
    return 0;
  }
  for (vtkIdType c = 1; c < cells; ++c)
  {
    if (types->GetValue(c) != first)
    {
      offendingType = types->GetValue(c);
      return 0;
    }
  }
  return first == VTK_TETRA ? 3 : 2;
}

/// SimplexDimension with the error message the filters give: 0 with `error` set (ending with
/// `remedy`, what the user can do) when the mesh has other cells.
inline int SimplexDimension(vtkUnstructuredGrid* input, const char* remedy, std::string& error)
{
  int offendingType = 0;
  const int dimension = SimplexDimension(input, offendingType);
  if (dimension == 0)
  {
    error = "the input must be a mesh of only tetrahedra or only triangles, but it has cells of "
            "VTK type " +
      std::to_string(offendingType) + "; " + remedy;
  }
  return dimension;
}

/// The checks every simplicial filter makes first: -1 when an upstream filter was aborted or the
/// request is for one of several pieces with an empty input (stmPieces::SkipsPiece) (the filter
/// then returns 1 with an empty output, quietly); 0 with `error` set when the input has no
/// cells, or cells that are not all tetrahedra or all triangles (`remedy` says what to do), or
/// is a later piece with cells not made by SplitIntoPieces; else the dimension, 3 or 2.
inline int Preflight(vtkInformationVector* inputVector, vtkUnstructuredGrid* input,
  const char* remedy, std::string& error)
{
  vtkInformation* inInfo = inputVector->GetInformationObject(0);
  if (inInfo && inInfo->Get(vtkAlgorithm::ABORTED()))
  {
    return -1;
  }
  if (stmPieces::SkipsPiece(inInfo, input, error))
  {
    return error.empty() ? -1 : 0;
  }
  if (!input || input->GetNumberOfCells() == 0 || !input->GetPoints())
  {
    error = "the input mesh has no cells";
    return 0;
  }
  return SimplexDimension(input, remedy, error);
}

/// What the cutting filters tell a user whose mesh is not simplicial.
constexpr const char* TessellateSimplicialFirst =
  "tessellate with Output Type Simplicial (or run Tetrahedralize) first";

/// The separating function: `selected` and `association` as GetInputArrayToProcess(0, ...)
/// returned them, `name` the selection's FIELD_NAME. When the selection names no array (a
/// script that created the filter before its input had data), the point array
/// "SeparatingFunction" of the stage before, else the active point scalars. Null with `error`
/// set when there is none or it is not a point scalar.
inline vtkDataArray* FindSeparatingFunction(vtkDataArray* selected, int association,
  const char* name, vtkUnstructuredGrid* input, std::string& error)
{
  vtkDataArray* function = selected;
  if (!function && (!name || !*name))
  {
    function = input->GetPointData()->GetArray("SeparatingFunction");
    function = function ? function : input->GetPointData()->GetScalars();
    association = vtkDataObject::FIELD_ASSOCIATION_POINTS;
  }
  if (!function || association != vtkDataObject::FIELD_ASSOCIATION_POINTS)
  {
    error = std::string("no point array '") + (name ? name : "") +
      "' to use as the separating function; compute one (Spacetree Tessellate, Separating "
      "Function) or select an existing point array";
    return nullptr;
  }
  if (function->GetNumberOfComponents() != 1)
  {
    error = std::string("the separating function '") +
      (function->GetName() ? function->GetName() : "") + "' has " +
      std::to_string(function->GetNumberOfComponents()) + " components; it must be a scalar";
    return nullptr;
  }
  return function;
}
/// Copies tuple ids[i] of each array to tuple start + i of its copy, on all threads.
template <class Id>
struct GatherWorker
{
  const Id* Ids;
  vtkIdType Count;
  vtkIdType Start;
  template <class SourceArray, class TargetArray>
  void operator()(SourceArray* source, TargetArray* target) const
  {
    const auto in = vtk::DataArrayTupleRange(source);
    auto out = vtk::DataArrayTupleRange(target);
    vtkSMPTools::For(0, this->Count,
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType i = begin; i < end; ++i)
        {
          out[this->Start + i] = in[static_cast<vtkIdType>(this->Ids[i])];
        }
      });
  }
};

/// What out->CopyData(in, ids, start) gives (out made from `in` by CopyAllocate or
/// InterpolateAllocate; tuple ids[i] to tuple start + i, the arrays ending at start + count),
/// each array gathered on all threads: VTK 9.2 copies a tuple at a time through the generic
/// array interface (the 116 labels' cell materials, 7.7 million: 0.09 s on one thread). When an
/// array of `out` has no data array of its name, type and components in `in`, CopyData does it.
template <class Id>
void GatherTuples(vtkDataSetAttributes* in, vtkDataSetAttributes* out, const Id* ids,
  vtkIdType count, vtkIdType start)
{
  std::vector<std::pair<vtkDataArray*, vtkDataArray*>> pairs;
  bool paired = true;
  for (int i = 0; i < out->GetNumberOfArrays() && paired; ++i)
  {
    vtkDataArray* target = out->GetArray(i);
    const char* name = target ? target->GetName() : nullptr;
    vtkDataArray* source = name ? in->GetArray(name) : nullptr;
    paired = source && source->GetDataType() == target->GetDataType() &&
      source->GetNumberOfComponents() == target->GetNumberOfComponents();
    pairs.emplace_back(source, target);
  }
  if (!paired)
  {
    vtkNew<vtkIdList> list;
    list->SetNumberOfIds(count);
    std::copy(ids, ids + count, list->GetPointer(0));
    out->CopyData(in, list, start);
    return;
  }
  const GatherWorker<Id> worker{ ids, count, start };
  for (const auto& pair : pairs)
  {
    pair.second->SetNumberOfTuples(start + count);
    if (!vtkArrayDispatch::Dispatch2SameValueType::Execute(pair.first, pair.second, worker))
    {
      worker(pair.first, pair.second);
    }
  }
}

} // namespace stmCutInput

#endif
