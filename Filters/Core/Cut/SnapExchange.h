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
  /// After List: true when no piece sends a state (every piece gets the same answer). No
  /// decision of one piece then depends on another's, and the rounds need no exchange.
  virtual bool IsIdle() const = 0;
  /// The listed points whose states this piece sends, and those whose states it receives.
  virtual const std::vector<std::int64_t>& GetSent() const = 0;
  virtual const std::vector<std::int64_t>& GetReceived() const = 0;
  /// Sends `width` doubles per sent point (in GetSent's order) and gives back those of the
  /// received points (in GetReceived's order).
  virtual void Share(const std::vector<double>& sent, int width, std::vector<double>& received) = 0;
};

/// The snap exchanges of a distributed mesh's pieces (MultiMaterialCutOptions::Exchanges). Every
/// piece makes every step, in the same order, and the snaps of the steps whose material lies
/// near a piece's border exchange as VertexSnap does (SnapExchange). Every call is collective.
class StepSnapExchanges
{
public:
  virtual ~StepSnapExchanges() = default;
  /// The largest `value` of all pieces: where a piece that stopped outside a snap tells the
  /// others (1: aborted, 2: failed), at the next step's snap or at the end.
  virtual double Maximum(double value) = 0;
  /// Element by element, the largest of every piece's `flags` (as many on every piece).
  virtual void AnyPiece(std::vector<std::uint8_t>& flags) = 0;
  /// The exchange of one step's snap, valid until the next call: the step's `count` points,
  /// named by their places before the snap (Dim coordinates each, which the pieces compute bit
  /// for bit alike; read during this call only), and per point 1 where it lies on one of the
  /// piece's own cells.
  virtual SnapExchange& ForStep(
    const double* places, const std::uint8_t* ownPoints, std::int64_t count) = 0;
};

} // namespace stm

#endif
