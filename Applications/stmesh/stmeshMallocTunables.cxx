// SPDX-License-Identifier: BSD-3-Clause
#include "stmeshMallocTunables.h"

#include <cstdlib>

#include <unistd.h>

namespace stmesh
{
const char* DefaultMallocTunables()
{
  return "glibc.malloc.hugetlb=1:glibc.malloc.mmap_threshold=33554432:"
         "glibc.malloc.top_pad=67108864";
}

void RestartWithMallocTunables(char* argv[])
{
#ifdef __linux__
  if (std::getenv("GLIBC_TUNABLES"))
  {
    return; // the user's choice, or this is the restarted process
  }
  if (setenv("GLIBC_TUNABLES", DefaultMallocTunables(), 1) != 0)
  {
    return;
  }
  execv("/proc/self/exe", argv);
  // Still here: execv failed and changed nothing else; the variable must not claim tunables
  // that this process does not have.
  unsetenv("GLIBC_TUNABLES");
#else
  static_cast<void>(argv);
#endif
}

std::string MallocTunablesInEffect()
{
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  return tunables ? tunables : "";
}
}
