#!/usr/bin/env python3
"""Writes the instancing demo: a procedural torus of about 100 000 triangles (binary PLY, with
vertex normals) and Mitsuba 3 scenes placing it N times through a shapegroup.

    python3 examples/instancing/gen.py OUT_DIR [N ...]      # default N: 1 and 10000

Each `OUT_DIR/instances-N.xml` (and `instances-N.scene`, the same in the candela language)
places the one `torus.ply` N times on a square grid (random
rotation, non-uniform scale and tint from a fixed seed: deterministic files), on a ground
rectangle under a sun and a sky. Nothing here is committed but this script: the mesh is
2.5 MB, the 10 000-instance scene 2.2 MB.
"""
import math
import os
import random
import struct
import sys

NU, NV = 250, 200  # 250 * 200 quads = 100 000 triangles
R, r = 1.0, 0.35


def torus(path):
    verts = []
    for i in range(NU):
        u = 2 * math.pi * i / NU
        for j in range(NV):
            v = 2 * math.pi * j / NV
            c = R + r * math.cos(v)
            p = (c * math.cos(u), c * math.sin(u), r * math.sin(v))
            n = (math.cos(v) * math.cos(u), math.cos(v) * math.sin(u), math.sin(v))
            verts.append(p + n)
    faces = []
    for i in range(NU):
        for j in range(NV):
            a = i * NV + j
            b = ((i + 1) % NU) * NV + j
            c = ((i + 1) % NU) * NV + (j + 1) % NV
            d = i * NV + (j + 1) % NV
            faces.append((a, b, c))
            faces.append((a, c, d))
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(verts)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\n"
        f"element face {len(faces)}\n"
        "property list uchar int vertex_indices\nend_header\n"
    )
    with open(path, "wb") as f:
        f.write(header.encode())
        for v in verts:
            f.write(struct.pack("<6f", *v))
        for t in faces:
            f.write(struct.pack("<B3i", 3, *t))
    return len(faces)


def scene(path, n):
    rng = random.Random(1)
    side = math.ceil(math.sqrt(n))
    spacing = 3.0
    half = (side - 1) * spacing / 2
    out = [
        '<scene version="3.0.0">',
        '  <integrator type="path"><integer name="max_depth" value="4"/></integrator>',
        '  <sensor type="perspective">',
        '    <float name="fov" value="50"/>',
        '    <transform name="to_world">',
        f'      <lookat origin="{-half - 8}, {-half - 8}, {max(6.0, half * 0.45)}" target="0, 0, 0" up="0, 0, 1"/>',
        "    </transform>",
        '    <film type="hdrfilm"><integer name="width" value="640"/><integer name="height" value="360"/></film>',
        '    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>',
        "  </sensor>",
        '  <emitter type="constant"><rgb name="radiance" value="0.25, 0.3, 0.4"/></emitter>',
        '  <emitter type="directional"><vector name="direction" x="1" y="0.6" z="-1"/>'
        '<rgb name="irradiance" value="3, 2.8, 2.5"/></emitter>',
        '  <bsdf type="diffuse" id="ground"><rgb name="reflectance" value="0.5"/></bsdf>',
        '  <shape type="rectangle"><ref id="ground"/><transform name="to_world">'
        f'<scale value="{half + 10}"/><translate z="-1.2"/></transform></shape>',
    ]
    out.append(
        '  <bsdf type="roughplastic" id="clay"><rgb name="diffuse_reflectance" value="0.8, 0.3, 0.2"/>'
        '<float name="alpha" value="0.2"/></bsdf>'
    )
    out.append(
        '  <shape type="shapegroup" id="torus"><shape type="ply">'
        '<string name="filename" value="torus.ply"/><ref id="clay"/></shape></shape>'
    )
    for i in range(n):
        x, y = (i % side) * spacing - half, (i // side) * spacing - half
        sx, sy, sz = (rng.uniform(0.7, 1.3) for _ in range(3))
        ax = [rng.gauss(0, 1) for _ in range(3)]
        norm = math.sqrt(sum(a * a for a in ax)) or 1.0
        ax = [a / norm for a in ax]  # Mitsuba does not normalise rotation axes
        angle = rng.uniform(0, 360)
        out.append(
            f'  <shape type="instance"><ref id="torus"/><transform name="to_world">'
            f'<scale x="{sx:.4f}" y="{sy:.4f}" z="{sz:.4f}"/>'
            f'<rotate x="{ax[0]:.4f}" y="{ax[1]:.4f}" z="{ax[2]:.4f}" angle="{angle:.2f}"/>'
            f'<translate x="{x:.3f}" y="{y:.3f}"/></transform></shape>'
        )
    out.append("</scene>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def course(path, n):
    """The same placements in the candela language (`instance(NAME, T)` of a named mesh)."""
    rng = random.Random(1)
    side = math.ceil(math.sqrt(n))
    spacing = 3.0
    half = (side - 1) * spacing / 2
    out = [
        "material ground(diffuse(<0.5, 0.5, 0.5>))",
        "material clay(diffuse(<0.8, 0.3, 0.2>))",
        f"parallelogram(ground, [{-half - 10}, {-half - 10}, -1.2], [{2 * half + 20}, 0, 0], [0, {2 * half + 20}, 0])",
        "environment(<0.25, 0.3, 0.4>)",
        "distant_light([1, 0.6, -1], <3, 2.8, 2.5>)",
        f"camera(perspective, look_at([{-half - 8}, {-half - 8}, {max(6.0, half * 0.45)}], [0, 0, 0], [0, 0, 1]), 1.7777778, 1.8)",
        'shape torus(mesh(clay, identity, "torus.ply"))',
    ]
    for i in range(n):
        x, y = (i % side) * spacing - half, (i // side) * spacing - half
        sx, sy, sz = (rng.uniform(0.7, 1.3) for _ in range(3))
        ax = [rng.gauss(0, 1) for _ in range(3)]
        angle = rng.uniform(0, 360)
        out.append(
            f"instance(torus, translation([{x:.3f}, {y:.3f}, 0]) * "
            f"rotation([{ax[0]:.4f}, {ax[1]:.4f}, {ax[2]:.4f}], {angle:.2f}) * "
            f"scaling([{sx:.4f}, {sy:.4f}, {sz:.4f}]))"
        )
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    counts = [int(a) for a in sys.argv[2:]] or [1, 10000]
    os.makedirs(out, exist_ok=True)
    tris = torus(os.path.join(out, "torus.ply"))
    for n in counts:
        scene(os.path.join(out, f"instances-{n}.xml"), n)
        course(os.path.join(out, f"instances-{n}.scene"), n)
    print(
        f"{out}: torus.ply ({tris} triangles), "
        + ", ".join(f"instances-{n}.xml/.scene" for n in counts)
    )


if __name__ == "__main__":
    main()
