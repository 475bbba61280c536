"""A delivered strip plate moved rigidly: its place on the shell chosen with its neighbours'.

A strip is one developable surface within the fit tolerance of its region; where the joint
fit-up (:mod:`.joint`) moves it so that its edges meet its neighbours', the plate itself is
the same: its development, outline, bending lines, marks and templates are intrinsic to it,
and its shop data are computed on the plate as developed (cut at its butt planes where it
was developed: the moved plate re-cut at them would be another piece of the strip). What
changes is where it sits: its edges, measured against its neighbours' by the fit-up, and its
distance from the hull are those of the moved plate at once (:func:`moved_rigidly`), and its
3D geometry (the strip's vertices, or the region mesh it is cut to) moves once its shop data
are done: the move is the last step of the shop work the plate owes (:mod:`.plateshop`), for
the OBJ and the pictures. Its frame marks stay where the plate
was developed to meet the frames: the move shifts them along the plate by at most the move
itself, within the fit tolerance.
"""

from __future__ import annotations

import copy
import dataclasses
import functools

import numpy as np

RULE = ("moved rigidly (its development, outline, bending lines, marks and templates those of the plate as "
        "developed) so that its edges meet its neighbours' (strake.fit_up: follow): p -> about + rotation (p - about) "
        "+ translation, model units; hull_fit is the moved plate's distance from the hull (plate to hull)")


def moved_rigidly(result, move: dict):
    """A copy of a strip plate's result (the input is not changed: a plan's cache may share
    it) to be moved by ``move`` ({rotation (3, 3), translation (3,), centre (3,),
    largest_move_mm}, :func:`.joint.joint_moves`): its fit-up edges moved and its
    ``hull_fit`` measured on the moved plate now, its 3D geometry moved once its owed shop
    data are done (at once when it owes none)."""
    transform = _transform(move)
    from .fitup import kept_edges

    # its edges as the plate was developed, moved: the sides of its boundary are told by the
    # butt planes within the tolerance, which a move along the hull could take a corner past
    out = copy.copy(result)
    out.figures = dict(result.figures)
    out.figures["fitup_edges"] = moved_edges(kept_edges(result), transform)
    points = transform(_geometry(result))
    hull = result.part.hull
    from flatten.closest import SurfaceDistance

    distance = (hull.distance or SurfaceDistance(hull.surface))(points)
    worst = int(np.argmax(distance))
    before = dict(result.figures.get("hull_fit") or {})
    # the two-sided figures of the plate as developed no longer describe it: replaced by the
    # moved plate's own distance from the hull
    kept = {k: v for k, v in before.items() if k not in ("region_to_strip_max", "strip_to_hull_max", "measured_on")}
    out.figures["hull_fit"] = dict(kept, max_distance=float(distance.max()),
                                   rms_distance=float(np.sqrt(np.mean(distance ** 2))),
                                   worst_point=np.asarray(points[worst]).tolist(),
                                   passed=bool(distance.max() <= hull.fit_tolerance),
                                   measured_on="the moved plate's points, their distance from the hull",
                                   before_move_max_distance=before.get("max_distance"))
    if "plate_class" in out.figures:
        out.figures["plate_class"] = dict(out.figures["plate_class"], max_deviation=float(distance.max()))
    out.figures["rigid_move"] = {"rule": RULE, "about": list(move["centre"]),
                                 "rotation": np.asarray(move["rotation"], dtype=np.float64).tolist(),
                                 "translation": list(move["translation"]), "largest_move_mm": move["largest_move_mm"],
                                 "placed": False}
    place_when_done(out, result, transform, "rigid_move")
    return out


def moved_edges(edges, transform):
    """A plate's fit-up edges (a :class:`.fitup.PlateEdges`, or None) moved by ``transform``
    (points (N, 3) -> (N, 3))."""
    if edges is None:
        return None
    return dataclasses.replace(edges, ring3=transform(edges.ring3),
                               edges=tuple(dataclasses.replace(e, points3=transform(e.points3)) for e in edges.edges))


def place_when_done(out, result, transform, key: str) -> None:
    """Move ``out``'s 3D geometry (a copy of ``result`` whose ``figures[key]`` records the
    move) by ``transform`` (picklable: it may travel to the worker that writes the plate) once
    the shop data the plate owes are done, on the plate as developed; at once when it owes none."""
    work = result.shop_work
    if work is None:
        _place(out, transform, key)
    else:
        out.shop_work = dataclasses.replace(work, fn=_shop_then_place, args=(work.fn, work.args, transform, key))


def _shop_then_place(result, config, fn, args, transform, key: str) -> None:
    """The shop data the plate owes (``fn(result, config, *args)``), on the plate as
    developed, then its 3D geometry moved: a :class:`.plateshop.ShopWork` that ends in the move."""
    fn(result, config, *args)
    _place(result, transform, key)


def _place(result, transform, key: str) -> None:
    """Move the result's 3D geometry (its strip's vertices, its region mesh) in place: a copy
    whose arrays are replaced, never written into."""
    if result.strip is not None:
        result.strip = dataclasses.replace(result.strip, vertices=transform(result.strip.vertices))
    if result.mesh is not None:
        result.mesh = (transform(result.mesh[0]), result.mesh[1])
    result.figures[key] = dict(result.figures[key], placed=True)


def pending_transform(result):
    """The rigid move a result records but has not yet applied to its 3D geometry (it waits
    for the plate's shop data), as a transform; None when there is none."""
    move = result.figures.get("rigid_move")
    if move is None or move.get("placed"):
        return None
    return _transform({"rotation": move["rotation"], "translation": move["translation"], "centre": move["about"]})


def shortened(move: dict, share: float) -> dict:
    """The move scaled down to ``share`` of itself: its translation and its turn's angle."""
    from .joint import turned

    turn = share * np.asarray(move["turn"], dtype=np.float64)
    return dict(move, turn=turn.tolist(), rotation=turned(turn).tolist(),
                translation=(share * np.asarray(move["translation"], dtype=np.float64)).tolist(),
                largest_move_mm=share * move["largest_move_mm"])


def _transform(move: dict):
    return functools.partial(rigid_transform, move)


def rigid_transform(move: dict, points) -> np.ndarray:
    """Points (N, 3) moved by ``move``: centre + rotation (p - centre) + translation."""
    rotation = np.asarray(move["rotation"], dtype=np.float64)
    translation = np.asarray(move["translation"], dtype=np.float64)
    centre = np.asarray(move["centre"], dtype=np.float64)
    return centre + (np.asarray(points, dtype=np.float64) - centre) @ rotation.T + translation


def _geometry(result) -> np.ndarray:
    """(N, 3) the delivered plate's 3D points: a trimmed strip's vertices, else its mesh's."""
    if result.strip is not None and result.strip.trim is not None:
        return np.asarray(result.strip.vertices, dtype=np.float64)
    return np.asarray(result.mesh[0], dtype=np.float64)
