"""Bad configurations exit 2 with a message naming the file, the field and the value,
and leave no file behind."""


import pytest
import yaml
from hypothesis import given, settings, strategies as st

from pipeline.cli import main

GOOD = {
    "name": "p",
    "units": "mm",
    "curves": {
        "c": {"degree": 3, "control_points": [[0, 0, 0], [100, 20, 0], [200, 20, 5], [300, 0, 0]]},
        "d": {"degree": 3, "control_points": [[0, 0, 500], [100, 30, 500], [200, 30, 510], [300, 0, 500]]},
    },
}


def with_change(path, value):
    data = yaml.safe_load(yaml.safe_dump(GOOD))
    node = data
    for key in path[:-1]:
        node = node[key]
    if value is DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return yaml.safe_dump(data)


DELETE = object()

CASES = [
    ("malformed YAML", "name: p\ncurves: {c: [1, 2\n", ["malformed YAML", ":3"]),
    ("not a mapping", "- just\n- a list\n", ["must be a mapping"]),
    ("unknown key", with_change(("colour",), "red"), ["colour", "unknown field", "red"]),
    ("unknown curve key", with_change(("curves", "c", "order"), 3), ["curves.c.order", "unknown field"]),
    ("knots of wrong length", with_change(("curves", "c", "knots"), [0, 0, 0, 1, 1, 1]),
     ["curves.c.knots has 6 values", "need 8"]),
    ("decreasing knots", with_change(("curves", "d", "knots"), [0, 0, 0, 0.7, 0.5, 1, 1, 1]),
     ["curves.d.knots", "non-decreasing"]),
    ("zero weight", with_change(("curves", "c", "weights"), [1, 0, 1, 1]), ["curves.c.weights[1]", "got 0"]),
    ("negative weight", with_change(("curves", "d", "weights"), [1, 1, -3, 1]), ["curves.d.weights[2]", "-3"]),
    ("NaN coordinate", with_change(("curves", "c", "control_points"),
                                   [[0, 0, 0], [1, float("nan"), 0], [2, 1, 0], [3, 0, 0]]),
     ["curves.c.control_points[1][1]", "nan"]),
    ("string coordinate", with_change(("curves", "c", "control_points"),
                                      [[0, 0, 0], [1, "x", 0], [2, 1, 0], [3, 0, 0]]),
     ["curves.c.control_points[1][1]", "'x'"]),
    ("too few points", with_change(("curves", "d", "control_points"), [[0, 0, 0], [1, 0, 1]]),
     ["curves.d.control_points has 2 points", "degree 3"]),
    ("missing curve", with_change(("curves", "d"), DELETE), ["curves.d", "Field required"]),
    ("bad units", with_change(("units",), "furlong"), ["units", "furlong"]),
    ("negative thickness", with_change(("steel",), {"thickness": -5}), ["steel.thickness", "-5"]),
    ("both resolutions", with_change(("resolution",), {"rulings": 10, "chord_tolerance": 1}),
     ["resolution", "either chord_tolerance or rulings"]),
    ("coincident curves", with_change(("curves", "d"), GOOD["curves"]["c"]), ["coincide"]),
    ("degenerate curve", with_change(("curves", "c", "control_points"), [[5, 5, 5]] * 4), ["zero length"]),
    ("bad part name", with_change(("name",), "a/b"), ["name", "a/b"]),
]


@pytest.mark.parametrize("label, text, expected", CASES, ids=[c[0] for c in CASES])
def test_bad_config_exits_2_naming_the_field_and_writes_nothing(label, text, expected, tmp_path, capsys):
    config = tmp_path / "bad.yaml"
    config.write_text(text)
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert str(config) in err
    for piece in expected:
        assert piece in err, (piece, err)
    assert "Traceback" not in err
    assert not out.exists()
    assert main(["check", str(config)]) == 2


def test_unreadable_file_exits_2(tmp_path, capsys):
    missing = tmp_path / "nope.yaml"
    assert main(["run", str(missing), "--out", str(tmp_path / "o")]) == 2
    assert "nope.yaml" in capsys.readouterr().err
    binary = tmp_path / "bin.yaml"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    assert main(["check", str(binary)]) == 2


def test_debug_shows_the_traceback(tmp_path, capsys):
    config = tmp_path / "bad.yaml"
    config.write_text(with_change(("units",), "furlong"))
    assert main(["--debug", "check", str(config)]) == 2
    assert "Traceback" in capsys.readouterr().err


def test_line_numbers_point_at_the_field(tmp_path, capsys):
    config = tmp_path / "bad.yaml"
    config.write_text("name: p\nunits: mm\nsteel:\n  thickness: -1\n" + yaml.safe_dump({"curves": GOOD["curves"]}))
    assert main(["check", str(config)]) == 2
    assert f"{config}:4: steel.thickness" in capsys.readouterr().err


@settings(max_examples=40, derandomize=True, deadline=None)
@given(st.recursive(st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=5),
                    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner, max_size=3),
                    max_leaves=8))
def test_arbitrary_yaml_never_crashes(tmp_path_factory, data):
    folder = tmp_path_factory.mktemp("fuzz")
    config = folder / "fuzz.yaml"
    config.write_text(yaml.safe_dump(data))
    assert main(["check", str(config)]) == 2
