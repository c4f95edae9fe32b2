#!/usr/bin/env python3
"""Writes a two-mesh Mitsuba `serialized` file (format 4: a floor quad in single precision, a
torus with vertex normals and uv in double precision), a scene using both (`shape_index` 0 and
1), and renders it with Mitsuba 3 if it is importable: the reference for candela's reader.

usage: serialized-vs-mitsuba.py OUT_DIR   (then: candela render OUT_DIR/scene.xml -o x.exr)
"""
import math
import struct
import sys
import zlib
from pathlib import Path


def mesh(flags, name, positions, normals, uvs, tris, double):
    fmt = "d" if double else "f"
    body = struct.pack("<I", flags) + name.encode() + b"\0"
    body += struct.pack("<QQ", len(positions), len(tris))
    for arr in (positions, normals, uvs):
        for v in arr:
            body += struct.pack("<" + fmt * len(v), *v)
    for t in tris:
        body += struct.pack("<3I", *t)
    return struct.pack("<HH", 0x041C, 4) + zlib.compress(body)


def torus(n=48, m=24, big=0.6, small=0.25):
    p, nn, uv, t = [], [], [], []
    for i in range(n + 1):
        a = 2 * math.pi * i / n
        for j in range(m + 1):
            b = 2 * math.pi * j / m
            c = (math.cos(a), math.sin(a))
            nrm = (c[0] * math.cos(b), c[1] * math.cos(b), math.sin(b))
            p.append(tuple(big * c[k] + small * nrm[k] for k in range(2)) + (small * nrm[2] + 0.25,))
            nn.append(nrm)
            uv.append((i / n, j / m))
    for i in range(n):
        for j in range(m):
            a, b = i * (m + 1) + j, (i + 1) * (m + 1) + j
            t += [(a, b, b + 1), (a, b + 1, a + 1)]
    return p, nn, uv, t


def main():
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    quad = mesh(0x1000, "floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], [], [],
                [(0, 1, 2), (0, 2, 3)], False)
    p, nn, uv, t = torus()
    tor = mesh(0x2000 | 0x1 | 0x2, "torus", p, nn, uv, t, True)
    data = quad + tor + struct.pack("<QQI", 0, len(quad), 2)
    (out / "two.serialized").write_bytes(data)
    (out / "scene.xml").write_text("""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="4"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, -4, 3" target="0, 0, 0.2" up="0, 0, 1"/></transform>
    <sampler type="independent"><integer name="sample_count" value="256"/></sampler>
    <film type="hdrfilm"><integer name="width" value="96"/><integer name="height" value="72"/></film>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
  <emitter type="point"><point name="position" x="1" y="-1" z="3"/><rgb name="intensity" value="8"/></emitter>
  <shape type="serialized"><string name="filename" value="two.serialized"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.6, 0.6"/></bsdf></shape>
  <shape type="serialized"><string name="filename" value="two.serialized"/><integer name="shape_index" value="1"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.3, 0.2"/></bsdf></shape>
</scene>
""")
    try:
        import mitsuba as mi
    except ImportError:
        return
    mi.set_variant("scalar_rgb")
    img = mi.render(mi.load_file(str(out / "scene.xml")))
    mi.Bitmap(img).write(str(out / "mitsuba.exr"))
    import numpy as np
    a = np.array(img)
    print("mitsuba channel means:", a.reshape(-1, 3).mean(axis=0))


if __name__ == "__main__":
    main()
