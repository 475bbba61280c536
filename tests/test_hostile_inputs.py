"""Hostile inputs: every one ends in exit 0, 1 or 2 with a message naming the file, the
field and the value, never a traceback, a signal or a hang, and a refused run leaves
the output folder as it was (not created)."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings, strategies as st

from pipeline.cli import main

ROOT = Path(__file__).resolve().parents[1]
SHIP = ROOT / "tests" / "data" / "ship"

C = [[0, 0, 0], [100, 20, 0], [200, 20, 5], [300, 0, 0]]
D = [[0, 0, 500], [100, 30, 500], [200, 30, 510], [300, 0, 500]]
GOOD = {"name": "p", "units": "mm", "resolution": {"rulings": 12}, "output": {"png": False, "obj": False},
        "curves": {"c": {"degree": 3, "control_points": C}, "d": {"degree": 3, "control_points": D}}}


def changed(*pairs) -> dict:
    """GOOD with (key path, value) pairs set; value DELETE removes the key."""
    data = yaml.safe_load(yaml.safe_dump(GOOD))
    for path, value in zip(pairs[::2], pairs[1::2]):
        node = data
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    return data


def smooth_pair(degree: int) -> dict:
    t = np.linspace(0.0, 1.0, degree + 2)
    c = np.column_stack([300 * t, 20 * np.sin(3 * t), 5 * t**2]).round(6).tolist()
    d = np.column_stack([300 * t, 30 * np.sin(3 * t) + 10, 500 + 5 * t]).round(6).tolist()
    return {"c": {"degree": degree, "control_points": c}, "d": {"degree": degree, "control_points": d}}


def iges_126(points, degree, knots, weights=None, unit_flag=2) -> str:
    """A minimal fixed-format IGES file holding one entity 126 (rational B-spline curve)."""
    weights = [1.0] * len(points) if weights is None else weights
    values = ([126, len(points) - 1, degree, 0, 0, 1, 0] + list(knots) + list(weights)
              + [x for point in points for x in point] + [knots[degree], knots[-degree - 1], 0, 0, 1])
    # a str is written as given (a malformed token), numbers as Python writes them
    text = ",".join(v if isinstance(v, str) else repr(v) for v in np.asarray(values, dtype=object).tolist()) + ";"
    p_lines = [text[k:k + 64] for k in range(0, len(text), 64)]
    g = "1H,,1H;,4HTEST,8HTEST.IGS,1HX,1HX,32,38,6,308,15,4HTEST,1.,%d,2HMM,1,1.,1HX,1E-6,1000.,1HX,1HX,11,0;" % unit_flag
    g_lines = [g[k:k + 72] for k in range(0, len(g), 72)]
    lines = ["".ljust(72) + "S      1"]
    lines += [line.ljust(72) + f"G{k + 1:7d}" for k, line in enumerate(g_lines)]
    lines += [f"{126:8d}{1:8d}{0:8d}{0:8d}{0:8d}{0:8d}{0:8d}{0:8d}{0:8d}".ljust(72) + "D      1",
              f"{126:8d}{0:8d}{0:8d}{len(p_lines):8d}{0:8d}".ljust(72) + "D      2"]
    lines += [line.ljust(64) + f"{1:8d}P{k + 1:7d}" for k, line in enumerate(p_lines)]
    lines.append(f"S{1:7d}G{len(g_lines):7d}D{2:7d}P{len(p_lines):7d}".ljust(72) + "T      1")
    return "\n".join(lines) + "\n"


def dxf_spline(degree: int, points) -> str:
    import io

    import ezdxf

    doc = ezdxf.new("R2000")
    knots = list(np.r_[np.zeros(degree + 1), np.linspace(0, 1, len(points) - degree + 1)[1:-1], np.ones(degree + 1)])
    doc.modelspace().add_open_spline(points, degree=degree, knots=knots, dxfattribs={"layer": "SEAM"})
    stream = io.StringIO()
    doc.write(stream)
    return stream.getvalue()


def dxf_polyline(points) -> str:
    import io

    import ezdxf

    doc = ezdxf.new("R2000")
    doc.modelspace().add_polyline3d(points, dxfattribs={"layer": "SEAM"})
    stream = io.StringIO()
    doc.write(stream)
    return stream.getvalue()


def with_c(source) -> dict:
    return changed(("curves", "c"), source)


def strake(**frames) -> dict:
    return {"name": "h", "output": {"png": False, "obj": False}, "resolution": {"chord_tolerance": 5.0},
            "strake": {"surface": {"iges": str(SHIP / "test_1_hull_exported.igs")},
                       "seams": [{"iso": {"v": 4.0}}, {"iso": {"v": 4.3}}], "butts": [56000, 72000],
                       "frames": frames}}


ALIAS_BOMB = "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{chr(98 + k)}: &{chr(98 + k)} [{', '.join(['*' + chr(97 + k)] * 10)}]\n" for k in range(8))
BIG_SCALAR = "name: p\nnote: " + "x" * (1 << 20) + "\n"

# (id, setup, expected exit code, pieces of the message); setup is a config mapping, the
# text of the config, or a callable(tmp_path) -> (config path, extra argv)
CASES = [
    # ------------------------------------------------------------------ files
    ("config /dev/zero", lambda tmp: (Path("/dev/zero"), []), 2, ["/dev/zero", "character device"]),
    ("config /dev/urandom", lambda tmp: (Path("/dev/urandom"), []), 2, ["/dev/urandom", "character device"]),
    ("config FIFO", lambda tmp: (fifo(tmp / "pipe.yaml"), []), 2, ["pipe.yaml", "FIFO"]),
    ("config directory", lambda tmp: (tmp, []), 2, ["a directory"]),
    ("config symlink loop", lambda tmp: (loop(tmp / "loop.yaml"), []), 2, ["loop.yaml", "symbolic links"]),
    ("config missing", lambda tmp: (tmp / "nope.yaml", []), 2, ["nope.yaml", "No such file"]),
    ("config over 1 MB", BIG_SCALAR, 2, ["configuration file has", "more than the limit"]),
    ("config not UTF-8", b"name: \xff\xfe\n", 2, ["not UTF-8"]),
    ("config NUL byte", "name: p\x00\n", 2, ["malformed YAML"]),
    ("config empty", "", 2, ["must be a mapping"]),
    ("config two documents", "name: p\n---\nname: q\n", 2, ["malformed YAML"]),
    ("config tab indentation", "name: p\ncurves:\n\tc: 1\n", 2, ["malformed YAML", ":3"]),
    # ------------------------------------------------------------------- YAML
    ("alias bomb", ALIAS_BOMB, 2, ["expands to more than"]),
    ("recursive alias", "name: &a [*a]\n", 2, ["alias *a"]),
    ("nesting 10000 deep", "name: " + "[" * 10000 + "]" * 10000 + "\n", 2, ["nesting deeper than 64", ":1"]),
    # under libyaml's own limit of 1000 levels (0.2.6): the count of events finds it
    ("nesting 200 deep", "name: " + "[" * 200 + "]" * 200 + "\n", 2, ["nesting deeper than 64", ":1"]),
    ("nesting 100 deep block", "name: p\nx:\n" + "".join("  " * k + "- \n" for k in range(1, 100)), 2,
     ["nesting deeper than 64"]),
    ("duplicate top key", "name: p\nname: q\n", 2, ["duplicate key 'name'", ":2", "line 1"]),
    ("duplicate nested key", yaml.safe_dump(GOOD, sort_keys=False).replace("degree: 3", "degree: 3\n    degree: 5", 1),
     2, ["duplicate key 'degree'"]),
    ("top level list", "- a\n- b\n", 2, ["must be a mapping"]),
    # ----------------------------------------------------------------- curves
    ("degree true", changed(("curves", "c", "degree"), True), 2, ["curves.c.degree", "boolean", "True"]),
    ("thickness true", changed(("steel",), {"thickness": True}), 2, ["steel.thickness", "boolean", "True"]),
    ("coordinate false", changed(("curves", "d", "control_points", 1), [0, False, 0]), 2,
     ["curves.d.control_points", "[1][1] is a boolean"]),
    ("degree 3.5", changed(("curves", "c", "degree"), 3.5), 2, ["curves.c.degree", "3.5"]),
    ("degree 10", changed(("curves", "c", "degree"), 10), 2, ["curves.c.degree", "9", "10"]),
    ("degree 0", changed(("curves", "d", "degree"), 0), 2, ["curves.d.degree", "0"]),
    ("coordinate 1e308", changed(("curves", "c", "control_points", 1), [1e308, 0, 0]), 2,
     ["curves.c.control_points[1][0]", "1e+308", "range"]),
    ("coordinate -1e300", changed(("curves", "d", "control_points", 2), [0, -1e300, 0]), 2,
     ["curves.d.control_points[2][1]", "-1e+300"]),
    ("coordinate .inf", "name: p\ncurves:\n  c: {control_points: [[0,0,0],[1,.inf,0],[2,0,0],[3,1,0]]}\n"
     "  d: {control_points: [[0,0,5],[1,0,5],[2,0,5],[3,1,5]]}\n", 2, ["curves.c.control_points[1][1]", "finite"]),
    ("coordinate .nan", "name: p\ncurves:\n  c: {control_points: [[0,0,0],[1,.nan,0],[2,0,0],[3,1,0]]}\n"
     "  d: {control_points: [[0,0,5],[1,0,5],[2,0,5],[3,1,5]]}\n", 2, ["curves.c.control_points[1][1]", "finite"]),
    ("coordinate 1e400", "name: p\ncurves:\n  c: {control_points: [[0,0,0],[1,1e400,0],[2,0,0],[3,1,0]]}\n"
     "  d: {control_points: [[0,0,5],[1,0,5],[2,0,5],[3,1,5]]}\n", 2, ["curves.c.control_points[1][1]", "finite"]),
    ("control points a string", changed(("curves", "c", "control_points"), "abc"), 2, ["curves.c.control_points"]),
    ("control point of 2 values", changed(("curves", "c", "control_points", 0), [0, 0]), 2,
     ["curves.c.control_points[0]"]),
    ("no control points", changed(("curves", "c", "control_points"), []), 2, ["curves.c.control_points"]),
    ("weight .inf", "name: p\ncurves:\n  c: {control_points: [[0,0,0],[1,1,0],[2,0,0],[3,1,0]], weights: [1,.inf,1,1]}\n"
     "  d: {control_points: [[0,0,5],[1,0,5],[2,0,5],[3,1,5]]}\n", 2, ["curves.c.weights[1]", "finite"]),
    ("weight 1e-320", changed(("curves", "c", "weights"), [1, 1e-320, 1, 1]), 2, ["curves.c.weights"]),
    ("knot .nan", "name: p\ncurves:\n  c: {control_points: [[0,0,0],[1,1,0],[2,0,0],[3,1,0]], "
     "knots: [0,0,0,0,.nan,1,1,1]}\n  d: {control_points: [[0,0,5],[1,0,5],[2,0,5],[3,1,5]]}\n", 2,
     ["curves.c.knots[4]", "finite"]),
    ("knot a word", changed(("curves", "c", "knots"), [0, 0, 0, 0, "a", 1, 1, 1]), 2, ["curves.c.knots[4]", "'a'"]),
    ("end multiplicity above degree",
     changed(("curves", "c", "control_points"), C + [[400, 0, 0]], ("curves", "c", "knots"), [0] * 5 + [1] * 4), 2,
     ["curves.c.knots", "multiplicity 5 > degree + 1"]),
    # control point 0 acts nowhere on the domain [1, 2] (it would hide that the curve is a point)
    ("dead control point hidden by knots",
     changed(("curves", "c", "control_points"), [[9, 9, 9]] + [[5, 5, 5]] * 4,
             ("curves", "c", "knots"), [0, 1, 1, 1, 1, 2, 2, 2, 2]), 2,
     ["curves.c.knots", "interior knot 1 has multiplicity 4 > degree 3", "[0, 1, 1, 1, 1, 2, 2, 2, 2]"]),
    ("knot domain 1e-300 wide", changed(("curves", "c", "knots"), [0, 0, 0, 0, 1e-300, 1e-300, 1e-300, 1e-300]), 2,
     ["curves.c.knots", "domain", "1e-300"]),
    ("knots 1e300", changed(("curves", "d", "knots"), [0, 0, 0, 0, 1e300, 1e300, 1e300, 1e300]), 2,
     ["curves.d.knots", "1e+300"]),
    ("coincident curves", changed(("curves", "d"), {"degree": 3, "control_points": C}), 2, ["coincide"]),
    ("all control points equal", changed(("curves", "c", "control_points"), [[5, 5, 5]] * 4), 2, ["zero length"]),
    # ------------------------------------------------------------ point lists
    ("points all equal", with_c({"points": [[1, 2, 3]] * 6, "tolerance": 0.1}), 2,
     ["curves.c", "4 distinct points", "got 1"]),
    ("points 3 distinct", with_c({"points": [[0, 0, 0], [1, 0, 0], [0, 0, 0], [2, 0, 0], [1, 0, 0]],
                                  "tolerance": 0.1}), 2, ["curves.c", "4 distinct points", "got 3"]),
    ("points 1e308", with_c({"points": [[0, 0, 0], [1, 0, 0], [2, 1e308, 0], [3, 0, 0]], "tolerance": 0.1}), 2,
     ["curves.c", "1e+308"]),
    ("points tolerance 0", with_c({"points": C, "tolerance": 0}), 2, ["curves.c.tolerance", "0"]),
    ("points 3 only", with_c({"points": C[:3], "tolerance": 1}), 2, ["curves.c.points"]),
    # -------------------------------------------------------------------- IGES
    ("IGES /dev/zero", with_c({"iges": "/dev/zero"}), 2, ["/dev/zero", "character device", "curves.c"]),
    ("IGES FIFO", lambda tmp: write(tmp, with_c({"iges": str(fifo(tmp / "f.igs"))})), 2, ["f.igs", "FIFO"]),
    ("IGES symlink loop", lambda tmp: write(tmp, with_c({"iges": str(loop(tmp / "l.igs"))})), 2,
     ["l.igs", "symbolic links"]),
    ("IGES a directory", lambda tmp: write(tmp, with_c({"iges": str(tmp)})), 2, ["directory"]),
    ("IGES text file", with_c({"iges": str(ROOT / "README.md")}), 2, ["README.md", "not an IGES"]),
    ("IGES degree 12", lambda tmp: write(tmp, with_c({"iges": str(text_file(
        tmp / "d12.igs", iges_126([[25.0 * k, 0.0, 0.0] for k in range(13)], 12,
                                  [0.0] * 13 + [1.0] * 13)))})), 2, ["d12.igs", "entity 126 at D1", "degree 12"]),
    ("IGES inf parameter", lambda tmp: write(tmp, with_c({"iges": str(text_file(
        tmp / "inf.igs", iges_126([[0, 0, 0], [1, "1D999", 0], [2, 1, 0], [3, 0, 0]], 3, [0.0] * 4 + [1.0] * 4)))})),
     2, ["inf.igs", "entity 126", "control_points[1][1]", "not finite"]),
    ("IGES 1e308 coordinate", lambda tmp: write(tmp, with_c({"iges": str(text_file(
        tmp / "big.igs", iges_126([[0, 0, 0], [1e308, 0, 0], [2, 1, 0], [3, 0, 0]], 3, [0.0] * 4 + [1.0] * 4)))})),
     2, ["big.igs", "control_points[1][0]"]),
    ("IGES entity missing", with_c({"iges": str(SHIP / "test_1_deck.igs"), "entity": 7}), 2,
     ["test_1_deck.igs", "index 7"]),
    ("IGES entity true", with_c({"iges": str(SHIP / "test_1_deck.igs"), "entity": True}), 2, ["curves.c.entity"]),
    # --------------------------------------------------------------------- DXF
    ("DXF /dev/urandom", with_c({"dxf": "/dev/urandom", "layer": "SEAM"}), 2, ["/dev/urandom", "character device"]),
    ("DXF garbage", lambda tmp: write(tmp, with_c({"dxf": str(text_file(tmp / "g.dxf", "0\nSECTION\n2\nJUNK\n" * 3)),
                                                   "layer": "SEAM"})), 2, ["g.dxf"]),
    ("DXF spline degree 11", lambda tmp: write(tmp, with_c({"dxf": str(text_file(
        tmp / "s.dxf", dxf_spline(11, [(25.0 * k, 0.0, 0.0) for k in range(14)]))), "layer": "SEAM"})), 2,
     ["s.dxf", "SPLINE", "degree 11"]),
    ("DXF polyline 3 distinct", lambda tmp: write(tmp, with_c({"dxf": str(text_file(
        tmp / "p.dxf", dxf_polyline([(0, 0, 0), (1, 0, 0), (2, 0, 0), (1, 0, 0), (2, 0, 0)]))), "layer": "SEAM"})), 2,
     ["4 distinct points", "got 3"]),
    ("DXF layer with newline", with_c({"dxf": "x.dxf", "layer": "SE\nAM"}), 2, ["curves.c.layer", "control character"]),
    # --------------------------------------------------------- steel / output
    ("thickness .inf", "name: p\nsteel: {thickness: .inf}\n" + yaml.safe_dump({"curves": GOOD["curves"]}), 2,
     ["steel.thickness", "finite", "inf"]),
    ("thickness 1e999", "name: p\nsteel: {thickness: 1e999}\n" + yaml.safe_dump({"curves": GOOD["curves"]}), 2,
     ["steel.thickness", "finite"]),
    ("density .nan", "name: p\nsteel: {density: .nan}\n" + yaml.safe_dump({"curves": GOOD["curves"]}), 2,
     ["steel.density", "finite"]),
    ("material with newline", changed(("steel",), {"material": "S355\n0\nEOF"}), 2,
     ["steel.material", "control character"]),
    ("layer with newline", changed(("output", "layers"), {"cut": "CUT\nOUTER"}), 2,
     ["output.layers.cut", "control character"]),
    ("layer 300 characters", changed(("output", "layers"), {"bend": "B" * 300}), 2, ["output.layers.bend"]),
    ("layer with a colon", changed(("output", "layers"), {"text": "A:B"}), 2, ["output.layers.text", "A:B"]),
    ("part name with a slash", changed(("name",), "../x"), 2, ["name", "../x"]),
    ("part name a dot", changed(("name",), ".."), 2, ["name", ".."]),
    # -------------------------------------------------------------- resolution
    ("rulings x samples too large", changed(("resolution",), {"rulings": 200000, "samples_per_ruling": 101}), 2,
     ["resolution", "mesh vertices"]),
    ("rulings true", changed(("resolution",), {"rulings": True}), 2, ["resolution.rulings", "True"]),
    ("samples 2.5", changed(("resolution",), {"rulings": 10, "samples_per_ruling": 2.5}), 2,
     ["resolution.samples_per_ruling", "2.5"]),
    ("chord tolerance .nan", "name: p\nresolution: {chord_tolerance: .nan}\n" + yaml.safe_dump({"curves": GOOD["curves"]}),
     2, ["resolution.chord_tolerance", "finite"]),
    # ---------------------------------------------------- sections and butts
    ("section normal NaN", "name: p\ncurves:\n  c: {iges: %s, section: {point: [0, 0, 2000], normal: [.nan, 0, 1]}}\n"
     "  d: {control_points: [[0,0,5],[1,0,5],[2,0,5],[3,1,5]]}\n" % (SHIP / "test_1_hull_exported.igs"), 2,
     ["curves.c.section.normal[0]", "finite"]),
    ("section normal zero", with_c({"iges": str(SHIP / "test_1_hull_exported.igs"),
                                    "section": {"point": [0, 0, 0], "normal": [0, 0, 0]}}), 2,
     ["curves.c.section.normal", "zero vector"]),
    ("butt NaN", "name: h\nstrake:\n  surface: {iges: x.igs}\n  seams: [{iso: {v: 4}}, {iso: {v: 4.3}}]\n"
     "  butts: [56000, .nan]\n", 2, ["strake.butts[1]", "finite"]),
    ("butt normal NaN", "name: h\nstrake:\n  surface: {iges: x.igs}\n  seams: [{iso: {v: 4}}, {iso: {v: 4.3}}]\n"
     "  butts: [56000, {point: [7e4, 0, 0], normal: [1, .nan, 0]}]\n", 2, ["strake.butts[1]", "finite"]),
    ("frames spacing 1e-6", strake(spacing=1e-6), 2, ["strake", "frames.spacing = 1e-06", "more than 1000"]),
    ("frames spacing 5e-324", strake(spacing=5e-324), 2, ["strake", "frames.spacing", "more than 1000"]),
    ("frames spacing 0", strake(spacing=0), 2, ["strake.frames.spacing", "0"]),
    # -------------------------------------------------------------- arguments
    ("--jobs 0", lambda tmp: write(tmp, GOOD, ["--jobs", "0"]), 2, ["--jobs 0", "from 1 to"]),
    ("--jobs -3", lambda tmp: write(tmp, GOOD, ["--jobs", "-3"]), 2, ["--jobs -3"]),
    ("--jobs 1000", lambda tmp: write(tmp, GOOD, ["--jobs", "1000"]), 2, ["--jobs 1000"]),
    ("--jobs abc", lambda tmp: write(tmp, GOOD, ["--jobs", "abc"]), 2, ["--jobs", "abc"]),
    # ------------------------------------------------------- accepted inputs
    ("degree 8 curves", changed(("curves",), smooth_pair(8)), 0, []),
    ("degree 9 curves", changed(("curves",), smooth_pair(9)), 0, []),
]


def fifo(path: Path) -> Path:
    os.mkfifo(path)
    return path


def loop(path: Path) -> Path:
    os.symlink(path.with_suffix(".other"), path)
    os.symlink(path, path.with_suffix(".other"))
    return path


def text_file(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def write(tmp: Path, data, argv=()) -> tuple[Path, list]:
    path = tmp / "case.yaml"
    path.write_text(yaml.safe_dump(data))
    return path, list(argv)


@pytest.fixture
def no_hang():
    """A hang becomes a failure after 60 s instead of a stuck suite."""
    def alarm(signum, frame):
        raise TimeoutError("the case hung")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.mark.parametrize("label, setup, code, expected", CASES, ids=[c[0] for c in CASES])
def test_hostile_input(label, setup, code, expected, tmp_path, capsys, no_hang):
    if callable(setup):
        config, argv = setup(tmp_path)
    else:
        config, argv = tmp_path / "case.yaml", []
        if isinstance(setup, bytes):
            config.write_bytes(setup)
        elif isinstance(setup, str):
            config.write_text(setup)
        else:
            config.write_text(yaml.safe_dump(setup))
    out = tmp_path / "out"
    result = main(["run", str(config), "--out", str(out), "--quiet", *argv])
    err = capsys.readouterr().err
    assert result == code, err
    assert "Traceback" not in err
    for piece in expected:
        assert piece in err, (piece, err)
    if code == 2:
        assert str(config) in err or argv, err  # the file is named (argument errors name the option)
        assert not out.exists()
    else:
        files = sorted(p.name for p in out.iterdir())
        assert files == ["p.dxf", "p.json", "p_summary.csv", "p_summary.json"], files


def test_the_table_is_large_enough():
    assert len(CASES) >= 60


# ------------------------------------------------------------------- fuzzing
HOSTILE_VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-10**20, 10**20), st.sampled_from([0, 1, 2, 3, 8, 9, 10, -1, 2**63]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e308, -1e308, 1e-308, 5e-324, 1e-300, 1e300, 1e9, 1e-9, -0.0, 0.5]),
    st.text(max_size=6), st.sampled_from(["a\nb", "\x00", "..", "a/b", "MM", "x" * 300]),
    st.lists(st.floats(-1e3, 1e3), max_size=4), st.lists(st.lists(st.floats(-1e3, 1e3), min_size=3, max_size=3),
                                                       max_size=6),
    st.dictionaries(st.sampled_from(["rulings", "thickness", "u", "degree"]), st.integers(-5, 5), max_size=2))

FUZZ_PATHS = [("name",), ("units",), ("profile",), ("curves", "c", "degree"), ("curves", "d", "degree"),
              ("curves", "c", "control_points"), ("curves", "c", "control_points", 1),
              ("curves", "c", "control_points", 2, 1), ("curves", "d", "weights"), ("curves", "c", "knots"),
              ("curves", "d", "knots"), ("resolution", "rulings"), ("resolution", "samples_per_ruling"),
              ("resolution", "chord_tolerance"), ("steel",), ("steel", "thickness"), ("steel", "material"),
              ("check", "max_residual"), ("check", "min_coverage"), ("output", "layers"), ("output", "dxf"),
              ("curves", "c"), ("curves",), ("parts",), ("sequence",), ("strake",)]


def set_path(data: dict, path: tuple, value) -> dict:
    node = data
    for key in path[:-1]:
        if isinstance(node, dict):
            node = node.setdefault(key, {})
        elif isinstance(node, list) and isinstance(key, int) and key < len(node):
            node = node[key]
        else:
            return data
    if isinstance(node, dict):
        node[path[-1]] = value
    elif isinstance(node, list) and isinstance(path[-1], int) and path[-1] < len(node):
        node[path[-1]] = value
    return data


@settings(max_examples=50, derandomize=True, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.lists(st.tuples(st.sampled_from(FUZZ_PATHS), HOSTILE_VALUES), min_size=1, max_size=3))
def test_fuzzed_configs_end_in_0_1_or_2_with_a_consistent_folder(tmp_path_factory, changes):
    folder = tmp_path_factory.mktemp("fuzz")
    data = yaml.safe_load(yaml.safe_dump(GOOD))
    for path, value in changes:
        set_path(data, path, value)
    config = folder / "fuzz.yaml"
    try:
        config.write_text(yaml.safe_dump(data))
    except (ValueError, yaml.YAMLError):  # not representable in YAML at all
        return
    out = folder / "out"
    previous = signal.signal(signal.SIGALRM, lambda *a: (_ for _ in ()).throw(TimeoutError("case hung")))
    signal.alarm(60)  # a hang fails the case; no case is near it
    try:
        import contextlib
        import io

        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            code = main(["run", str(config), "--out", str(out), "--quiet"])
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert code in (0, 1, 2), err.getvalue()
    assert "Traceback" not in err.getvalue()
    if code == 2:
        assert str(config) in err.getvalue() and not out.exists()
    else:
        for dxf in out.glob("*.dxf"):
            assert (out / (dxf.stem + ".json")).exists()
