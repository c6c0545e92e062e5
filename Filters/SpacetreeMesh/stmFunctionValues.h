// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   the values of a scalar array as doubles for the core (private to the module)
 *
 * The one array-type dispatch point of the filters that read a separating function: a
 * contiguous double array is used in place; any other numeric array is converted through
 * vtkArrayDispatch (typed fast paths for the real and integer types, a generic fallback).
 */

#ifndef stmFunctionValues_h
#define stmFunctionValues_h

#include "vtkAOSDataArrayTemplate.h"
#include "vtkArrayDispatch.h"
#include "vtkDataArray.h"
#include "vtkDataArrayRange.h"
#include "vtkSMPTools.h"

#include <vector>

namespace stmFunctionValues
{
struct ToDoubles
{
  template <class ArrayType>
  void operator()(ArrayType* array, std::vector<double>& values) const
  {
    const auto range = vtk::DataArrayValueRange<1>(array);
    values.resize(static_cast<std::size_t>(range.size()));
    vtkSMPTools::For(0, static_cast<vtkIdType>(range.size()),
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType i = begin; i < end; ++i)
        {
          values[i] = static_cast<double>(range[i]);
        }
      });
  }
};

/// The first component of a one-component array as doubles: the array's own memory when it is
/// a double array, else a converted copy in storage.
inline const double* AsDoubles(vtkDataArray* array, std::vector<double>& storage)
{
  if (auto* doubles = vtkAOSDataArrayTemplate<double>::FastDownCast(array))
  {
    return doubles->GetPointer(0);
  }
  if (!vtkArrayDispatch::Dispatch::Execute(array, ToDoubles{}, storage))
  {
    ToDoubles{}(array, storage); // vtkDataArray fallback (virtual access)
  }
  return storage.data();
}
} // namespace stmFunctionValues

#endif
