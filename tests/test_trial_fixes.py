"""Defects from the new-user trial: the heating label's plural, the console summary's name
column, the hull image's plates."""

import dataclasses
import types

import numpy as np
import pytest
import yaml

from pipeline.shop.heating import group_text
from tests.hull_shapes import cylinder_sphere_iges


def _group(lines):
    return {"group": 3, "lines": lines, "side": "drawn", "shape": "dome", "max_required_strain": 0.0033,
            "passes": 1}


def test_heating_label_says_line_for_one_line():
    assert group_text(_group(1), 0.43).startswith("HEAT G3 (1 LINE): THIS SIDE (INSIDE OF ROLL), SHRINK 3.3 MM/M")
    assert group_text(_group(2), 0.43).startswith("HEAT G3 (2 LINES): ")
    assert group_text(_group(9), 0.43) == ("HEAT G3 (9 LINES): THIS SIDE (INSIDE OF ROLL), SHRINK 3.3 MM/M, "
                                           "0.43 MM A LINE")


def _row(name, status="ok"):
    from pipeline.stages import PartResult

    return PartResult(name, None, status=status, figures={"area_m2": 1.5})


def test_summary_table_name_column_fits_the_longest_name():
    from pipeline.report import summary_table

    long = "part1_P1_S01_B01-1-1-1"  # 22 characters: ran into the status column
    lines = summary_table([_row("a"), _row(long), _row(long + "-extra", "failed")]).splitlines()
    header, rows = lines[0], lines[2:]
    assert rows[1].split()[:2] == [long, "ok"] and rows[2].split()[:2] == [long + "-extra", "failed"]
    # the columns stay aligned: every row's status starts under the header's
    at = header.index("status")
    assert all(row[at - 1] == " " and row[at:].split()[0] in ("ok", "failed") for row in rows)
    assert len(lines[1]) == len(header)


def test_summary_table_short_names_as_before():
    from pipeline.report import summary_table

    lines = summary_table([_row("bilge_plate")]).splitlines()
    assert lines[0].startswith("part" + " " * 18 + "status  ")
    assert lines[2].startswith("bilge_plate" + " " * 11 + "ok      ")


@pytest.fixture(scope="module")
def cs_run(tmp_path_factory):
    """A uniform plan of the cylinder-sphere in strakes 1.5 m wide, each plate run: on the
    cylinder one plate delivered as a strip trimmed by its butts (``strip.trim``) and two
    as trimmed strips (their 3D shape ``result.mesh``), on the sphere six formed plates."""
    from pipeline.hull.plan import load_run
    from pipeline.runner import guarded_run

    tmp = tmp_path_factory.mktemp("cs")
    iges = cylinder_sphere_iges(tmp / "cs.igs", 10000.0, 60.0, 1500.0, 3000.0, 0.3)
    plan = {"method": "uniform", "stock": {"max_length": 4000, "max_width": 1500, "min_length": 1000,
                                           "min_width": 1000}}
    data = {"name": "cs", "units": "mm", "resolution": {"chord_tolerance": 1.0}, "output": {"png": True},
            "strake": {"surface": {"iges": str(iges)}, "margin": 0.2, "fit_tolerance": 5.0, "plan": plan}}
    path = tmp / "cs.yaml"
    path.write_text(yaml.safe_dump(data))
    config = load_run(path)
    return config, [guarded_run(part, config) for part in config.parts]


def test_hull_image_draws_every_plate_with_a_3d_shape(cs_run, tmp_path, monkeypatch):
    """NAME_hull.png drew only the plates delivered as strips with a trim (one of nine here)."""
    from pipeline import export, plots

    config, results = cs_run
    assert all(r.ok for r in results) and len(results) == 9
    strips = [r for r in results if r.strip is not None and r.strip.trim is not None]
    meshes = [r for r in results if r.strip is None and r.mesh is not None]
    assert len(strips) == 1 and len(meshes) == 8  # what the old image drew, what it left out
    drawn = []
    hull_png = plots.hull_png
    monkeypatch.setattr(plots, "hull_png", lambda target, plates, *args: (drawn.append(plates),
                                                                          hull_png(target, plates, *args)))
    classed = [r for r in results if (r.figures.get("plate_class") or {}).get("class")]
    written = export._images(results, classed, config, tmp_path, "cs")
    assert tmp_path / "cs_hull.png" in written and (tmp_path / "cs_hull.png").stat().st_size > 0
    [plates] = drawn
    assert [name for name, *_ in plates] == [r.name for r in results]
    for (name, ring, deviation), r in zip(plates, results):
        assert deviation == r.figures["hull_fit"]["max_distance"]  # the summary's hull deviation
        assert ring.shape[1] == 3 and len(ring) >= 4
    # the strip's boundary as the old image drew it
    r = strips[0]
    grid = r.strip.vertices.reshape(-1, len(r.strip.samples), 3)
    [ring] = [ring for name, ring, _ in plates if name == r.name]
    np.testing.assert_array_equal(ring, np.vstack([grid[:, 0], grid[::-1, -1]]))
    # each mesh plate's boundary is its own grid's, on the hull where the plate lies
    for r in meshes:
        [ring] = [ring for name, ring, _ in plates if name == r.name]
        v = r.mesh[0]
        assert np.all(ring.min(axis=0) >= v.min(axis=0) - 1e-9) and np.all(ring.max(axis=0) <= v.max(axis=0) + 1e-9)
        assert np.ptp(ring, axis=0) == pytest.approx(np.ptp(v, axis=0), rel=1e-9)


def test_hull_image_skips_plates_without_shape_and_greys_plates_without_deviation(cs_run, tmp_path):
    from pipeline.export import hull_image_plates
    from pipeline.plots import hull_png

    _, results = cs_run
    formed = results[-1]
    no_figure = dataclasses.replace(formed, name="cs_no_fit", figures={k: v for k, v in formed.figures.items()
                                                                      if k != "hull_fit"})
    failed = dataclasses.replace(formed, name="cs_failed", status="failed", strip=None, mesh=None)
    plain = dataclasses.replace(formed, name="pair", part=types.SimpleNamespace(hull=None))  # a curve-pair part
    plates = hull_image_plates([results[0], no_figure, failed, plain])
    assert [name for name, *_ in plates] == [results[0].name, "cs_no_fit"]
    assert np.isnan(plates[1][2]) and not np.isnan(plates[0][2])
    hull_png(tmp_path / "h.png", plates, 5.0, "mm")
    assert (tmp_path / "h.png").stat().st_size > 0
    assert hull_image_plates([plain]) == []  # a run without hull plates draws no hull image
