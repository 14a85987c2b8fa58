#!/usr/bin/env python3
"""The rigid motion of two sequences of closed surface frames (PLY), side by side.

For each frame: the centre of the enclosed volume, the angle of the longest principal axis
of its second moments in the x-y plane (degrees, 0..180; meaningful for a body with one
clearly longest axis, a brick, not a cube), the volume; and the distance between the two
centres. Used to compare CalculiX at two meshes (its own discretization spread) or ssc's
`simulate` frames with a reference:

    python3 tools/calculix/compare_frames.py A/frames B/frames [--every-b N]

--every-b N takes every N-th frame of B (ssc simulate writes every step; 10 steps of 1/600 s
are one frame at 60 Hz). Standard library only; ASCII or binary little-endian PLY.
"""

import argparse
import math
import os
import struct


def read_triangles(path):
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().split("\n")
    vertices = faces = 0
    props = []
    for line in header:
        if line.startswith("element vertex"):
            vertices = int(line.split()[2])
        elif line.startswith("element face"):
            faces = int(line.split()[2])
        elif line.startswith("property") and "list" not in line and faces == 0:
            props.append(line.split()[1])
    if any("ascii" in line for line in header[:3]):
        lines = data[end:].decode().split("\n")
        v = [tuple(float(x) for x in lines[i].split()[:3]) for i in range(vertices)]
        f = [[int(x) for x in lines[vertices + i].split()[1:]] for i in range(faces)]
    else:
        fmt = "<" + "".join("f" if t == "float" else "d" for t in props)
        size, off = struct.calcsize(fmt), end
        v = []
        for _ in range(vertices):
            v.append(struct.unpack_from(fmt, data, off)[:3])
            off += size
        f = []
        for _ in range(faces):
            n = data[off]
            off += 1
            f.append(struct.unpack_from("<%di" % n, data, off))
            off += 4 * n
    return [(v[p[0]], v[p[k]], v[p[k + 1]]) for p in f for k in range(1, len(p) - 1)]


def det(a, b, c):
    return (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0]))


def rigid_state(triangles):
    """(volume, centre, long-axis angle in x-y) of a closed, outward-oriented surface."""
    six_volume, first = 0.0, [0.0, 0.0, 0.0]
    for a, b, c in triangles:
        w = det(a, b, c)
        six_volume += w
        for i in range(3):
            first[i] += w * (a[i] + b[i] + c[i])
    centre = [x / (4 * six_volume) for x in first]
    sxx = syy = sxy = 0.0
    for tri in triangles:
        a, b, c = ([p[i] - centre[i] for i in range(3)] for p in tri)
        w = det(a, b, c) / 120
        s = [a[i] + b[i] + c[i] for i in range(3)]
        sxx += w * (a[0] * a[0] + b[0] * b[0] + c[0] * c[0] + s[0] * s[0])
        syy += w * (a[1] * a[1] + b[1] * b[1] + c[1] * c[1] + s[1] * s[1])
        sxy += w * (a[0] * a[1] + b[0] * b[1] + c[0] * c[1] + s[0] * s[1])
    angle = 0.5 * math.degrees(math.atan2(2 * sxy, sxx - syy)) % 180
    return six_volume / 6, centre, angle


def frames(folder, every=1):
    names = sorted(n for n in os.listdir(folder) if n.endswith(".ply"))
    return [os.path.join(folder, n) for n in names][::every]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--every-b", type=int, default=1)
    args = ap.parse_args()
    print("frame | A centre x y z (mm) | angle | volume (l) | B centre x y z (mm) | angle | volume (l) | "
          "distance (mm) | angle difference")
    worst = 0.0
    for k, (pa, pb) in enumerate(zip(frames(args.a), frames(args.b, args.every_b))):
        va, ca, aa = rigid_state(read_triangles(pa))
        vb, cb, ab = rigid_state(read_triangles(pb))
        d = 1e3 * math.dist(ca, cb)
        worst = max(worst, d)
        print("%3d | %7.1f %7.1f %6.1f | %5.1f | %.3f | %7.1f %7.1f %6.1f | %5.1f | %.3f | %5.1f | %5.1f"
              % (k, *(1e3 * x for x in ca), aa, 1e3 * va, *(1e3 * x for x in cb), ab, 1e3 * vb, d,
                 (aa - ab + 90) % 180 - 90))
    print("largest distance between the centres: %.1f mm" % worst)


if __name__ == "__main__":
    main()
