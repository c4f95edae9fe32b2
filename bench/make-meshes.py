#!/usr/bin/env python3
"""Generates the meshes of bench/scenes/meshes-sky.xml into bench/meshes/ (deterministic, Python
standard library only): binary little-endian PLY files with float x y z nx ny nz and uchar/uint
triangle lists, smooth (area-weighted) vertex normals.

- bumpy.ply: an icosphere subdivided 6 times (81 920 triangles) displaced by a sum of sines;
- knot.ply:  a (2, 3) torus knot tube, 640 × 64 quads (81 920 triangles);
- blob.ply:  a lumpy UV sphere, 96 rings × 256 segments (48 640 triangles).
Total: 212 480 triangles.

And sky.pfm, the environment map of bench/extra/meshes-envmap.xml: a 256 × 128 lat-long sky
(a bluish gradient over a dark ground) with a small sun (about 2.3° across, radiance ~3000).

Usage: python3 bench/make-meshes.py [OUT_DIR]   (default: bench/meshes beside this script)
"""
import math, os, struct, sys

def normalize(v):
    l = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) or 1.0
    return (v[0] / l, v[1] / l, v[2] / l)

def sub(a, b): return (a[0] - b[0], a[1] - b[1], a[2] - b[2])
def cross(a, b): return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])

def icosphere(levels):
    t = (1 + 5 ** 0.5) / 2
    verts = [normalize(v) for v in [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
                                    (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
             (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5),
             (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        cache = {}
        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                va, vb = verts[a], verts[b]
                verts.append(normalize(((va[0] + vb[0]) / 2, (va[1] + vb[1]) / 2, (va[2] + vb[2]) / 2)))
                cache[key] = len(verts) - 1
            return cache[key]
        nf = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = nf
    return verts, faces

def smooth_normals(verts, faces):
    n = [[0.0, 0.0, 0.0] for _ in verts]
    for a, b, c in faces:
        fn = cross(sub(verts[b], verts[a]), sub(verts[c], verts[a]))  # area-weighted
        for i in (a, b, c):
            n[i][0] += fn[0]; n[i][1] += fn[1]; n[i][2] += fn[2]
    return [normalize(v) for v in n]

def write_ply(path, verts, faces):
    normals = smooth_normals(verts, faces)
    with open(path, "wb") as f:
        f.write(("ply\nformat binary_little_endian 1.0\ncomment candela bench mesh\n"
                 f"element vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n"
                 "property float nx\nproperty float ny\nproperty float nz\n"
                 f"element face {len(faces)}\nproperty list uchar uint vertex_indices\nend_header\n").encode())
        f.write(b"".join(struct.pack("<6f", *v, *n) for v, n in zip(verts, normals)))
        f.write(b"".join(struct.pack("<B3I", 3, *t) for t in faces))
    return len(faces)

def make_bumpy():
    verts, faces = icosphere(6)
    out = []
    for x, y, z in verts:
        r = 1 + 0.06 * math.sin(9 * x + 1) * math.sin(11 * y) * math.sin(7 * z + 2) + 0.03 * math.sin(23 * x * y + 5 * z)
        out.append((x * r, y * r, z * r))
    return out, faces

def make_knot(nu=640, nv=64, p=2, q=3, tube=0.18):
    def curve(t):
        r = 0.6 + 0.3 * math.cos(q * t)
        return (r * math.cos(p * t), 0.3 * math.sin(q * t), r * math.sin(p * t))
    verts = []
    for i in range(nu):
        t = 2 * math.pi * i / nu
        c = curve(t)
        d = normalize(sub(curve(t + 1e-3), curve(t - 1e-3)))
        up = (0.0, 1.0, 0.0)
        b = normalize(cross(d, up))
        nrm = cross(b, d)
        for j in range(nv):
            a = 2 * math.pi * j / nv
            ca, sa = math.cos(a), math.sin(a)
            verts.append((c[0] + tube * (ca * nrm[0] + sa * b[0]), c[1] + tube * (ca * nrm[1] + sa * b[1]),
                          c[2] + tube * (ca * nrm[2] + sa * b[2])))
    faces = []
    for i in range(nu):
        for j in range(nv):
            a, b2 = i * nv + j, ((i + 1) % nu) * nv + j
            c2, d2 = ((i + 1) % nu) * nv + (j + 1) % nv, i * nv + (j + 1) % nv
            faces += [(a, d2, c2), (a, c2, b2)]
    return verts, faces

def make_blob(nth=96, nph=256):
    """A lumpy UV sphere: nth rings × nph segments, poles as fans (2·nph·(nth−1) triangles)."""
    verts = [(0.0, 1.0, 0.0)]
    for i in range(1, nth):
        th = math.pi * i / nth
        for j in range(nph):
            ph = 2 * math.pi * j / nph
            x, y, z = math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph)
            r = 1 + 0.15 * math.sin(3 * ph) * math.sin(2 * th) + 0.08 * math.cos(5 * th)
            verts.append((x * r * 1.1, y * r * 0.8, z * r))
    verts.append((0.0, -0.8 * 1.07, 0.0))
    faces = []
    ring = lambda i, j: 1 + (i - 1) * nph + j % nph
    for j in range(nph):
        faces.append((0, ring(1, j + 1), ring(1, j)))
    for i in range(1, nth - 1):
        for j in range(nph):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)
            faces += [(a, b, c), (a, c, d)]
    last = len(verts) - 1
    for j in range(nph):
        faces.append((last, ring(nth - 1, j), ring(nth - 1, j + 1)))
    return verts, faces

def write_sky(path, w=256, h=128):
    """A lat-long map (row 0 at the top: +y, Mitsuba's convention) as a little-endian PFM."""
    sun = normalize((math.cos(0.6) * math.cos(1.0), math.sin(0.6), math.cos(0.6) * math.sin(1.0)))
    rows = []
    for j in range(h):
        theta = math.pi * (j + 0.5) / h
        row = []
        for i in range(w):
            phi = 2.0 * math.pi * (i + 0.5) / w
            d = (math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi))
            if d[1] > 0.0:
                c = (0.25 + 0.3 * (1.0 - d[1]), 0.35 + 0.3 * (1.0 - d[1]), 0.6 + 0.2 * (1.0 - d[1]))
            else:
                c = (0.12, 0.1, 0.08)
            if d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2] > math.cos(0.04):
                c = (3000.0, 2800.0, 2400.0)
            row.append(c)
        rows.append(row)
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w, h))
        for row in reversed(rows):  # PFM rows go bottom to top
            for c in row:
                f.write(struct.pack("<3f", *c))

def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "meshes")
    os.makedirs(out, exist_ok=True)
    total = 0
    for name, make in (("bumpy", make_bumpy), ("knot", make_knot), ("blob", make_blob)):
        v, f = make()
        total += write_ply(os.path.join(out, name + ".ply"), v, f)
    write_sky(os.path.join(out, "sky.pfm"))
    print(f"{out}: {total} triangles, sky.pfm")

if __name__ == "__main__":
    main()
