// SPDX-License-Identifier: BSD-3-Clause
#include "stmThreadedBackend.h"

#include "vtkSMPTools.h"

#include <cstdlib>
#include <cstring>

bool stmThreadedBackend::SelectUnlessChosen()
{
  const char* fromEnvironment = std::getenv("VTK_SMP_BACKEND_IN_USE");
  if (fromEnvironment && *fromEnvironment)
  {
    return false;
  }
  const char* current = vtkSMPTools::GetBackend();
  if (!current || std::strcmp(current, "Sequential") != 0)
  {
    return false;
  }
  return vtkSMPTools::SetBackend("STDThread");
}

namespace
{
// At load time, not at a filter's first run, so that a backend the program sets after loading
// the library is never overridden.
[[maybe_unused]] const bool SwitchedWhenLoaded = stmThreadedBackend::SelectUnlessChosen();
}
