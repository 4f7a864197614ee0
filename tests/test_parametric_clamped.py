"""The pulsating-flow tongues of the pipe clamped at both ends (Paidoussis & Issid's second
support case) against the independent Galerkin-Floquet solver (tests/galerkin_floquet.py,
the clamped-clamped beam's eigenfunctions, no pipeflex code), for both axial conditions of
the outlet: held (the fluid's acceleration loads the pipe with N = mdot' (x - L / 2)) and
free to slide (N = -mdot' (L - x), as a free outlet)."""
import numpy as np
import pytest

import pipeflex as pf
from galerkin_floquet import Pipe
from test_parametric import tongue_edges

#: L = 1 m, EI = 1 N m^2, m = 0.75, M = 0.25 kg/m (the simply supported scene's section);
#: buckling at u = mdot L / sqrt(M EI) = 2 pi, so mdot = pi / 2 is half of it
CC_FLOW = np.pi / 4


def clamped_pipe(*, outlet_slides: bool, n_elements: int = 16):
    section = pf.PipeSection(EI=1.0, EA=1e10, pipe_mass=0.75, fluid_mass=0.25)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), n_elements, section)
    b.clamp(n0)
    if outlet_slides:
        b.fix(nodes[-1], ("uy", "uz", "rx", "ry", "rz"))
    else:
        b.clamp(nodes[-1])
    return b.build()


def stability(model, mu, Omega, *, modes=8, **options):
    return pf.parametric_stability(model, mean_flow=CC_FLOW, amplitude=mu, frequency=Omega, modes=modes, **options)


@pytest.mark.parametrize("outlet_slides", [False, True])
def test_principal_tongue_of_the_clamped_pipe_matches_the_galerkin_solver(outlet_slides):
    model = clamped_pipe(outlet_slides=outlet_slides)
    # the sliding outlet's N = -mdot' (L - x) couples the symmetric and antisymmetric modes:
    # 8 modes leave its lower edge 3e-3 low, 14 modes 2e-4
    modes = 14 if outlet_slides else 8
    oracle = Pipe("clamped", n_modes=6, c=1.0 if outlet_slides else 0.5)
    w1 = oracle.frequencies(CC_FLOW)[0]
    r = stability(model, 0.0, 2 * w1)
    assert r.natural_frequencies[0] == pytest.approx(w1, rel=1e-3)  # the apex 2 omega_1(mdot0)
    assert w1 < 4.73004074 ** 2  # the flow lowers it (gyroscopic, below buckling)
    # no dissipation: the tongue opens from mu = 0
    assert not stability(model, 0.005, 2 * r.natural_frequencies[0]).stable
    for side in (0.99, 1.01):
        assert stability(model, 0.005, side * 2 * w1).stable
    mu = 0.3
    ours = tongue_edges(lambda W: stability(model, mu, W, modes=modes, check_modes=False).largest, 2 * w1)
    theirs = tongue_edges(lambda W: oracle.largest(CC_FLOW, mu, W), 2 * w1)
    np.testing.assert_allclose(ours, theirs, rtol=1e-3)
    assert theirs[1] - theirs[0] > 0.005 * w1 * mu  # of finite width


def test_the_axial_condition_of_the_outlet_moves_the_tongue():
    """The fluid acceleration's axial force differs with the outlet's axial support, and so
    does the tongue: at mu = 0.3 and 0.95 of the apex frequency the pipe with a sliding
    outlet is inside its tongue (largest multiplier 1.0129), the held one outside (1 to
    round-off), in both solvers."""
    mu = 0.3
    for slides, c in ((False, 0.5), (True, 1.0)):
        oracle = Pipe("clamped", n_modes=6, c=c)
        Omega = 0.95 * 2 * oracle.frequencies(CC_FLOW)[0]
        theirs = oracle.largest(CC_FLOW, mu, Omega)
        ours = stability(clamped_pipe(outlet_slides=slides), mu, Omega, modes=14, check_modes=False).largest
        if slides:
            assert theirs > 1.01
            assert ours == pytest.approx(theirs, rel=1e-4)
        else:
            assert theirs == pytest.approx(1.0, abs=1e-12)
            assert ours == pytest.approx(1.0, abs=1e-9)
