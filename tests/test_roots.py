"""pipeflex's Brent root bracketing (analysis/_roots.py) against scipy.optimize.brentq,
whose steps it takes: the same number of points tried, each and the root equal to a few
ulps; and the errors. (It replaces scipy's so that a critical flow need not import
scipy.optimize.)"""
import math

import numpy as np
import pytest
from scipy.optimize import brentq as scipy_brentq

from helpers import assert_close_ulps
from pipeflex.analysis._roots import brentq

FUNCTIONS = [
    lambda x: x**3 - 2 * x - 5,
    lambda x: math.cos(x) - x,
    lambda x: math.exp(x) - 10,
    lambda x: (x - 0.3) ** 5,  # flat root: many bisections
    lambda x: 1e-8 * math.atan(x - 1.2345),  # tiny values
    lambda x: math.sin(20 * x) + 0.1,  # several roots in the bracket
    lambda x: 1.0 if x > 0.7 else -1.0,  # a jump: bisection only
]


def _tried(solver, f, a, b, **options):
    points = []
    try:
        root = solver(lambda x: (points.append(x), f(x))[1], a, b, **options)
    except RuntimeError:
        root = "no convergence"
    return root, points


@pytest.mark.parametrize("options", [{}, dict(xtol=1e-6, rtol=1e-9), dict(xtol=1e-14)])
def test_the_same_steps_as_scipy(options):
    rng = np.random.default_rng(1)
    cases = 0
    for f in FUNCTIONS:
        for _ in range(60):
            a, b = sorted(rng.uniform(-3.0, 4.0, 2))
            if f(a) * f(b) >= 0.0:
                continue
            cases += 1
            (root, points), (ref_root, ref_points) = (_tried(g, f, a, b, **options) for g in (brentq, scipy_brentq))
            # Python's arithmetic against scipy's C, which a compiler may contract into FMAs
            # (aarch64): the same steps, each point and the root to a few ulps of the bracket
            assert len(points) == len(ref_points) and (root == "no convergence") == (ref_root == "no convergence")
            bracket = max(abs(a), abs(b))
            assert_close_ulps(points, ref_points, scale=bracket, what=f"points tried in [{a!r}, {b!r}]")
            if root != "no convergence":
                assert_close_ulps(root, ref_root, scale=bracket, what=f"root in [{a!r}, {b!r}]")
    assert cases > 150


def test_a_bracket_end_that_is_a_root_is_returned():
    assert brentq(lambda x: x - 1.0, 1.0, 3.0) == 1.0
    assert brentq(lambda x: x - 3.0, 1.0, 3.0) == 3.0


def test_errors_name_the_rule():
    with pytest.raises(ValueError, match="different signs"):
        brentq(lambda x: x * x + 1.0, -1.0, 1.0)
    with pytest.raises(ValueError, match="xtol must be > 0"):
        brentq(lambda x: x, -1.0, 1.0, xtol=0.0)
    with pytest.raises(ValueError, match="rtol must be >= 4 eps"):
        brentq(lambda x: x, -1.0, 1.0, rtol=1e-17)
    with pytest.raises(ValueError, match=r"f\(.*\) = nan is not finite"):
        brentq(lambda x: math.nan if x > 0.5 else x, -1.0, 1.0)
    with pytest.raises(RuntimeError, match="no convergence in 3 iterations"):
        brentq(lambda x: (x - 0.123456) ** 5, -1.0, 1.0, max_iterations=3)
