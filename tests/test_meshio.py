"""The strip's OBJ file reads back to the very doubles and faces it was written from."""

from __future__ import annotations

import numpy as np
from hypothesis import given, seed, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from pipeline.io.meshio import obj_text, read_obj

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@seed(15)
@settings(max_examples=60, deadline=None)
@given(vertices=arrays(np.float64, st.tuples(st.integers(3, 12), st.just(3)), elements=finite),
       data=st.data())
def test_obj_reads_back_bit_for_bit(tmp_path_factory, vertices, data):
    n = len(vertices)
    flat = data.draw(arrays(np.float64, (n, 2), elements=finite))
    faces = data.draw(arrays(np.int64, st.tuples(st.integers(1, 8), st.just(3)), elements=st.integers(0, n - 1)))
    path = tmp_path_factory.mktemp("obj") / "strip.obj"
    path.write_text(obj_text(vertices, flat, faces, "strip"))
    v, vt, f = read_obj(path)
    assert np.array_equal(v.view(np.int64), vertices.view(np.int64))  # same bits: -0.0 stays -0.0
    assert np.array_equal(vt.view(np.int64), flat.view(np.int64))
    assert np.array_equal(f, faces)
