"""Surface quality for the same boundary curves: devflat's developable strip against the
naive ruled surface T = t (what most CAD ruled surfaces do, FreeCAD's included) and a
projection-matched ruled surface (each point of c joined to its closest point on d).

    python bench/bench_surface.py [--rulings 256]

Prints, per plate and surface, the max |K| at interior vertices times the squared part
size (dimensionless; libigl angle defect over Voronoi area), the integrated |angle
defect|, and the distortion its unroll must accept: max and RMS relative edge-length
error and area ratio of the best mesh flattening (libigl LSCM + ARAP) - and, for
devflat's strip, of its exact development.
"""

from __future__ import annotations

import argparse
import sys

from bench_unroll import lscm_arap
from common import machine_line, plates

import numpy as np  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

from flatten.develop import develop  # noqa: E402
from flatten.meshcheck import angle_defects, naive_rulings  # noqa: E402
from flatten.metrics import edge_lengths, triangle_areas, unique_edges  # noqa: E402
from flatten.strip import build_strip, choose_rulings  # noqa: E402


def projection_rulings(c, d, n: int) -> np.ndarray:
    """T(t) = the closest point of d to c(t): KD-tree start, Newton on (d - c) . d' = 0."""
    t = np.linspace(*c.domain, n)
    dense = np.linspace(*d.domain, 20001)
    _, idx = cKDTree(d(dense)).query(c(t))
    T = dense[idx]
    pc = c(t)
    for _ in range(8):
        pd, d1, d2 = d.derivatives(T, 2)
        g = np.einsum("ij,ij->i", pd - pc, d1)
        dg = np.einsum("ij,ij->i", d1, d1) + np.einsum("ij,ij->i", pd - pc, d2)
        T = np.clip(T - g / dg, *d.domain)
    return np.column_stack([t, T])


def distortion(V, F, flat):
    edges = unique_edges(F)
    edges = edges[edge_lengths(V, edges) > 0]
    rel = np.abs(edge_lengths(flat, edges) - edge_lengths(V, edges)) / edge_lengths(V, edges)
    return rel.max(), np.sqrt(np.mean(rel**2)), triangle_areas(flat, F).sum() / triangle_areas(V, F).sum()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rulings", type=int, default=256)
    args = parser.parse_args(argv)
    print(machine_line())
    header = (f"{'plate':<16}{'surface':<24}{'max|K| L^2':>12}{'sum|defect|':>13}  {'flattening':<18}"
              f"{'max edge':>10}{'rms edge':>10}{'area ratio':>14}")
    print(header)
    print("-" * len(header))
    for plate in plates(20):
        c, d, n = plate.c, plate.d, args.rulings
        surfaces = [("devflat developable", choose_rulings(plate.solution, c, d, n_rulings=n)),
                    ("naive T = t", naive_rulings(c, d, n)),
                    ("projection-matched", projection_rulings(c, d, n))]
        for label, rulings in surfaces:
            strip = build_strip(c, d, rulings, 5)
            V, F = strip.vertices, strip.faces.astype(np.int64)
            areas = triangle_areas(V, F)
            F = F[areas > 1e-12 * areas.max()]  # fans at the ends of projection-matched rulings
            used = np.unique(F)
            if len(used) < len(V):  # libigl's ARAP needs every vertex referenced
                remap = np.full(len(V), -1)
                remap[used] = np.arange(len(used))
                V, F = V[used], remap[F]
            size = float(np.ptp(V, axis=0).max())
            k = angle_defects(V, F)
            # pin both ends of the first ruling: a straight segment keeps its length when flat
            m = len(strip.samples)
            first = strip.vertices[[0, m - 1]]
            b = np.array([int(np.argmin(np.linalg.norm(V - p, axis=1))) for p in first], dtype=np.int64)
            bc = np.array([[0.0, 0.0], [np.linalg.norm(first[1] - first[0]), 0.0]])
            flats = []
            if label.startswith("devflat"):
                dev = develop(c, d, rulings, plate.solution.field).vertices(strip.samples)
                flats.append(("exact development", dev if len(dev) == len(V) else dev[used]))
            flats.append(("LSCM + ARAP", lscm_arap(V, F, b, bc)))
            for k_row, (method, flat) in enumerate(flats):
                mx, rms, area = distortion(V, F, flat)
                first = f"{plate.name:<16}{label:<24}{k.max_abs_K * size**2:>12.2e}{k.integrated_abs_defect:>13.2e}"
                lead = first if k_row == 0 else " " * len(first)
                print(f"{lead}  {method:<18}{mx:>10.2e}{rms:>10.2e}{area:>14.8f}")
    print("max|K| L^2: pointwise Gaussian curvature at interior vertices times the squared part size.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
