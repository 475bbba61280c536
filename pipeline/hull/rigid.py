"""A delivered strip plate moved rigidly: its place on the shell chosen with its neighbours'.

A strip is one developable surface within the fit tolerance of its region; where the joint
fit-up (:mod:`.joint`) moves it so that its edges meet its neighbours', the plate itself is
the same: its development, outline, bending lines and marks are intrinsic to it and do not
change. What changes is where it sits: its 3D geometry (the strip's vertices, or the region
mesh it is cut to) and the seam curves its shop data are computed from move with it, and it
is measured against the hull again. Its frame marks stay where the plate was developed to
meet the frames: the move shifts them along the plate by at most the move itself, within the
fit tolerance.
"""

from __future__ import annotations

import copy
import dataclasses

import numpy as np

RULE = ("moved rigidly (its development, outline, bending lines and marks unchanged) so that its edges meet its "
        "neighbours' (strake.fit_up: follow): p -> about + rotation (p - about) + translation, model units")


def moved_rigidly(result, move: dict):
    """A copy of a strip plate's result (the input is not changed: a plan's cache may share
    it) moved by ``move`` ({rotation (3, 3), translation (3,), centre (3,), largest_move_mm},
    :func:`.joint.joint_moves`), its ``hull_fit`` measured again on the moved geometry."""
    rotation = np.asarray(move["rotation"], dtype=np.float64)
    translation = np.asarray(move["translation"], dtype=np.float64)
    centre = np.asarray(move["centre"], dtype=np.float64)

    def moved(points):
        return centre + (np.asarray(points, dtype=np.float64) - centre) @ rotation.T + translation

    from .fitup import plate_edges

    # its edges as the plate was developed, moved: the sides of its boundary are told by the
    # butt planes within the tolerance, which a move along the hull could take a corner past
    edges = result.figures.get("fitup_edges") or plate_edges(result)
    out = copy.copy(result)
    out.figures = dict(result.figures)
    out.figures["fitup_edges"] = None if edges is None else dataclasses.replace(
        edges, ring3=moved(edges.ring3),
        edges=tuple(dataclasses.replace(e, points3=moved(e.points3)) for e in edges.edges))
    if result.strip is not None:
        out.strip = dataclasses.replace(result.strip, vertices=moved(result.strip.vertices))
    if result.mesh is not None:
        out.mesh = (moved(result.mesh[0]), result.mesh[1])
    work = result.shop_work
    if work is not None and work.part is not None:
        out.shop_work = dataclasses.replace(work, part=_moved_part(work.part, moved))
    points = out.strip.vertices if out.strip is not None and out.strip.trim is not None else out.mesh[0]
    hull = result.part.hull
    from flatten.closest import SurfaceDistance

    distance = (hull.distance or SurfaceDistance(hull.surface))(points)
    worst = int(np.argmax(distance))
    before = dict(result.figures.get("hull_fit") or {})
    out.figures["hull_fit"] = dict(before, max_distance=float(distance.max()),
                                   rms_distance=float(np.sqrt(np.mean(distance ** 2))),
                                   worst_point=np.asarray(points[worst]).tolist(),
                                   passed=bool(distance.max() <= hull.fit_tolerance),
                                   before_move_max_distance=before.get("max_distance"))
    out.figures["rigid_move"] = {"rule": RULE, "about": centre.tolist(), "rotation": rotation.tolist(),
                                 "translation": translation.tolist(), "largest_move_mm": move["largest_move_mm"]}
    return out


def shortened(move: dict, share: float) -> dict:
    """The move scaled down to ``share`` of itself: its translation and its turn's angle."""
    from .joint import turned

    turn = share * np.asarray(move["turn"], dtype=np.float64)
    return dict(move, turn=turn.tolist(), rotation=turned(turn).tolist(),
                translation=(share * np.asarray(move["translation"], dtype=np.float64)).tolist(),
                largest_move_mm=share * move["largest_move_mm"])


def _moved_part(part, moved):
    """A copy of the part its shop data are computed from, its seam curves moved."""
    from flatten.nurbs import nurbs_curve

    out = copy.copy(part)
    for key in ("c", "d"):
        curve = getattr(part, key)
        setattr(out, key, nurbs_curve(moved(curve.control_points), curve.degree, curve.weights, curve.knots,
                                      curve.name))
    return out
