// SPDX-License-Identifier: BSD-3-Clause
/**
 * Start-up of stmesh with glibc's allocator tuned for large meshes.
 *
 * Each stage allocates arrays of hundreds of megabytes and frees them again. With glibc's
 * defaults every such array is a fresh anonymous mapping, faulted in 4 KiB pages; on virtual
 * machines a page fault costs about 10 us, so the 116-label AAL run spent about a quarter of its
 * time in about 900,000 page faults. Transparent huge pages (which Debian's kernels give to
 * memory that asks for them) and a heap that keeps freed memory cut that to about 10,000.
 * glibc reads its tunables only when a program starts, so stmesh sets them and starts itself
 * again, once.
 */
#ifndef stmeshMallocTunables_h
#define stmeshMallocTunables_h

#include <string>

namespace stmesh
{
/// The GLIBC_TUNABLES that stmesh runs with unless the environment sets that variable: malloc
/// asks for transparent huge pages (glibc.malloc.hugetlb=1, glibc 2.35 and later; older ones
/// ignore it), serves allocations up to 32 MiB (its largest mmap_threshold) from the heap, and
/// grows the heap in steps of 64 MiB, so that huge pages fit in each step.
const char* DefaultMallocTunables();

/// Unless GLIBC_TUNABLES is set (to anything, even empty, which keeps glibc's defaults), sets it
/// to DefaultMallocTunables() and replaces the process with a new start of the same executable
/// with the same arguments. Returns only when it does not restart (the variable was set, or
/// /proc/self/exe cannot be executed: the run goes on with the allocator as it is).
void RestartWithMallocTunables(char* argv[]);

/// The GLIBC_TUNABLES of this process, for the summary; empty when the variable is not set.
std::string MallocTunablesInEffect();
}

#endif
