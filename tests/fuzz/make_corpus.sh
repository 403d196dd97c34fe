#!/bin/sh
# make_corpus.sh -- regenerates the seed corpora in tests/fuzz/corpus/.
#
# Usage: tests/fuzz/make_corpus.sh RAYTRAFFIC_BINARY
#
# Names: ok-* must be accepted by their harness, bad-* refused
# (tests/fuzz_replay.sh checks both). Every trace and din seed starts with
# the harness's selector byte (fuzz_trace.c, fuzz_din.c). Needs python3
# for the byte surgery. The seeds are committed; run this only when the
# formats change.
set -eu
bin=$1
here=$(cd "$(dirname "$0")" && pwd)
c=$here/corpus
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
rm -rf "$c"
mkdir -p "$c/trace" "$c/din" "$c/obj" "$c/ply" "$c/cli" "$c/pbrt" "$c/gz"

# Traces at 4x4: each tracer, with and without writes from shadow rays
# (version 1), and version 3 with its sample index (a chunk and its side
# chunk).
"$bin" trace cornell -W 4 -H 4 --no-sample -o "$tmp/cornell.rtt" >/dev/null 2>&1
"$bin" trace sphereflake:level=0 -W 4 -H 4 --lights all -t packet --packet 2 --no-sample -o "$tmp/flake.rtt" >/dev/null 2>&1
"$bin" trace knot:segs=8,sides=3 -W 4 -H 4 -t dynamic --cache-size 1K --no-sample -o "$tmp/knot.rtt" >/dev/null 2>&1
"$bin" trace cornell -W 4 -H 4 -o "$tmp/cornell3.rtt" >/dev/null 2>&1
"$bin" trace-dump --din "$tmp/cornell.rtt" | head -n 40 > "$tmp/cornell.din"
python3 - "$tmp" "$c" <<'EOF'
import struct, sys, zlib
tmp, c = sys.argv[1], sys.argv[2]
def plain(f):
    """Mode 2 of fuzz_trace.c: each chunk body uncompressed."""
    P = struct.unpack_from('<I', f, 12)[0]
    out, i = bytearray(f[:20 + P]), 20 + P
    while f[i:i + 4] in (b'RTCK', b'RTSM'):
        C = struct.unpack_from('<I', f, i + 16)[0]
        body = zlib.decompress(f[i + 24:i + 24 + C])
        h = bytearray(f[i:i + 24])
        struct.pack_into('<I', h, 16, len(body))
        out += h + body
        i += 24 + C
    return bytes(out + f[i:])
def put(name, data):
    open(f'{c}/{name}', 'wb').write(data)
for name in ('cornell', 'flake', 'knot', 'cornell3'):
    f = open(f'{tmp}/{name}.rtt', 'rb').read()
    put(f'trace/ok-{name}-raw', bytes([0x40]) + f)          # mode 0, buffer 65
    put(f'trace/ok-{name}-crc', bytes([0x01]) + f)          # mode 1, buffer 1
    put(f'trace/ok-{name}-plain', bytes([0xfe]) + plain(f)) # mode 2, buffer 253
f = open(f'{tmp}/cornell.rtt', 'rb').read()
put('trace/bad-truncated', bytes([0x40]) + f[:len(f) // 2])
put('trace/bad-magic', bytes([0x40]) + b'RTTRACX' + f[7:])
flip = bytearray(f); flip[40] ^= 4
put('trace/bad-bitflip', bytes([0x40]) + bytes(flip))
put('trace/bad-trailing', bytes([0x40]) + f + b'\0')
put('trace/bad-empty', bytes([0x00]))
d = open(f'{tmp}/cornell.din', 'rb').read()
put('din/ok-cornell', bytes([0x23]) + d)
put('din/ok-forms', bytes([0x00]) + b'0 10\n1 0x1f\n\n2 ffffffffffffffff trailing words\r\n  0\t0\n')
put('din/bad-label', bytes([0x10]) + b'0 10\n3 20\n')
put('din/bad-address', bytes([0x10]) + b'0 10\n1 0x\n')
put('din/bad-overflow', bytes([0x10]) + b'0 10000000000000000\n')
put('din/bad-nul', bytes([0x10]) + b'0 10\n0 2\x003\n')
EOF
cp "$here/../../data/meshes/cube.obj" "$c/obj/ok-cube.obj"
cp "$here/../../data/meshes/forms.obj" "$c/obj/ok-forms.obj"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1 1\nvt 0 0\nvn 0 0 1\nf 1/1/1 2//1 3\r\nf -1 -2 -3 -4\n' > "$c/obj/ok-negative"
printf 'v 0 0 0\nv 1 0 0\nf 1 2 3\n' > "$c/obj/bad-index"
printf 'v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n' > "$c/obj/bad-nan"
printf 'v 0 0 0\nv 1e30 0 0\nv 0 1 0\nf 1 2 3\n' > "$c/obj/bad-range"
printf '# no faces\nv 0 0 0\n' > "$c/obj/bad-nofaces"
cp "$here/../../data/meshes/tetra_ascii.ply" "$c/ply/ok-tetra-ascii.ply"
python3 - "$c" <<'EOF'
import struct, sys
c = sys.argv[1]
V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
F = [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]
def binply(fmt, e, vtype='float', ctype='uchar', itype='int', extra=b''):
    h = (f'ply\nformat {fmt} 1.0\ncomment seed\nelement vertex 4\nproperty {vtype} x\nproperty {vtype} y\n'
         f'property {vtype} z\nproperty uchar red\nelement face 4\nproperty list {ctype} {itype} vertex_indices\n'
         'end_header\n').encode()
    vt = {'float': 'f', 'double': 'd', 'short': 'h'}[vtype]
    ct = {'uchar': 'B', 'ushort': 'H'}[ctype]
    it = {'int': 'i', 'uint': 'I', 'short': 'h'}[itype]
    b = b''.join(struct.pack(e + vt * 3 + 'B', *v, 200) for v in V)
    b += b''.join(struct.pack(e + ct + it * 3, 3, *f) for f in F)
    return h + b + extra
open(f'{c}/ply/ok-tetra-le', 'wb').write(binply('binary_little_endian', '<'))
open(f'{c}/ply/ok-tetra-be', 'wb').write(binply('binary_big_endian', '>', 'double', 'ushort', 'short'))
open(f'{c}/ply/bad-short', 'wb').write(binply('binary_little_endian', '<')[:-7])
open(f'{c}/ply/bad-count', 'wb').write(binply('binary_little_endian', '<').replace(b'vertex 4', b'vertex 9999999'))
open(f'{c}/ply/bad-format', 'wb').write(b'ply\nformat binary_middle_endian 1.0\nend_header\n')
EOF
cp "$here/../../data/pbrt/cornell.pbrt" "$c/pbrt/ok-cornell.pbrt"
cat > "$c/pbrt/ok-features" <<'PBRT'
# every shape and most directives of the subset, without files
Scale -1 1 1
LookAt 0 -4 1  0 0 0.5  0 0 1
Camera "perspective" "float fov" [ 50 ] "float screenwindow" [ -1 1 -0.75 0.75 ]
Film "rgb" "integer xresolution" 64 "integer yresolution" 48
Sampler "halton"
WorldBegin
CoordinateSystem "origin"
LightSource "point" "point3 from" [ 1 -3 4 ] "rgb I" [ 10 10 10 ]
LightSource "spot" "point3 from" [ -1 -3 4 ] "point3 to" [ 0 0 0 ]
MakeNamedMaterial "glass" "string type" "dielectric" "float eta" 1.5
AttributeBegin
  Material "conductor" "rgb eta" [ 0.2 0.9 1.1 ] "rgb k" [ 3.9 2.4 2.2 ]
  Translate 0 0 1
  Shape "sphere" "float radius" 0.5
AttributeEnd
TransformBegin
  Rotate 30 0 0 1
  NamedMaterial "glass"
  Shape "loopsubdiv" "integer levels" 2 "point3 P" [ 1 1 1 1 -1 -1 -1 1 -1 -1 -1 1 ]
      "integer indices" [ 0 1 2 0 2 3 0 3 1 1 3 2 ]
TransformEnd
ObjectBegin "quad"
  Material "coateddiffuse" "rgb reflectance" [ 0.2 0.4 0.6 ]
  Shape "bilinearmesh" "point3 P" [ 0 0 0 1 0 0 0 1 0 1 1 0 ]
ObjectEnd
ConcatTransform [ 1 0 0 0 0 1 0 0 0 0 1 0 2 0 0 1 ]
ObjectInstance "quad"
CoordSysTransform "origin"
AttributeBegin
  AreaLightSource "diffuse" "blackbody L" 5500 "float scale" 2
  Shape "trianglemesh" "point3 P" [ -5 -5 3 5 -5 3 5 5 3 -5 5 3 ] "integer indices" [ 0 2 1 0 3 2 ]
AttributeEnd
Shape "trianglemesh" "point3 P" [ -5 -5 0 5 -5 0 5 5 0 -5 5 0 ] "integer indices" [ 0 1 2 0 2 3 ]
Shape "disk"
PBRT
cat > "$c/pbrt/ok-instances" <<'PBRT'
# instances for the two-level structure: rotated, scaled, translated, a flat object, a singular one
LookAt 0 3 -12  0 0 0  0 1 0
Camera "perspective" "float fov" 45
WorldBegin
Shape "trianglemesh" "point3 P" [-8 -2 -8  8 -2 -8  8 -2 8  -8 -2 8] "integer indices" [0 1 2 0 2 3]
ObjectBegin "box"
Shape "trianglemesh" "point3 P" [-1 -1 -1 1 -1 -1 1 1 -1 -1 1 -1 -1 -1 1 1 -1 1 1 1 1 -1 1 1]
  "integer indices" [0 1 2 0 2 3  4 6 5 4 7 6  0 4 5 0 5 1  3 2 6 3 6 7  0 3 7 0 7 4  1 5 6 1 6 2]
ObjectEnd
ObjectBegin "card"
Shape "trianglemesh" "point3 P" [-1 -1 0 0 -1 0 1 -1 0 -1 1 0 0 1 0 1 1 0] "integer indices" [0 1 4 0 4 3 1 2 5 1 5 4]
ObjectEnd
ObjectInstance "box"
AttributeBegin Translate -3 0 1 Rotate 30 0 1 0 Rotate 20 1 0 0 ObjectInstance "box" AttributeEnd
AttributeBegin Translate 3 1 2 Scale 0.5 2 1 ObjectInstance "box" AttributeEnd
AttributeBegin Translate 0 0 -2 Rotate 33 0 1 0 ObjectInstance "card" AttributeEnd
AttributeBegin Translate 4 0 -2 Scale 1 0 1 ObjectInstance "box" AttributeEnd
PBRT
cat > "$c/pbrt/ok-nested" <<'PBRT'
# nested instancing two deep: leaf in branch in tree, instanced at the top
LookAt 0 2 -10  0 0 6  0 1 0
Camera "perspective" "float fov" 50
WorldBegin
ObjectBegin "leaf"
Shape "trianglemesh" "point3 P" [-1 -1 -1 1 -1 -1 1 1 -1 -1 1 -1 -1 -1 1 1 -1 1 1 1 1 -1 1 1]
  "integer indices" [0 1 2 0 2 3  4 6 5 4 7 6  0 4 5 0 5 1  3 2 6 3 6 7  0 3 7 0 7 4  1 5 6 1 6 2]
ObjectEnd
ObjectBegin "branch"
AttributeBegin Translate 2 0 0 Rotate 30 0 0 1 Scale 0.5 0.5 0.5 ObjectInstance "leaf" AttributeEnd
AttributeBegin Translate -2 1 0 Rotate 45 0 1 0 ObjectInstance "leaf" AttributeEnd
Shape "trianglemesh" "point3 P" [0 0 0  1 0 0  0 2 0] "integer indices" [0 1 2]
ObjectEnd
ObjectBegin "tree"
AttributeBegin Translate 0 3 0 ObjectInstance "branch" AttributeEnd
AttributeBegin Translate 0 -3 1 Scale 1 0.5 1 ObjectInstance "branch" AttributeEnd
ObjectEnd
AttributeBegin Translate -6 0 8 Rotate 15 0 1 0 ObjectInstance "tree" AttributeEnd
AttributeBegin Translate 6 0 10 Scale 1.2 1.2 1.2 ObjectInstance "tree" AttributeEnd
AttributeBegin Translate 0 -1 4 ObjectInstance "branch" AttributeEnd
PBRT
cat > "$c/pbrt/ok-shapes2" <<'PBRT'
# disk, annulus, cylinder, curves (bezier, bspline, ribbon), interface, alpha, deferred instances
LookAt 0 -6 3  0 0 0.5  0 0 1
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 32 "integer yresolution" 24 "float cropwindow" [ 0 1 0 1 ]
WorldBegin
Shape "disk" "float radius" 0.6 "float height" 0.1
Shape "disk" "float radius" 0.6 "float innerradius" 0.3 "float phimax" 270
Shape "cylinder" "float radius" 0.4 "float zmin" 0 "float zmax" 1 "float phimax" 180
Shape "curve" "point3 P" [ -2 -1 0.5  -1 -1 1.5  1 -1 1.5  2 -1 0.5 ] "float width0" 0.1 "float width1" 0.02
Shape "curve" "string basis" "bspline" "point3 P" [ 0 0 0  1 0 1  2 0 0  3 0 1  4 0 0 ] "integer splitdepth" 2
Shape "curve" "string type" "ribbon" "point3 P" [ 0 0 0  1 0 0  2 0 0  3 0 0 ] "normal N" [ 0 1 0  0 0 1 ]
AttributeBegin
  Material "interface"
  Shape "sphere" "float radius" 3
AttributeEnd
Shape "sphere" "float radius" 2 "float alpha" 0
Shape "trianglemesh" "point3 P" [ -3 -3 -0.01  3 -3 -0.01  3 3 -0.01 ] "texture alpha" "leaves"
ObjectBegin "three"
  Shape "trianglemesh" "point3 P" [ 0 0 0 1 0 0 0 1 0  0 0 1 ] "integer indices" [ 0 1 2 0 1 3 0 2 3 ]
ObjectEnd
Translate 1 0 0
ObjectInstance "three"
Translate 1 0 0
ObjectInstance "three"
PBRT
python3 -c "import gzip,sys; sys.stdout.buffer.write(gzip.compress(open(sys.argv[1],'rb').read(), 9, mtime=0))" "$c/pbrt/ok-shapes2" > "$c/pbrt/ok-shapes2-gz"
printf 'WorldBegin\nAttributeEnd\n' > "$c/pbrt/bad-unbalanced"
printf 'WorldBegin\nShape "trianglemesh" "point3 P" [ 0 0 0 1 0 0 0 1 0 ] "integer indices" [ 0 1 3 ]\n' > "$c/pbrt/bad-index"
printf 'WorldBegin\nInclude "../../etc/passwd"\n' > "$c/pbrt/bad-escape"
printf 'WorldBegin\nShape "loopsubdiv" "integer levels" 30 "point3 P" [ 0 0 0 1 0 0 0 1 0 ] "integer indices" [ 0 1 2 ]\n' > "$c/pbrt/bad-levels"
printf 'Frobnicate\n' > "$c/pbrt/bad-directive"
printf -- '-t\npacket\n-W\n4\n-H\n4\n--packet\n2\n--lights\n0,2' > "$c/cli/ok-packet"
printf -- '--tracer=dynamic\n--cache-size\n64K\n--gmax=1M\n--cores\n8\n--qorder\ntree\n--line\n4K\n--rate\n1/64' > "$c/cli/ok-dynamic"
printf -- '--subsample\n16:4\n--width=65536\n-H1\n--lights=all\n-h\n--\nscene.obj' > "$c/cli/ok-subsample"
printf -- '-W\n0' > "$c/cli/bad-width"
printf -- '--subsample\n0:99999\n--cache-size\n63' > "$c/cli/bad-subsample"
printf -- '--line\n2M\n--rate\n2\n--lights\n3' > "$c/cli/bad-line"
printf -- '--cache-size\n18446744073709551615K\n-t\nwhitted' > "$c/cli/bad-overflow"
# gzip input (fuzz_gz.c): the tetrahedron gzipped, in two members, plain;
# cut, with a bad method byte, with bytes after the stream, the magic alone
python3 - "$c" "$here/../../data/meshes/tetra_ascii.ply" <<'EOF'
import gzip, sys
c, ply = sys.argv[1], open(sys.argv[2], 'rb').read()
g = gzip.compress(ply, 9, mtime=0)
open(f'{c}/gz/ok-tetra', 'wb').write(g)
open(f'{c}/gz/ok-members', 'wb').write(gzip.compress(ply[:40], 9, mtime=0) + gzip.compress(ply[40:], 9, mtime=0))
open(f'{c}/gz/ok-plain', 'wb').write(ply)
open(f'{c}/gz/bad-cut', 'wb').write(g[:len(g) // 2])
open(f'{c}/gz/bad-method', 'wb').write(g[:2] + b'\x07' + g[3:])
open(f'{c}/gz/bad-trailing', 'wb').write(g + b'garbage')
open(f'{c}/gz/bad-magic-only', 'wb').write(b'\x1f\x8b')
EOF
du -sh "$c"
