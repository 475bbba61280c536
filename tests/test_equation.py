"""The developability field: Plücker factorisation, degrees, roots on lines."""

import numpy as np
from hypothesis import given, settings, strategies as st

from flatten import developability_field, normalized_residual, nurbs_curve
from flatten.equation import COPLANAR, GENERAL, PARALLEL_PLANES, classify_pair
from flatten.plucker import reciprocal_matrix, wedge
from tests.oracles import circular_arc, planar_cubics_on_parallel_planes

FLOATS = st.floats(-10, 10, allow_nan=False)


@settings(max_examples=50, derandomize=True, deadline=None)
@given(st.lists(FLOATS, min_size=16, max_size=16))
def test_reciprocal_product_is_the_4x4_determinant(values):
    m = np.array(values).reshape(4, 4)
    got = wedge(m[:, 0], m[:, 1]) @ reciprocal_matrix() @ wedge(m[:, 2], m[:, 3])
    assert np.isclose(got, np.linalg.det(m), rtol=1e-9, atol=1e-9 * np.abs(m).max() ** 4)


def random_rational(seed, n, knots=None, name="c"):
    rng = np.random.default_rng(seed)
    return nurbs_curve(rng.normal(size=(n, 3)), 3, weights=rng.uniform(0.5, 2.0, n), knots=knots, name=name)


def test_field_equals_homogeneous_determinant_and_its_derivatives():
    c = random_rational(0, 6)
    d = random_rational(1, 7, knots=[0, 0, 0, 0, 0.2, 0.3, 0.7, 2, 2, 2, 2], name="d")
    field = developability_field(c, d)
    assert field.kind == GENERAL
    # Theorem 1: degree 2n - 2 in each variable per span pair
    assert field.cells.shape == (c.n_spans, d.n_spans, 5, 5)
    rng = np.random.default_rng(2)
    t, T = rng.uniform(*c.domain, 20), rng.uniform(*d.domain, 20)
    hc, hd = c.homogeneous_derivatives(t, 2), d.homogeneous_derivatives(T, 2)

    def det(a, b, e, f):
        return np.linalg.det(np.stack([a, b, e, f], axis=-1))

    np.testing.assert_allclose(field(t, T), det(hc[0], hc[1], hd[0], hd[1]), rtol=1e-10)
    np.testing.assert_allclose(field(t, T, 1, 0), det(hc[0], hc[2], hd[0], hd[1]), rtol=1e-9)
    np.testing.assert_allclose(field(t, T, 0, 1), det(hc[0], hc[1], hd[0], hd[2]), rtol=1e-9)
    # f = ± w^2 W^2 g
    pc, dc = c.derivatives(t, 1)
    pd, dd = d.derivatives(T, 1)
    g = np.einsum("ij,ij->i", np.cross(dc, dd), pd - pc)
    ratio = field(t, T) / (hc[0][:, 3] ** 2 * hd[0][:, 3] ** 2 * g)
    np.testing.assert_allclose(np.abs(ratio), 1.0, rtol=1e-9)


def test_top_degree_term_cancels_for_every_span_pair():
    c = random_rational(3, 8)
    d = random_rational(4, 5, name="d")
    field = developability_field(c, d)
    # direct dense sampling of f(t_k, ·) on a span of d is a quartic: a degree-5 fit leaves zero top term
    T = np.linspace(*d.breakpoints[:2], 9)
    values = field(np.full(9, 0.3), T)
    fit = np.polynomial.polynomial.polyfit((T - T[0]) / (T[-1] - T[0]), values, 6)
    assert np.all(np.abs(fit[5:]) <= 1e-8 * np.abs(fit).max())


def test_parallel_planes_are_detected_and_solved_at_degree_q_minus_1():
    c, d = planar_cubics_on_parallel_planes()
    kind, plane = classify_pair(c, d, 1e-10)
    assert kind == PARALLEL_PLANES
    assert np.isclose(abs(plane["height"]), 1.2)
    reduced = developability_field(c, d, kind, plane)
    full = developability_field(c, d)
    assert reduced.degree_in_T == d.degree - 1 and reduced.degree_in_t == c.degree - 1
    assert full.degree_in_T == 2 * d.degree - 2
    # the full-form coefficients above degree q - 1 vanish: the degree drop is real
    top = np.abs(full.cells[:, :, :, d.degree:]).max()
    assert top <= 1e-12 * np.abs(full.cells).max()
    # both forms have the same zero set: proportional values
    rng = np.random.default_rng(0)
    t, T = rng.uniform(0, 1, 50), rng.uniform(0, 1, 50)
    ratio = full(t, T) / reduced(t, T)
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-9)


def test_pair_classification():
    arc1 = circular_arc(1.0, 0.0, 1.0)
    arc2 = circular_arc(2.0, 0.0, 1.5, name="d")
    assert classify_pair(arc1, arc2, 1e-10)[0] == COPLANAR
    arc3 = circular_arc(2.0, 1.0, 1.5, name="d")  # rational: no degree drop
    assert classify_pair(arc1, arc3, 1e-10)[0] == GENERAL


@settings(max_examples=25, derandomize=True, deadline=None)
@given(seed=st.integers(0, 10_000), t=st.floats(0.0, 1.0))
def test_batched_roots_match_numpy_roots_per_line(seed, t):
    c = random_rational(seed, 6)
    d = random_rational(seed + 1, 6, name="d")
    field = developability_field(c, d)
    _, roots, _ = field.roots_in_T(np.array([t]))
    # baseline: numpy.roots on each span polynomial, one at a time
    coefs = field.polynomials_in_T(np.array([t]))[0]
    expected = []
    b = d.breakpoints
    for j, poly in enumerate(coefs):
        for r in np.roots(poly[::-1]):
            if abs(r.imag) < 1e-9 and -1e-12 <= r.real <= 1 + 1e-12:
                expected.append(b[j] + r.real * (b[j + 1] - b[j]))
    expected = np.unique(np.round(expected, 9))
    assert len(np.unique(np.round(roots, 9))) == len(expected)
    np.testing.assert_allclose(np.sort(np.unique(np.round(roots, 9))), expected, atol=2e-9)
    if len(roots):
        assert normalized_residual(c, d, np.full(len(roots), t), roots).max() <= 1e-12


@settings(max_examples=10, derandomize=True, deadline=None)
@given(seed=st.integers(0, 10_000), rational=st.booleans())
def test_a_zero_speed_end_is_divided_out_of_the_field(seed, rational):
    # a doubled first pole of c and last pole of d: C' = 0 at t = t0 and D' = 0 at
    # T = T1, so det[C, C', D, D'] vanishes on both side lines (no tangent line there in
    # the product, yet the curves have one). The field is the determinant divided by s
    # on c's first span and by (1 - σ) on d's last span; elsewhere it is the determinant.
    rng = np.random.default_rng(seed)
    pc, pd = rng.normal(size=(5, 3)), rng.normal(size=(6, 3)) + [0.0, 0.0, 3.0]
    wc = rng.uniform(0.5, 2.0, 6) if rational else None
    wd = rng.uniform(0.5, 2.0, 7) if rational else None
    if rational:  # the doubled pole keeps its weight: the point stands still
        wc[1], wd[-1] = wc[0], wd[-2]
    c = nurbs_curve(np.vstack([pc[:1], pc]), 3, weights=wc, knots=[0, 0, 0, 0, 0.3, 0.6, 1, 1, 1, 1], name="c")
    d = nurbs_curve(np.vstack([pd, pd[-1:]]), 3, weights=wd, knots=[0, 0, 0, 0, 0.2, 0.5, 0.8, 1, 1, 1, 1], name="d")
    field = developability_field(c, d)
    t, T = rng.uniform(0.0, 1.0, 400), rng.uniform(0.0, 1.0, 400)
    hc, hd = c.homogeneous_derivatives(t, 1), d.homogeneous_derivatives(T, 1)
    det = np.linalg.det(np.stack([hc[0], hc[1], hd[0], hd[1]], axis=-1))
    s = np.where(t < 0.3, t / 0.3, 1.0)  # c's first span [0, 0.3]
    sigma = np.where(T >= 0.8, (T - 0.8) / 0.2, 0.0)  # d's last span [0.8, 1]
    np.testing.assert_allclose(field(t, T) * s * (1.0 - sigma), det, rtol=1e-8, atol=1e-12 * np.abs(det).max())
    # on the side lines the field keeps its size (the tangent line C ∧ C'' there)
    on_sides = np.abs(np.concatenate([field(np.zeros(200), np.linspace(0.0, 1.0, 200)),
                                      field(np.linspace(0.0, 1.0, 200), np.ones(200))]))
    assert np.median(on_sides) > 1e-6 * np.abs(det).max()
