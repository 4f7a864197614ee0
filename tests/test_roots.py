"""pipeflex's Brent root bracketing (analysis/_roots.py) against scipy.optimize.brentq,
whose steps it takes: the same points tried and the same root, to the bit; and the
errors. (It replaces scipy's so that a critical flow need not import scipy.optimize.)"""
import math

import numpy as np
import pytest
from scipy.optimize import brentq as scipy_brentq

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
            assert _tried(brentq, f, a, b, **options) == _tried(scipy_brentq, f, a, b, **options)
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
