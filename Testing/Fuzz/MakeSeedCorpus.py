"""Writes the seed corpus of FuzzCorePipeline (corpus/core/): one file per case.

The byte layout is FuzzCorePipeline.cxx's Decode: dimension (even 2D, odd 3D), the extents
(1 + b % 12 in 2D, 1 + b % 7 in 3D), the parts of the pattern per axis (1 + b % 3), the
largest cell (1 + b % 16), the flags (1 face balance only, 2 background, 4 Kuhn, 8 hybrid,
16/32 template rule, 64 snap, 128 thin parts), balance level (b % 4), smoothing iterations
(b % 5), quality sweeps (b / 5 % 3) and the binary cut's snap rule (b / 15 % 2: 1 threshold,
0 quality driven), materials (1 + b % 5), the thin-part mode when flagged (1 + b % 2), then a label per
voxel (b % (materials + 1)), axis 0 fastest. Run: python3 MakeSeedCorpus.py
"""
import math
import os
import random

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus", "core")
FACE_ONLY, BACKGROUND, KUHN, HYBRID, SNAP, THIN = 1, 2, 4, 8, 64, 128


def write(name, extents, parts, largest, flags, balance, smooth, materials, labels, thin=0):
    dims = [e - 1 for e in extents]
    header = [len(extents) - 2] + dims + [p - 1 for p in parts]
    header += [largest - 1, flags, balance, smooth, materials - 1]
    if flags & THIN:
        header.append(thin - 1)
    count = math.prod(extents)
    assert len(labels) == count, name
    with open(os.path.join(HERE, name), "wb") as out:
        out.write(bytes(header + labels))


def grid(extents):
    if len(extents) == 2:
        return [(x, y, 0) for y in range(extents[1]) for x in range(extents[0])]
    return [(x, y, z) for z in range(extents[2]) for y in range(extents[1]) for x in range(extents[0])]


def main():
    os.makedirs(HERE, exist_ok=True)
    for name in os.listdir(HERE):
        os.remove(os.path.join(HERE, name))
    random.seed(7)
    write("ball2d", [10, 10], [2, 2], 8, SNAP, 1, 2, 1,
          [1 if (x - 4.5) ** 2 + (y - 4.5) ** 2 < 9 else 0 for x, y, _ in grid([10, 10])])
    write("three_materials3d", [6, 6, 6], [2, 2, 2], 4, SNAP | BACKGROUND | THIN, 2, 3 + 5, 3,
          [random.randrange(4) if random.random() < 0.3 else 1 for _ in grid([6, 6, 6])], thin=1)
    write("anisotropic3d", [7, 7, 4], [2, 2, 1], 8, FACE_ONLY | 16, 1, 1 + 10, 2,
          [(x // 3 + y // 2 + z) % 3 for x, y, z in grid([7, 7, 4])])
    write("hybrid3d", [7, 7, 7], [3, 3, 3], 9, HYBRID | 32, 1, 0, 1,
          [1 if x < 4 and y > 1 else 0 for x, y, z in grid([7, 7, 7])])
    write("kuhn_specks2d", [12, 6], [1, 2], 3, KUHN | BACKGROUND | SNAP | THIN, 3, 1, 4,
          [(x * y) % 5 for x, y, _ in grid([12, 6])], thin=1)
    write("thin_body_shell3d", [7, 7, 7], [2, 2, 2], 16, THIN | BACKGROUND, 1, 2, 2,
          [2 if max(abs(x - 3), abs(y - 3), abs(z - 3)) == 2 else
           (1 if max(abs(x - 3), abs(y - 3), abs(z - 3)) < 2 else 0) for x, y, z in grid([7, 7, 7])],
          thin=2)
    write("single_voxel3d", [1, 1, 1], [2, 2, 2], 1, BACKGROUND, 1, 0, 1, [1])
    write("all_background2d", [3, 4], [2, 2], 2, 0, 1, 0, 1, [0] * 12)
    with open(os.path.join(HERE, "empty"), "wb"):
        pass


if __name__ == "__main__":
    main()
