// SPDX-License-Identifier: BSD-3-Clause
// stmNeighbourExchange under mpiexec: the lists and shares between pieces along a line, with
// both transports. Rank r owns the points x = 4r .. 4r + 3 and also offers 4r + 4 (a point on
// own cells of two pieces), and wants 4r - 2, 4r - 1, 4r + 5, 4r + 6 and 4r + 8 (the last
// offered by r + 1 and r + 2: the lower rank sends it); rank 0 also wants a point nobody has.
// So every rank exchanges values with r - 1 and r + 1 only, whatever the number of ranks.
#include "stmNeighbourExchange.h"

#include "vtkMPIController.h"
#include "vtkNew.h"

#include <cstdio>
#include <string>
#include <vector>

namespace
{
int Failures = 0;

void Expect(bool condition, const std::string& what, int rank)
{
  if (!condition)
  {
    std::fprintf(stderr, "rank %d: %s\n", rank, what.c_str());
    ++Failures;
  }
}

stmNeighbourExchange::Key KeyOf(int x)
{
  return { static_cast<double>(x), 0.5 * x, -static_cast<double>(x) };
}

int GroupOf(int x)
{
  return x % 3;
}

void Check(vtkMultiProcessController* controller, stmNeighbourExchange::Transport transport)
{
  const int rank = controller->GetLocalProcessId();
  const int ranks = controller->GetNumberOfProcesses();
  const int points = 4 * ranks;
  std::vector<int> offered, wanted;
  for (int x = 4 * rank; x <= 4 * rank + 4 && x < points; ++x)
  {
    offered.push_back(x);
  }
  for (const int x : { 4 * rank - 2, 4 * rank - 1, 4 * rank + 5, 4 * rank + 6, 4 * rank + 8 })
  {
    if (x >= 0 && x < points)
    {
      wanted.push_back(x);
    }
  }
  if (rank == 0)
  {
    wanted.push_back(-3);
  }
  std::vector<stmNeighbourExchange::Key> offeredKeys, wantedKeys;
  std::vector<std::uint8_t> groups;
  for (const int x : offered)
  {
    offeredKeys.push_back(KeyOf(x));
    groups.push_back(static_cast<std::uint8_t>(GroupOf(x)));
  }
  for (const int x : wanted)
  {
    wantedKeys.push_back(KeyOf(x));
  }
  stmNeighbourExchange::Lists lists(controller, transport);
  lists.Build(wantedKeys, offeredKeys, groups, 3);

  const int peers = (rank > 0 ? 1 : 0) + (rank + 1 < ranks ? 1 : 0);
  Expect(lists.GetNumberOfPeers() == peers,
    "peers " + std::to_string(lists.GetNumberOfPeers()) + ", expected " + std::to_string(peers),
    rank);
  for (std::size_t w = 0; w < wanted.size(); ++w)
  {
    const int x = wanted[w];
    // The lowest rank offering x: its owner, or the rank below for a first point.
    const int provider = x < 0 ? -1 : (x % 4 == 0 && x > 0 ? x / 4 - 1 : x / 4);
    Expect(lists.GetProviders()[w] == provider,
      "provider of " + std::to_string(x) + ": " + std::to_string(lists.GetProviders()[w]), rank);
  }
  for (std::size_t o = 0; o < offered.size(); ++o)
  {
    const int x = offered[o];
    // Wanted by the ranks that have it within two of their own, from this rank if lowest.
    bool taken = false;
    for (int r = 0; r < ranks; ++r)
    {
      const int provider = x % 4 == 0 && x > 0 ? x / 4 - 1 : x / 4;
      const bool wants =
        x == 4 * r - 2 || x == 4 * r - 1 || x == 4 * r + 5 || x == 4 * r + 6 || x == 4 * r + 8;
      taken = taken || (wants && provider == rank);
    }
    Expect(lists.GetTaken()[o] == (taken ? 1 : 0), "taken " + std::to_string(x), rank);
  }

  // Each group alone, then all together: every matched wanted point gets its value once per
  // share of its group.
  for (int first = 0; first <= 3; ++first)
  {
    const int from = first < 3 ? first : 0;
    const int to = first < 3 ? first + 1 : 3;
    std::vector<int> received(wanted.size(), 0);
    lists.Share(
      2, from, to,
      [&](std::int64_t o, double* out)
      {
        const int x = offered[static_cast<std::size_t>(o)];
        out[0] = x;
        out[1] = 1000.0 * rank + x * x;
      },
      [&](std::int64_t w, const double* in)
      {
        const int x = wanted[static_cast<std::size_t>(w)];
        ++received[static_cast<std::size_t>(w)];
        Expect(GroupOf(x) >= from && GroupOf(x) < to, "group of " + std::to_string(x), rank);
        Expect(in[0] == x && in[1] == 1000.0 * lists.GetProviders()[w] + x * x,
          "value of " + std::to_string(x), rank);
      });
    for (std::size_t w = 0; w < wanted.size(); ++w)
    {
      const int x = wanted[w];
      const bool expected = x >= 0 && GroupOf(x) >= from && GroupOf(x) < to;
      Expect(received[w] == (expected ? 1 : 0),
        "received " + std::to_string(x) + " " + std::to_string(received[w]) + " times", rank);
    }
  }
}
} // namespace

int main(int argc, char* argv[])
{
  vtkNew<vtkMPIController> controller;
  controller->Initialize(&argc, &argv);
  Check(controller, stmNeighbourExchange::Transport::Automatic);
  Check(controller, stmNeighbourExchange::Transport::PairsInTurn);
  int mine = Failures, all = 0;
  controller->AllReduce(&mine, &all, 1, vtkCommunicator::SUM_OP);
  if (controller->GetLocalProcessId() == 0)
  {
    std::printf("%d ranks: %d failures\n", controller->GetNumberOfProcesses(), all);
  }
  controller->Finalize();
  return all == 0 ? 0 : 1;
}
