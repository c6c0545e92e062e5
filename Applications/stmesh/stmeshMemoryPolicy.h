// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmeshMemoryPolicy_h
#define stmeshMemoryPolicy_h

// Whether stmesh keeps the memory its stages free for the stages after them (--keep-memory).
// Each stage allocates its output and frees its input, and glibc gives large blocks back to the
// system as soon as they are freed (munmap); the next stage's first touch of the same amount of
// memory then takes one page fault per 4 KiB page again. On this project's virtual machines a
// fault costs about 10 us (docs/performance.md, "Memory kept in the process"), which was a fifth
// of the AAL runs. Kept memory costs about an eighth more peak memory (blocks that do not fit the
// holes left by freed ones), so the automatic choice keeps it only where the machine has plenty.

#include <string>

namespace stmesh
{

enum class KeepMemoryOption
{
  Automatic,
  Yes,
  No
};

/// Parses auto, yes or no; false for anything else.
bool ParseKeepMemoryOption(const std::string& text, KeepMemoryOption& option);
const char* KeepMemoryOptionName(KeepMemoryOption option);

/// A generous bound of a run's peak memory per voxel of the image, for the automatic choice
/// (AAL, 116 labels, kept memory: 1,400 MiB for 7.1 million voxels, 207 bytes per voxel).
constexpr double PeakBytesPerVoxelBound = 400.0;

struct MemoryPolicy
{
  bool Keep = false;
  std::string Reason; // for the summary
};

/// The choice: Yes and No as given; Automatic keeps the memory unless the environment sets
/// glibc's allocator (GLIBC_TUNABLES, the user's choice) or the image's voxels times
/// PeakBytesPerVoxelBound exceed a quarter of the available memory (availableBytes <= 0:
/// unknown, then not kept).
MemoryPolicy ChooseMemoryPolicy(
  KeepMemoryOption option, double voxels, double availableBytes, const char* mallocTunables);

/// Applies the choice to glibc's allocator (no mmap of large blocks, no trimming of the heap's
/// top), for the allocations after the call. Returns false where that is not possible (another C
/// library, or glibc refused); the policy's Keep is then reset and its Reason says why.
bool ApplyMemoryPolicy(MemoryPolicy& policy);

} // namespace stmesh

#endif
