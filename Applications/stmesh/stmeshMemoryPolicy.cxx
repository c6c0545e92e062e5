// SPDX-License-Identifier: BSD-3-Clause
#include "stmeshMemoryPolicy.h"

#include <limits>
#include <sstream>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace stmesh
{

bool ParseKeepMemoryOption(const std::string& text, KeepMemoryOption& option)
{
  if (text == "auto")
  {
    option = KeepMemoryOption::Automatic;
  }
  else if (text == "yes")
  {
    option = KeepMemoryOption::Yes;
  }
  else if (text == "no")
  {
    option = KeepMemoryOption::No;
  }
  else
  {
    return false;
  }
  return true;
}

const char* KeepMemoryOptionName(KeepMemoryOption option)
{
  switch (option)
  {
    case KeepMemoryOption::Yes:
      return "yes";
    case KeepMemoryOption::No:
      return "no";
    case KeepMemoryOption::Automatic:
      break;
  }
  return "auto";
}

MemoryPolicy ChooseMemoryPolicy(
  KeepMemoryOption option, double voxels, double availableBytes, const char* mallocTunables)
{
  MemoryPolicy policy;
  if (option != KeepMemoryOption::Automatic)
  {
    policy.Keep = option == KeepMemoryOption::Yes;
    policy.Reason = "--keep-memory " + std::string(KeepMemoryOptionName(option));
    return policy;
  }
  if (mallocTunables)
  {
    policy.Reason = "auto: GLIBC_TUNABLES is set, glibc's allocator as it says";
    return policy;
  }
  std::ostringstream reason;
  const double bound = voxels * PeakBytesPerVoxelBound;
  if (!(availableBytes > 0.0))
  {
    policy.Reason = "auto: the available memory is unknown";
    return policy;
  }
  policy.Keep = bound <= 0.25 * availableBytes;
  reason << "auto: " << static_cast<long long>(voxels) << " voxels x " << PeakBytesPerVoxelBound
         << " bytes " << (policy.Keep ? "within" : "above") << " a quarter of the available "
         << static_cast<long long>(availableBytes / 1048576.0) << " MiB";
  policy.Reason = reason.str();
  return policy;
}

bool ApplyMemoryPolicy(MemoryPolicy& policy)
{
  if (!policy.Keep)
  {
    return true;
  }
#if defined(__GLIBC__)
  // Large blocks from the heap instead of their own mappings (which free would unmap), and the
  // heap's free top kept up to 2 GiB (mallopt takes an int).
  if (mallopt(M_MMAP_MAX, 0) == 1 &&
    mallopt(M_TRIM_THRESHOLD, std::numeric_limits<int>::max()) == 1)
  {
    return true;
  }
  policy.Reason += "; glibc refused the settings";
#else
  policy.Reason += "; not glibc, the allocator as it is";
#endif
  policy.Keep = false;
  return false;
}

} // namespace stmesh
