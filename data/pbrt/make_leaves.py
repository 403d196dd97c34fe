#!/usr/bin/env python3
"""Writes data/pbrt/leaves.pbrt and data/pbrt/leaf.png: a bush of leaf
cards (quads with a leaf-shaped alpha mask, as foliage is authored in
scenes such as barcelona-pavilion and sanmiguel) over a ground quad.

    python3 data/pbrt/make_leaves.py [FOLDER]   (default: this file's folder)

Deterministic (its own LCG, no random module): the same files every run.
The mask is 64 x 64, 8-bit grey: 255 inside a leaf outline (an ellipse
pinched to a point at both ends, a notch for the stem), 0 outside; about
half the card's area is leaf.
"""
import math
import os
import struct
import sys
import zlib

N = 64


def leaf_mask():
    rows = []
    for y in range(N):
        row = bytearray()
        for x in range(N):
            u = (x + 0.5) / N * 2 - 1  # -1..1 across
            v = (y + 0.5) / N * 2 - 1  # -1..1 along the leaf (top to bottom)
            half = 0.62 * (1 - v * v) ** 0.8  # half-width along the leaf
            inside = abs(u) < half and abs(v) < 0.97
            stem = v > 0.8 and abs(u) < 0.04  # the stem to the bottom edge
            vein = abs(u) < 0.015 and abs(v) < 0.9  # a hole along the midrib
            row.append(255 if (inside and not vein) or stem else 0)
        rows.append(bytes(row))
    return rows


def write_png(path, rows):
    raw = b"".join(b"\x00" + r for r in rows)
    def chunk(t, d):
        c = struct.pack(">I", len(d)) + t + d
        return c + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", N, N, 8, 0, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


class Lcg:
    def __init__(self, seed):
        self.s = seed

    def unif(self):
        self.s = (self.s * 6364136223846793005 + 1442695040888963407) % (1 << 64)
        return (self.s >> 11) / float(1 << 53)


def write_scene(path, ncards=600):
    r = Lcg(37)
    out = []
    out.append("# A bush of %d leaf cards (quads textured with the alpha mask leaf.png) over a ground quad." % ncards)
    out.append("# Written by make_leaves.py; docs/results.md (\"Alpha cutouts\") measures it with and without the cutout.")
    out.append('LookAt 0 1.6 -5.5  0 1.3 0  0 1 0')
    out.append('Camera "perspective" "float fov" 45')
    out.append('Film "rgb" "integer xresolution" 256 "integer yresolution" 256 "string filename" "leaves.exr"')
    out.append("WorldBegin")
    out.append('LightSource "point" "point3 from" [3 6 -4] "rgb I" [60 60 60]')
    out.append('Texture "leaf" "float" "imagemap" "string filename" "leaf.png" "string filter" "point"')
    out.append('Material "diffuse" "rgb reflectance" [0.4 0.35 0.3]')
    out.append('Shape "trianglemesh" "point3 P" [-6 0 -6  6 0 -6  6 0 6  -6 0 6] "integer indices" [0 1 2 0 2 3]')
    out.append('Material "diffuse" "rgb reflectance" [0.2 0.5 0.15]')
    pts, idx, uvs = [], [], []
    for i in range(ncards):
        # a point in an ellipsoid crown around (0, 1.4, 0)
        while True:
            x, y, z = (r.unif() * 2 - 1 for _ in range(3))
            if x * x + y * y + z * z <= 1:
                break
        cx, cy, cz = 1.3 * x, 1.4 + 0.9 * y, 1.3 * z
        a, b = r.unif() * 2 * math.pi, (r.unif() - 0.5) * math.pi
        # the card's two axes: along (leaf length) and across
        ax = (math.cos(a) * math.cos(b), math.sin(b), math.sin(a) * math.cos(b))
        t = (-math.sin(a), 0.0, math.cos(a))
        c2 = r.unif() * 2 * math.pi
        ac = tuple(math.cos(c2) * t[k] + math.sin(c2) * (ax[(k + 1) % 3] * t[(k + 2) % 3] - ax[(k + 2) % 3] * t[(k + 1) % 3])
                   for k in range(3))
        L, W = 0.22 + 0.08 * r.unif(), 0.16
        base = len(pts)
        for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            p = tuple(c + su * W / 2 * acr + sv * L / 2 * alr for c, acr, alr in zip((cx, cy, cz), ac, ax))
            pts.append(p)
            uvs.append(((su + 1) / 2, (sv + 1) / 2))
        idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    out.append('Shape "trianglemesh"')
    out.append('  "point3 P" [' + " ".join("%.5f %.5f %.5f" % p for p in pts) + "]")
    out.append('  "point2 uv" [' + " ".join("%g %g" % q for q in uvs) + "]")
    out.append('  "integer indices" [' + " ".join(str(k) for k in idx) + "]")
    out.append('  "texture alpha" "leaf"')
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
    write_png(os.path.join(d, "leaf.png"), leaf_mask())
    write_scene(os.path.join(d, "leaves.pbrt"))


if __name__ == "__main__":
    main()
