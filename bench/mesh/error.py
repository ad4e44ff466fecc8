#!/usr/bin/env python3
"""Surface error of a mesh of the CSG classic (bench/mesh.sh).

    python3 bench/mesh/error.py MESH.stl [MESH.stl ...]
    python3 bench/mesh/error.py --self-test

Reads a binary STL, merges the triangle corners into unique vertices (exact
float32 equality) and evaluates the analytic SDF d of the shape in float64.
Prints one line per file:

    FILE triangles T vertices V max_err M rms_err R face_max FM face_rms FR

M = max |d| and R = sqrt(mean d^2) over the unique vertices.  FM and FR are
the same over 7 points of every triangle (its corners, edge midpoints and
centroid), FR weighted by triangle area: this also sees how far the triangles
themselves stray from the surface, e.g. where marching cubes cuts a sharp
edge off with a chamfer (its vertices sit on the surface, its triangles do
not).

The shape: sphere radius 1.35 intersected with the box of half extent 1,
minus the union of three infinite cylinders of radius 0.55 along x, y and z,
centred at the origin, no rotation.  That is the intersection of five exact
Euclidean SDFs (sphere, box, the complements of the three cylinders) by max:
inside the solid |d| is the exact distance to the surface; outside it is a
lower bound (exact except near the convex edges, where the true distance is
larger).
"""
import struct
import sys

import numpy as np

RADIUS = 1.35
HALF = 1.0
HOLE = 0.55


def sdf(p):
    """Analytic SDF of the CSG classic at points p (n x 3, float64)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    sphere = np.sqrt(x * x + y * y + z * z) - RADIUS
    q = np.abs(p) - HALF
    box = np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)
    body = np.maximum(sphere, box)
    cx = np.hypot(y, z) - HOLE
    cy = np.hypot(x, z) - HOLE
    cz = np.hypot(x, y) - HOLE
    holes = np.minimum(np.minimum(cx, cy), cz)
    return np.maximum(body, -holes)


def read_stl(path):
    """Triangle corners of a binary STL file: (n, 3, 3) float32."""
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 84:
        raise ValueError(f"{path}: too short for a binary STL")
    (n,) = struct.unpack_from("<I", data, 80)
    if len(data) < 84 + 50 * n:
        raise ValueError(f"{path}: {n} triangles announced, file holds fewer (ASCII STL?)")
    rec = np.dtype([("normal", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    return np.frombuffer(data, dtype=rec, count=n, offset=84)["v"]


def measure(path, chunk=1 << 18):
    """(triangles, unique vertices, vertex max, vertex rms, face max, face rms)."""
    tris = read_stl(path)
    if len(tris) == 0:
        raise ValueError(f"{path}: no triangles")
    verts = np.unique(tris.reshape(-1, 3), axis=0).astype(np.float64)
    d = sdf(verts)
    vmax, vrms = float(np.abs(d).max()), float(np.sqrt(np.mean(d * d)))
    # 7 points per triangle: corners, edge midpoints, centroid (area-weighted).
    fmax, fsum, asum = 0.0, 0.0, 0.0
    for i in range(0, len(tris), chunk):
        t = tris[i : i + chunk].astype(np.float64)
        a, b, c = t[:, 0], t[:, 1], t[:, 2]
        area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
        pts = (a, b, c, (a + b) / 2, (b + c) / 2, (c + a) / 2, (a + b + c) / 3)
        dd = np.stack([sdf(q) for q in pts], axis=1) ** 2
        fmax = max(fmax, float(dd.max()))
        fsum += float((dd.mean(axis=1) * area).sum())
        asum += float(area.sum())
    frms = np.sqrt(fsum / asum) if asum > 0 else float("nan")
    return len(tris), len(verts), vmax, vrms, float(np.sqrt(fmax)), float(frms)


def write_stl(path, tris):
    tris = np.asarray(tris, dtype="<f4").reshape(-1, 3, 3)
    rec = np.dtype([("normal", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    a = np.zeros(len(tris), dtype=rec)
    a["v"] = tris
    with open(path, "wb") as f:
        f.write(b"\0" * 80 + struct.pack("<I", len(tris)) + a.tobytes())


def self_test():
    """Known meshes: vertices on the surface give ~0; pushed out by e give e."""
    import os
    import tempfile

    rng = np.random.default_rng(1)
    # Points on the flat faces of the box (inside the sphere, outside the
    # holes) and on the inner walls of the holes (inside the body).
    pts = []
    while len(pts) < 3000:
        u, v = rng.uniform(-1, 1, 2)
        if u * u + v * v > HOLE * HOLE + 0.01 and u * u + v * v + 1 < RADIUS**2 - 0.01:
            pts.append((1.0, u, v))           # face x = +1
            pts.append((u, -1.0, v))          # face y = -1
        t, a = rng.uniform(-0.7, 0.7), rng.uniform(0, 2 * np.pi)
        c = (HOLE * np.cos(a), HOLE * np.sin(a))
        if min(np.hypot(c[0], t), np.hypot(c[1], t)) > HOLE + 0.01:
            pts.append((c[0], c[1], t))      # wall of the z hole, off the others
    pts = np.array(pts[: len(pts) // 3 * 3])
    # Points on the sphere part (|x|,|y|,|z| < 1, outside the holes).
    s = rng.normal(size=(6000, 3))
    s = s / np.linalg.norm(s, axis=1, keepdims=True) * RADIUS
    keep = (np.abs(s).max(axis=1) < 0.999) & (sdf(s) > -1e-9)
    s = s[keep][: len(s[keep]) // 3 * 3]
    surf = np.vstack([pts, s])
    assert np.abs(sdf(surf)).max() < 1e-12, "analytic SDF not ~0 on its surface"
    fd, path = tempfile.mkstemp(suffix=".stl")
    os.close(fd)
    try:
        write_stl(path, surf)
        _, v, mx, rms, _, _ = measure(path)
        print(f"self-test: {v} vertices on the surface: max {mx:.2e}, rms {rms:.2e}")
        assert mx < 1e-6, mx  # float32 rounding of coordinates ~ 1e-7
        # A triangulated patch of the x = +1 face (0.6 <= y <= 0.8, |z| <= 0.3:
        # inside the sphere, off the holes) moved out by 0.01: error 0.01.
        g = np.linspace(0.0, 1.0, 11)
        Y, Z = 0.6 + 0.2 * g, -0.3 + 0.6 * g
        quad = []
        for j in range(10):
            for k in range(10):
                p00, p10 = (1.01, Y[j], Z[k]), (1.01, Y[j + 1], Z[k])
                p01, p11 = (1.01, Y[j], Z[k + 1]), (1.01, Y[j + 1], Z[k + 1])
                quad += [p00, p10, p11, p00, p11, p01]
        write_stl(path, quad)
        _, v, mx, rms, fmx, frms = measure(path)
        print(f"self-test: {v} vertices 0.01 off the x = 1 face: max {mx:.6f}, rms {rms:.6f}, "
              f"face max {fmx:.6f}, face rms {frms:.6f}")
        assert abs(mx - 0.01) < 1e-6 and abs(rms - 0.01) < 1e-6, (mx, rms)
        assert abs(fmx - 0.01) < 1e-6 and abs(frms - 0.01) < 1e-6, (fmx, frms)
        # A chamfer: one triangle across the convex rim of the z hole on the
        # z = +1 face, corners on the face (r = 0.65) and on the hole wall
        # (z = 0.9): its corners are on the surface, the midpoint of the edge
        # A-B (r = 0.6, z = 0.95) is 0.05 deep.
        a0, a1 = 0.5, 0.6
        A = (0.65 * np.cos(a0), 0.65 * np.sin(a0), 1.0)
        B = (0.55 * np.cos(a0), 0.55 * np.sin(a0), 0.9)
        C = (0.65 * np.cos(a1), 0.65 * np.sin(a1), 1.0)
        write_stl(path, [A, B, C])
        _, v, mx, rms, fmx, frms = measure(path)
        print(f"self-test: a chamfer triangle: vertex max {mx:.2e}, face max {fmx:.4f}")
        assert mx < 1e-6 and abs(fmx - 0.05) < 1e-6, (mx, fmx)
    finally:
        os.unlink(path)
    print("self-test: ok")


def main(argv):
    if argv == ["--self-test"]:
        self_test()
        return 0
    if not argv:
        print(__doc__.strip().split("\n\n")[1], file=sys.stderr)
        return 2
    for path in argv:
        t, v, mx, rms, fmx, frms = measure(path)
        print(f"{path} triangles {t} vertices {v} max_err {mx:.6g} rms_err {rms:.6g} "
              f"face_max {fmx:.6g} face_rms {frms:.6g}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
