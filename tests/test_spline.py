"""Control splines (``mjsuff.scenes.spline``)."""

import numpy as np
import pytest

from mjsuff.scenes.spline import ControlSpline


@pytest.mark.parametrize("anchored", [False, True])
@pytest.mark.parametrize(("knots", "steps"), [(2, 2), (3, 150), (4, 151), (5, 200), (7, 250), (12, 97)])
def test_controls_are_the_hat_basis_product_bit_for_bit(knots, steps, anchored):
    """The controls must equal the full basis product to the last bit (the scenes' golden
    records were made with it), whether a spline interpolates between the two knots around each
    step or, where a rounding residue puts a third weight on a step, takes the product."""
    spline = ControlSpline(knots, steps, np.array([-3.0, -0.5]), np.array([3.0, 0.5]), anchored=anchored)
    rng = np.random.default_rng(knots * 1000 + steps)
    params = rng.uniform(-4.0, 4.0, size=(64, knots, 2))  # some beyond the bounds: clipped
    anchor = rng.uniform(-3.0, 3.0, size=(64, 2)) if anchored else None
    full = spline.clip(params)
    if anchored:
        full = np.concatenate([spline.clip(anchor)[:, None, :], full], axis=1)
    expected = np.einsum("tk,bku->btu", spline.basis, full)
    np.testing.assert_array_equal(spline.controls(params, anchor), expected)
    np.testing.assert_allclose(spline.basis.sum(axis=1), 1.0, rtol=1e-12)


@pytest.mark.parametrize(("knots", "steps", "anchored"), [(3, 150, True), (5, 200, False)])
def test_the_shipped_scenes_splines_take_the_two_knot_interpolation(knots, steps, anchored):
    """The reacher's (3 knots after an anchor, 1.5 s at 0.01 s) and the lander's (5 knots, 4 s
    at 0.02 s): the fast path, not the product."""
    spline = ControlSpline(knots, steps, np.array([-1.0]), np.array([1.0]), anchored=anchored)
    assert spline._two_knots


def test_knots_are_reached_at_their_steps():
    spline = ControlSpline(3, 101, np.array([-1.0]), np.array([1.0]))
    controls = spline.controls(np.array([[[-1.0], [0.5], [1.0]]]))
    np.testing.assert_allclose(controls[0, [0, 50, 100], 0], [-1.0, 0.5, 1.0], atol=1e-12)


def test_bad_splines_are_refused():
    with pytest.raises(ValueError, match="2 knots"):
        ControlSpline(1, 10, np.zeros(1), np.ones(1))
    with pytest.raises(ValueError, match="high > low"):
        ControlSpline(3, 10, np.ones(1), np.zeros(1))
    with pytest.raises(ValueError, match="anchored"):
        ControlSpline(3, 10, np.zeros(1), np.ones(1), anchored=True).controls(np.zeros((1, 3, 1)))
