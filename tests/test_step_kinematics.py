"""The nodes' rotation kinematics a generalised-alpha step shares: the work bookkeeping's
node motions taken again by the re-basing, and the convective angular acceleration's
coefficient rates on both sides of their series / closed-form switch."""
import numpy as np

import pipeflex as pf
from pipeflex import _core


def spatial_pipe():
    """A flexible pipe with flow, loaded out of its plane and twisted: every rotation
    component moves, so the re-based frames carry the whole 3D rotation."""
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 5e-4, 5e-4))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 4, sec)
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, 1.5, -1.0), moment=(0.3, 0.0, 0.0))
    b.add_load(nodes[2], force=(0.0, 0.0, 2.0))
    return b.build(mass_flow=20.0)


def test_work_bookkeeping_leaves_the_motion_unchanged():
    """work=True evaluates the nodes' motions for the fluid power and the re-basing after it
    takes them; work=False re-bases from its own. A stale or misplaced reuse turns the frames
    by a different rotation and moves the motion far beyond round-off."""
    model = spatial_pipe()
    runs = {work: pf.simulate(model, 0.3, integrator="generalized_alpha", step=2e-3, n_outputs=7,
                              progress=False, work=work) for work in (True, False)}
    with_work, without = runs[True], runs[False]
    assert np.isfinite(with_work.fluid_work).all() and np.abs(with_work.fluid_work).max() > 1e-3
    assert np.isnan(without.fluid_work).all()
    # the motion is 3D: every rotation component is exercised
    assert np.abs(with_work.omega[-1]).max(axis=0).min() > 1e-2
    for name in ("x", "R", "xd", "omega"):
        a, b = getattr(with_work, name), getattr(without, name)
        ulps = 8 * np.finfo(float).eps * max(np.abs(a).max(), 1.0)
        assert np.allclose(a, b, rtol=0, atol=ulps), name


def test_convective_acceleration_is_continuous_at_the_coefficients_switch(rng):
    """Below |phi|^2 = 1e-2 the coefficients' rates come from their series, above from the
    closed forms (s - 2a) / (2 t^2) and (a - 3b) / (2 t^2): both sides agree (to the closed
    forms' cancellation, ~1e-10 there) and match central differences of T(phi) phi_dot."""
    for _ in range(5):
        n = rng.standard_normal(3)
        n /= np.linalg.norm(n)
        phid = rng.standard_normal(3)
        below = _core.convective_angular_acceleration(0.1 * (1 - 1e-12) * n, phid)
        above = _core.convective_angular_acceleration(0.1 * (1 + 1e-12) * n, phid)
        scale = np.abs(below).max()
        assert scale > 0.0
        assert np.allclose(below, above, rtol=0, atol=1e-9 * scale)
        phi = 0.1 * n
        h = 1e-5
        dT = (_core.rotation_jacobian(phi + h * phid) - _core.rotation_jacobian(phi - h * phid)) / (2 * h)
        assert np.allclose(above, dT @ phid, rtol=0, atol=1e-8 * max(1.0, scale))
