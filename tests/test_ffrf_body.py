"""Floating-frame bodies (seed 004): kernels against finite differences and physics checks."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import scenes
from pipeflex.multibody import MultibodyBuilder, flexible_body, linearize, static_equilibrium
from pipeflex.rotation import rotation_exp


def _section(**kw):
    base = dict(EI=7.0, EIz=11.0, EA=3e3, GJ=5.0, pipe_mass=1.3, fluid_mass=0.7, rotary_inertia=(0.01, 0, 0))
    base.update(kw)
    return pf.PipeSection(**base)


def _perturbed(system, rng, scale=0.05):
    st = system.initial_state()
    system.increment(st, scale * rng.standard_normal(system.n_coordinates))
    st.v[:] = rng.standard_normal(system.n_coordinates)
    st.a[:] = rng.standard_normal(system.n_coordinates)
    return st


def _two_bodies(curvature=0.0, internal_modes=2):
    body = flexible_body(length=0.6, n_elements=6, section=_section(), internal_modes=internal_modes,
                         curvature=curvature)
    b = MultibodyBuilder()
    j0 = b.add_body(body, position=(0.3, 0.0, 0.0))
    # place body 1 so that its start node meets body 0's end node in position and orientation
    sys0 = MultibodyBuilder()
    sys0.add_body(body, position=(0.3, 0.0, 0.0))
    sys0.fix(0, "start")
    s0 = sys0.build()
    p, A, _, _ = s0.node_kinematics(s0.initial_state(), 0, body.n_elements)
    _, A1, _, _ = s0.node_kinematics(s0.initial_state(), 0, 0)  # start-node orientation relative to frame
    R1 = A @ A1.T
    x0 = body.node_rows(0)[2] + body.node_rows(0)[0] @ body.eta0
    j1 = b.add_body(body, position=p - R1 @ x0, rotation=R1)
    b.fix(j0, "start")
    b.rigid(j0, "end", j1, "start")
    b.add_load(j1, "end", force=(0.3, -0.2, 0.5), moment=(0.1, 0.05, -0.02))
    b.set_gravity((0.0, -9.81, -3.0))
    return b.build(mass_flow=0.9)


@pytest.mark.parametrize("curvature", [0.0, 1.5])
def test_body_tangent_matches_finite_differences(rng, curvature):
    """wK dF/dq, wC dF/dv, wM dF/da of the C++ kernels (bodies, loads, joint reactions;
    rotation increments on the Lie group) against central differences, with flow, its
    rate, gravity, rotation and multipliers."""
    s = _two_bodies(curvature)
    st = _perturbed(s, rng)
    st.lam[:] = rng.standard_normal(s.n_constraints)
    kw = dict(mass_flow=0.9, mass_flow_rate=0.4)
    h = 1e-6
    N = s.n_coordinates
    for weights, perturb in (((1, 0, 0), "q"), ((0, 1, 0), "v"), ((0, 0, 1), "a")):
        T = s.evaluate(st, wK=weights[0], wC=weights[1], wM=weights[2], **kw)[3]
        fd = np.zeros((N, N))
        for i in range(N):
            sp, sm = st.copy(), st.copy()
            if perturb == "q":
                d = np.zeros(N)
                d[i] = h
                s.increment(sp, d)
                s.increment(sm, -d)
            else:
                getattr(sp, perturb)[i] += h
                getattr(sm, perturb)[i] -= h
            fd[:, i] = (s.evaluate(sp, tangent=False, **kw)[0] - s.evaluate(sm, tangent=False, **kw)[0]) / (2 * h)
        assert np.abs(T - fd).max() <= 1e-6 * np.abs(fd).max(), perturb


def test_constraint_jacobian_matches_finite_differences(rng):
    s = _two_bodies(1.5)
    st = _perturbed(s, rng)
    _, J = s.constraints(st)
    h = 1e-6
    fd = np.zeros_like(J)
    for i in range(s.n_coordinates):
        d = np.zeros(s.n_coordinates)
        d[i] = h
        sp, sm = st.copy(), st.copy()
        s.increment(sp, d)
        s.increment(sm, -d)
        fd[:, i] = (s.constraints(sp)[0] - s.constraints(sm)[0]) / (2 * h)
    assert np.abs(J - fd).max() <= 1e-7


def test_mass_matrix_sums_to_the_total_mass():
    body = flexible_body(length=0.8, n_elements=8, section=_section(), internal_modes=3)
    M = np.asarray(body.data.M)
    assert np.allclose(M[:3, :3], body.mass * np.eye(3), rtol=1e-13)
    # rotary inertia about the body axis of a straight body: only the section's polar inertia
    assert M[3, 3] == pytest.approx(0.01 * 0.8, rel=1e-12)
    # about a transverse axis through the centre: m L^2 / 12
    assert M[4, 4] == pytest.approx(body.mass * 0.8**2 / 12, rel=1e-12)


@pytest.mark.parametrize("curvature", [0.0, 2.0])
def test_no_elastic_force_under_rigid_motion(rng, curvature):
    """A body moved rigidly (any position and rotation) with eta = eta0, at rest, has no
    force: the preimposed curvature is stress-free."""
    s = _two_bodies(curvature)
    st = s.initial_state()
    for j in range(2):
        st.r[j] = rng.standard_normal(3)
        st.R[j] = rotation_exp(rng.standard_normal(3))
    F = s.evaluate(st, mass_flow=0.0, gravity_factor=0.0, load_factor=0.0, tangent=False)[0]
    assert np.abs(F).max() < 1e-12


def test_one_body_is_two_hermite_elements():
    """With the centre node fixed, a body with boundary modes only is exactly two beam
    elements of half its length: the natural frequencies of n bodies equal those of
    seed 000's element with 2n elements (bending; the FFRF pipe also has torsion and
    axial modes, which seed 000's Table 2 model makes rigid)."""
    lin = linearize(scenes.ffrf_cantilever_pipe(n_bodies=2), mass_flow=0.0)
    w = np.abs(pf.eigenvalues(lin).values.imag)
    ref = np.abs(pf.eigenvalues(pf.linearize(scenes.cantilever_pipe(n_elements=4))).values.imag)
    ref = np.sort(ref[ref < 1e4])
    assert len(ref) == 32  # 4 elements x 2 planes x 2 nodes x 2 (+- i omega)
    nearest = np.array([w[np.argmin(np.abs(w - x))] for x in ref])
    assert nearest == pytest.approx(ref, rel=1e-9)


def test_full_body_equals_all_internal_modes():
    """Craig-Bampton with every internal mode spans the full (unreduced) body."""
    f = scenes.ffrf_cantilever_pipe(n_bodies=1, elements_per_body=6, reduction="full")
    c = scenes.ffrf_cantilever_pipe(n_bodies=1, elements_per_body=6, internal_modes=6 * 7 - 18)
    wf = np.sort(np.abs(pf.eigenvalues(linearize(f, mass_flow=10.0)).values))
    wc = np.sort(np.abs(pf.eigenvalues(linearize(c, mass_flow=10.0)).values))
    assert wf == pytest.approx(wc, rel=1e-8)


def test_static_tip_deflection():
    """F = 1.5 N at the tip of the cantilever of seed 004, sec. 8.1: F L^3 / 3 EI = 0.05 m
    (minus the second-order shortening of the large deflection)."""
    s = scenes.ffrf_cantilever_pipe(n_bodies=2, tip_force=1.5)
    st = static_equilibrium(s, mass_flow=0.0)
    tip = s.node_position(st.state, *s.info["tip"])
    assert tip[2] == pytest.approx(0.05, rel=5e-3)
    assert st.residual < 1e-9


def test_bad_input():
    sec = _section()
    with pytest.raises(ValueError, match="n_elements must be even"):
        flexible_body(length=1.0, n_elements=5, section=sec)
    with pytest.raises(ValueError, match="length must be > 0"):
        flexible_body(length=0.0, n_elements=4, section=sec)
    # a basis of free-free modes contains the rigid motion
    n = 6 * 5
    with pytest.raises(ValueError, match="rigid-body motion"):
        flexible_body(length=1.0, n_elements=4, section=sec, basis=np.eye(n))
    body = flexible_body(length=1.0, n_elements=4, section=sec)
    b = MultibodyBuilder()
    j0 = b.add_body(body, position=(0.5, 0, 0))
    with pytest.raises(ValueError, match="body 3"):
        b.rigid(j0, "end", 3, "start")
    with pytest.raises(ValueError, match="node must be"):
        b.fix(j0, "middle")
    j1 = b.add_body(body, position=(1.6, 0, 0))
    b.fix(j0, "start")
    b.rigid(j0, "end", j1, "start")
    with pytest.raises(ValueError, match="do not coincide"):
        b.build()
    b = MultibodyBuilder()
    j0 = b.add_body(body, position=(0.5, 0, 0))
    b.fix(j0, "start")
    b.hinge(j0, "start", (0, 0, 1))
    with pytest.raises(ValueError, match="redundant"):
        b.build()
    b = MultibodyBuilder()
    b.add_body(body, position=(0.5, 0, 0))
    with pytest.raises(ValueError, match="no joints"):
        b.build()


def test_clear_errors_for_misuse():
    s = scenes.ffrf_cantilever_pipe(n_bodies=1)
    with pytest.raises(ValueError, match=r"rho_inf must be in \[0, 1\) \(index-3 constraints"):
        pf.simulate(s, 0.01, step=1e-3, rho_inf=1.0)  # joints' multipliers need numerical damping
    late = pf.simulate(s, 0.52, t_start=0.5, step=5e-3, n_outputs=3)  # the same driver: any start time
    assert late.t[0] == 0.5 and late.t[-1] == pytest.approx(0.52) and late.final_state.t == pytest.approx(0.52)
    with pytest.raises(ValueError, match="flow_factor"):
        b = MultibodyBuilder()
        j = b.add_body(flexible_body(length=1.0, n_elements=2, section=pf.PipeSection(EI=1.0, pipe_mass=1.0)),
                       position=(0.5, 0, 0))
        b.fix(j)
        b.build(mass_flow=1.0)
    from pipeflex.multibody import simulate
    with pytest.raises(ValueError, match="rho_inf"):
        simulate(s, 1.0, step=1e-3, rho_inf=2.0)
    with pytest.raises(ValueError, match="step"):
        simulate(s, 1.0, step=0.0)


def test_kink_force_of_the_flow():
    """Two straight pipe bodies at a right angle, clamped at the inlet, steady flow at
    rest. Momentum balance of the fluid: the clamp carries P (e_in - t_out), P = mu_f
    sdot^2, e_in the inlet direction and t_out the deformed outlet tangent: the kink force
    P (e1 - e2) plus the bodies' own terms in their bent shape. Without junction forces
    (seed 004 as printed) only the bending terms remain."""
    sec = pf.PipeSection(EI=50.0, EA=1e5, GJ=40.0, pipe_mass=1.0, fluid_mass=2.0, rotary_inertia=(1e-3, 0, 0))
    body = flexible_body(length=0.4, n_elements=4, section=sec)
    b = MultibodyBuilder()
    j0 = b.add_body(body, position=(0.2, 0.0, 0.0))
    j1 = b.add_body(body, position=(0.4, 0.2, 0.0), rotation=rotation_exp([0.0, 0.0, np.pi / 2]))
    b.fix(j0, "start")
    b.rigid(j0, "end", j1, "start")
    mdot = 6.0
    P = mdot**2 / sec.fluid_mass
    s = b.build(mass_flow=mdot)
    st = static_equilibrium(s).state
    t_out = s.node_kinematics(st, j1, body.n_elements)[1][:, 0]
    # to the order of the FFRF's small-deformation terms (rotations here ~0.05 rad)
    assert np.linalg.norm(st.lam[0:3]) == pytest.approx(P * np.linalg.norm(np.array([1.0, 0, 0]) - t_out), rel=5e-4)
    assert np.linalg.norm(st.lam[0:3]) > 0.9 * np.sqrt(2) * P
    s0 = b.build(mass_flow=mdot, junction_forces=False)
    assert np.linalg.norm(static_equilibrium(s0).state.lam[0:3]) < 1e-3 * P


def test_accelerating_flow_pushes_the_pipe_along_its_axis():
    """Fluid accelerating at sddot relative to a pipe at rest needs the force mu_f L sddot
    along the flow (eq. 70's sddot C r term), carried by the bodies' frame rows."""
    s = scenes.ffrf_cantilever_pipe(n_bodies=2)
    st = s.initial_state()
    mu = s.bodies[0].section.fluid_mass
    rate = 3.0  # d(mdot)/dt [kg/s^2]: sddot = rate / mu_f
    F = s.evaluate(st, mass_flow=0.0, mass_flow_rate=rate, tangent=False)[0]
    total = sum(F[s.body_slice(j)][:3] for j in range(2))
    L, sddot = 1.0, rate / mu
    assert total == pytest.approx([mu * L * sddot, 0.0, 0.0], abs=1e-12)
