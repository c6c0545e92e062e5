// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSnapExchange_h
#define stmCoreSnapExchange_h

#include <cstdint>
#include <vector>

namespace stm
{

/// What VertexSnap needs from the other pieces of a distributed mesh to decide as the whole
/// mesh does (VertexSnapOptions::Exchange). A piece holds the points of its own cells and of
/// ghost cells around them. Its decisions for the points of its own cells are the whole mesh's
/// as long as the points around them are in the whole mesh's state at the start of every round;
/// so after every round each piece sends the states of its own cells' points that other pieces
/// hold, and takes theirs for the points it holds on no own cell of its own. Every call is
/// collective: each piece makes the same calls in the same order.
class SnapExchange
{
public:
  virtual ~SnapExchange() = default;
  /// The largest `value` of all pieces.
  virtual double Maximum(double value) = 0;
  /// Makes the lists, given the points whose states can change (ascending ids, `count` of
  /// them). The indices below are indices into this list.
  virtual void List(const std::int64_t* points, std::int64_t count) = 0;
  /// The listed points whose states this piece sends, and those whose states it receives.
  virtual const std::vector<std::int64_t>& GetSent() const = 0;
  virtual const std::vector<std::int64_t>& GetReceived() const = 0;
  /// Sends `width` doubles per sent point (in GetSent's order) and gives back those of the
  /// received points (in GetReceived's order).
  virtual void Share(const std::vector<double>& sent, int width, std::vector<double>& received) = 0;
};

} // namespace stm

#endif
