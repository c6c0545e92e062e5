// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmThreadedBackend
 * @brief   selects VTK's STDThread SMP backend when the filters' library is loaded (private)
 *
 * Debian's VTK 9.2 has STDThread compiled in but Sequential as its default, so without this the
 * filters would run on one thread in ParaView, pvpython, pvbatch and the users' own programs:
 * threads must come without setting anything. The library switches from that default only:
 * - not when VTK_SMP_BACKEND_IN_USE names a backend (VTK's own variable, which VTK has already
 *   applied by then);
 * - not when a backend other than Sequential is in use when the library is loaded (a program's
 *   vtkSMPTools::SetBackend before loading it, ParaView's --smp-backend naming a threaded one).
 * A program calling vtkSMPTools::SetBackend after loading the library has the last word;
 * VTK_SMP_MAX_THREADS limits the threads as usual.
 */

#ifndef stmThreadedBackend_h
#define stmThreadedBackend_h

class stmThreadedBackend
{
public:
  /// Switches the Sequential backend to STDThread unless the environment chose a backend;
  /// returns whether it switched.
  static bool SelectUnlessChosen();
};

#endif
