// SPDX-License-Identifier: BSD-3-Clause
// The collective calls by which the pieces of a distributed mesh smooth and split edges as the
// whole mesh would (BoundarySmoothOptions::Exchange, InteriorEdgeSplitOptions::Exchange).
#ifndef stmCoreSmoothingExchange_h
#define stmCoreSmoothingExchange_h

#include <cstdint>
#include <vector>

namespace stm
{

/// The exchanges of a piece of a distributed mesh with the other pieces while the pieces smooth
/// and split edges, so that they move every point and split every edge as the whole mesh's
/// smoothing does (BoundarySmoothOptions::Exchange, InteriorEdgeSplitOptions::Exchange).
/// Every call is collective: all pieces make the same calls in the same order.
class SmoothingExchange
{
public:
  virtual ~SmoothingExchange() = default;
  /// Whether every piece is `ready`; the first call.
  virtual bool AllReady(bool ready) = 0;
  /// Gives the points this piece does not move (HeldPoints) the values of the piece that moves
  /// them: `width` doubles per point in `values`; with `colour` >= 0 only the points of that
  /// root colour (the colour of the block its piece moves a point in), else all. Appends the
  /// points whose values changed to `changed` when not null.
  virtual void Share(double* values, int width, int colour, std::vector<std::int64_t>* changed) = 0;
  /// The largest `value` of all pieces.
  virtual double Maximum(double value) = 0;
  /// Every piece's `values`, one piece after the other in the pieces' order.
  virtual std::vector<double> Gather(const std::vector<double>& values) = 0;
};

} // namespace stm

#endif
