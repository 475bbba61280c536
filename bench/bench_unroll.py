"""Unroll accuracy and time: devflat's exact development against libigl LSCM, LSCM + ARAP
and FreeCAD's flatmesh.FaceUnwrapper, on the same strip meshes, in one run.

    python bench/bench_unroll.py [--rulings 100]

For each plate (configs/plate.yaml, configs/frustum.yaml, a lampshade piece and a
Series 60 hull plate) prints the max and RMS relative edge-length error, the area ratio,
the boundary length error in mm per metre (flat c and d polylines against the 3D arc
lengths) and the wall time, with the ratios to devflat. FreeCAD is run through
freecadcmd; without it the line says so.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from common import machine_line, plates, timed

import igl  # noqa: E402
import numpy as np  # noqa: E402

from flatten.develop import develop  # noqa: E402
from flatten.metrics import edge_lengths, polyline_length, triangle_areas, unique_edges  # noqa: E402

FREECAD_SCRIPT = r"""
import json, os, time
import numpy as np
import flatmesh
data = json.load(open(os.environ["DEVFLAT_MESH"]))
V = np.array(data["V"]); F = np.array(data["F"])
start = time.perf_counter()
unwrapper = flatmesh.FaceUnwrapper(V, F)
unwrapper.findFlatNodes(10, 0.95)
uv = np.array(unwrapper.ze_nodes)
elapsed = time.perf_counter() - start
json.dump({"uv": uv.tolist(), "time": elapsed}, open(os.environ["DEVFLAT_UV"], "w"))
"""


def aligned_error(flat, reference):
    """Largest vertex distance after the best rigid motion (2D Kabsch, no scaling)."""
    a = flat - flat.mean(axis=0)
    b = reference - reference.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    rot = u @ vt
    if np.linalg.det(rot) < 0:
        u[:, -1] *= -1
        rot = u @ vt
    return float(np.linalg.norm(a @ rot - b, axis=1).max())


def frustum_sector(c, strip, r1=3000.0, r2=2000.0, h=1500.0):
    """Closed-form development of the frustum: annular sector (DESIGN 1.6)."""
    s = np.hypot(r1 - r2, h)
    rho1, rho2 = r1 * s / (r1 - r2), r2 * s / (r1 - r2)
    p = c(strip.rulings[:, 0])
    angle = np.arctan2(p[:, 1], p[:, 0]) * (r1 - r2) / s
    radius = rho1 + strip.samples[None, :] * (rho2 - rho1)
    return np.stack([radius * np.cos(angle)[:, None], radius * np.sin(angle)[:, None]], axis=-1).reshape(-1, 2)


def figures(V, F, flat, ruling_edges, boundary_c, boundary_d, arc_c, arc_d, reference):
    size = float(np.ptp(reference, axis=0).max())
    edges = unique_edges(F)
    l3, l2 = edge_lengths(V, edges), edge_lengths(flat, edges)
    rel = np.abs(l2 - l3) / l3
    r3, r2 = edge_lengths(V, ruling_edges), edge_lengths(flat, ruling_edges)
    area = triangle_areas(flat, F).sum() / triangle_areas(V, F).sum()
    mm_c = 1000 * (polyline_length(flat[boundary_c]) - arc_c) / arc_c
    mm_d = 1000 * (polyline_length(flat[boundary_d]) - arc_d) / arc_d
    return (aligned_error(flat, reference) / size, float(np.max(np.abs(r2 - r3) / r3)), rel.max(),
            np.sqrt(np.mean(rel**2)), area, max(abs(mm_c), abs(mm_d)))


def lscm(V, F, b, bc):
    uv, _ = igl.lscm(V, F, b, bc)
    return uv


def lscm_arap(V, F, b, bc):
    uv = lscm(V, F, b, bc)
    data = igl.ARAPData()
    data.max_iter = 50
    igl.arap_precomputation(V, F, 2, b.astype(np.int32), data)
    return igl.arap_solve(bc, data, uv)


def freecad(V, F):
    exe = shutil.which("freecadcmd") or shutil.which("FreeCADCmd")
    if exe is None:
        return None, "skipped: freecadcmd not installed (Debian package freecad)"
    with tempfile.TemporaryDirectory() as tmp:
        script, mesh, result = Path(tmp, "unwrap.py"), Path(tmp, "mesh.json"), Path(tmp, "uv.json")
        script.write_text(FREECAD_SCRIPT)
        mesh.write_text(json.dumps({"V": V.tolist(), "F": F.tolist()}))
        env = dict(os.environ, DEVFLAT_MESH=str(mesh), DEVFLAT_UV=str(result))
        done = subprocess.run([exe, str(script)], capture_output=True, text=True, timeout=600, env=env)
        if not result.exists():
            return None, f"skipped: freecadcmd failed: {(done.stderr or done.stdout).strip()[-200:]}"
        out = json.loads(result.read_text())
        return (np.array(out["uv"])[:, :2], out["time"]), ""


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rulings", type=int, default=100)
    args = parser.parse_args(argv)
    print(machine_line())
    print(f"{args.rulings} rulings x 5 samples per plate; LSCM / ARAP pinned at two vertices placed "
          "where devflat's development puts them (same scale and position)")
    header = (f"{'plate':<16}{'method':<22}{'vertex err':>11}{'ruling err':>11}{'max edge':>10}{'rms edge':>10}"
              f"{'area ratio':>14}{'bnd mm/m':>10}{'time s':>9}{'time x':>8}")
    print(header)
    print("-" * len(header))
    for plate in plates(args.rulings):
        strip, c, d = plate.strip, plate.c, plate.d
        V, F = strip.vertices, strip.faces.astype(np.int64)
        m = len(strip.samples)
        k = np.arange(strip.n_rulings) * m
        bc_idx, bd_idx = k, k + m - 1
        arc_c = float(np.diff(c.arc_length_at(strip.rulings[[0, -1], 0]))[0])
        arc_d = abs(float(np.diff(d.arc_length_at(strip.rulings[[0, -1], 1]))[0]))
        ours_time, dev = timed(develop, c, d, strip.rulings, plate.solution.field, repeat=3)
        flat = dev.vertices(strip.samples)
        rows = [("devflat exact", flat, ours_time)]
        b = np.array([0, len(V) - 1], dtype=np.int64)
        bc = flat[b]
        t, uv = timed(lscm, V, F, b, bc, repeat=3)
        rows.append(("libigl LSCM", uv, t))
        t, uv = timed(lscm_arap, V, F, b, bc)
        rows.append(("libigl LSCM+ARAP", uv, t))
        fc, why = freecad(V, F)
        if fc is not None:
            rows.append(("FreeCAD FaceUnwrapper", fc[0], fc[1]))
        if plate.name == "frustum":
            reference, label = frustum_sector(c, strip), "closed-form annular sector"
        else:
            reference, label = flat, "devflat's development (exact on the frustum and the cylinder tests)"
        print(f"{plate.name}: vertex error against the {label}")
        for method, uv, t in rows:
            v_err, r_err, mx, rms, area, mm = figures(V, F, uv, strip.ruling_edges(), bc_idx, bd_idx, arc_c,
                                                      arc_d, reference)
            print(f"{plate.name:<16}{method:<22}{v_err:>11.1e}{r_err:>11.1e}{mx:>10.1e}{rms:>10.1e}{area:>14.10f}"
                  f"{mm:>10.2e}{t:>9.4f}{t / ours_time:>8.1f}")
        if fc is None:
            print(f"{plate.name:<16}{'FreeCAD FaceUnwrapper':<22}  {why}")
    print("vertex err: largest vertex distance / part size after the best rigid motion; ruling err: largest")
    print("relative error of the ruling (bending line) lengths; max/rms edge: |flat - 3D| / 3D over all mesh edges")
    print("(devflat's non-ruling edges differ from their 3D chords by the chord discrepancy O(h^2) of the smooth")
    print("development: the mesh-based methods fit the polyhedral mesh, devflat the smooth plate that is bent).")
    return 0


if __name__ == "__main__":
    sys.exit(main())
