"""Helpers for the tests: build an element and evaluate it, small models, and an
ulp-scaled comparison of two code paths."""
import numpy as np

import pipeflex as pf
from pipeflex import _core


def element(kind="straight", *, shear=False, rotary=False, fluid_end_terms=True):
    """Element data of a straight or curved (quarter arc) pipe element, stress-free as built."""
    sec = pf.PipeSection(EI=7.0, EIz=11.0, EA=3e3, GJ=5.0, GAy=900.0 if shear else None,
                         GAz=700.0 if shear else None, pipe_mass=1.3, fluid_mass=0.7, kv=1.1,
                         rotary_inertia=(0.02, 0.01, 0.015) if rotary else (0, 0, 0))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.1, -0.2, 0.3))
    if kind == "straight":
        b.add_line(n0, (1.1, 0.3, 0.5), 1, sec, fluid_end_terms=fluid_end_terms)
    else:
        b.add_arc(n0, center=(0.1, 0.8, 0.3), angle=np.pi / 2, normal=(0, 0, 1), n_elements=1, section=sec,
                  fluid_end_terms=fluid_end_terms)
    b.clamp(n0)
    model = b.build()
    x = model.positions
    q = np.concatenate([x[0], np.zeros(3), x[1], np.zeros(3)])
    return model.core.pipe(0), q


def assert_close_ulps(a, b, *, ulps=4, scale=0.0, what=""):
    """Assert |a - b| <= ulps * eps * max(|a|, |b|, scale) entry by entry (eps = 2.2e-16,
    float64), with the same shape and NaNs at the same places.

    For two code paths that compute the same numbers but may round differently: numpy's
    vectorised and scalar transcendental functions (SVML on AVX-512 CPUs, libm elsewhere),
    another BLAS thread count or kernel, another process (array alignment), C against
    Python (FMA contraction). ``scale`` [unit of a, b] is the magnitude below which the
    tolerance stops shrinking: an entry that cancelled to ~0 inherits the round-off of
    the larger terms it came from (e.g. the largest entry of the array, or 1 for unit
    vectors). ``what`` names the compared quantity in the message."""
    a = np.asarray(a, dtype=complex if np.iscomplexobj(a) or np.iscomplexobj(b) else float)
    b = np.asarray(b, dtype=a.dtype)
    assert a.shape == b.shape, f"{what}: shapes {a.shape} != {b.shape}"
    nan_a, nan_b = np.isnan(a), np.isnan(b)
    assert np.array_equal(nan_a, nan_b), f"{what}: NaN at different places"
    a, b = np.where(nan_a, 0.0, a), np.where(nan_b, 0.0, b)
    tol = ulps * np.finfo(float).eps * np.maximum(np.maximum(np.abs(a), np.abs(b)), scale)
    with np.errstate(invalid="ignore"):  # inf - inf: equal infinities pass through a == b
        err = np.where(a == b, 0.0, np.abs(a - b))
    if not np.all(err <= tol):
        k = np.unravel_index(np.argmax(np.where(err <= tol, -np.inf, err)), err.shape)
        raise AssertionError(f"{what}: differ by more than {ulps} ulps: at {k} {a[k]!r} vs {b[k]!r} "
                             f"(|difference| {err[k]:.3g}, allowed {tol[k]:.3g})")


def load(mass_flow=0.0, mass_flow_rate=0.0, gravity=(0.0, 0.0, 0.0)):
    ls = _core.LoadState()
    ls.mass_flow, ls.mass_flow_rate, ls.gravity = mass_flow, mass_flow_rate, list(gravity)
    return ls


def residual(data, q, v, a, ld, frames=(np.eye(3), np.eye(3))):
    r, _ = _core.pipe_tangent(data, frames[0], frames[1], ld, q, v, a, 0.0, 0.0, 0.0)
    return r


def tangent(data, q, v, a, ld, wK, wC, wM, frames=(np.eye(3), np.eye(3))):
    _, J = _core.pipe_tangent(data, frames[0], frames[1], ld, q, v, a, wK, wC, wM)
    return J


def residual_columns(model, state, load, which, h):
    """Central differences of an element model's assembled residual (load factor 1) in its
    reduced coordinates: ``which`` "q" (positions: the tangent's K) or "v" (rates: C), step
    h, one column per coordinate."""
    n = model.n_dofs
    D = np.zeros((n, n))
    for col in range(n):
        dz = np.zeros(n)
        dz[col] = h
        sp, sm = state.copy(), state.copy()
        _core.add_increment(model.core, sp, dz, which)
        _core.add_increment(model.core, sm, -dz, which)
        rp, _ = _core.assemble(model.core, sp, load, 1.0, 0.0, 0.0, 0.0, False)
        rm, _ = _core.assemble(model.core, sm, load, 1.0, 0.0, 0.0, 0.0, False)
        D[:, col] = (rp - rm) / (2 * h)
    return D


def fluttering_cantilever():
    """Two elements beyond the flutter flow (40 kg/s), with a small initial tip velocity."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    b.add_line(n0, (1, 0, 0), 2, pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e6, GJ=8.0,
                                                rotary_inertia=(1e-2, 1e-3, 1e-3)))
    b.clamp(n0)
    m = b.build(mass_flow=40.0)
    st = m.initial_state()
    st.v[6 * 2 + 1] = 1e-3
    return m, st


def u_tube():
    """The user guide's example (docs/user_guide.md, "A model")."""
    sec = pf.PipeSection.tube(outer_diameter=0.0508, inner_diameter=0.0472, E=208e9, G=80e9,
                              density=8027.0, fluid_density=1000.0)
    b = pf.ModelBuilder()
    inlet = b.add_node((0.0, 0.0, 0.0))
    leg = b.add_line(inlet, (0.0, 0.45, 0.0), 2, sec)
    arc = b.add_arc(leg[-1], center=(0.15, 0.45, 0.0), angle=-np.pi, normal=(0, 0, 1), n_elements=12, section=sec)
    b.clamp(inlet)
    b.add_load(arc[6], force=(0.0, 0.0, 10.0))
    return b.build(mass_flow=1.5)


def on_clamped_hub(arm, root, *, stiffness_ratio, rotary_inertia=(1.0, 0.0, 0.0)):
    """The floating element model `arm` clamped (rigid joint) at node `root` to the end of a
    short hub body (0.2 m, 2 elements, EI = stiffness_ratio * 3 EI_arm / (0.2 m)^3 per
    unit mass, EI_arm = 10 N m^2) whose start is clamped to the ground."""
    from pipeflex.multibody import MultibodyBuilder, flexible_body
    mb = MultibodyBuilder()
    mu = 3 * 10.0 / 0.2**3
    hub = mb.add_body(flexible_body(length=0.2, n_elements=2,
                                    section=pf.PipeSection(EI=stiffness_ratio * mu, pipe_mass=mu,
                                                           rotary_inertia=rotary_inertia)),
                      position=(-0.1, 0.0, 0.0))
    mb.fix(hub, "start")
    system = pf.CoupledSystem(arm, mb.build())
    system.rigid(root, hub, "end")
    return system


def imported_module(package: str, node) -> str:
    """The absolute module an ``ast.ImportFrom`` in ``package`` names (its relative
    levels resolved)."""
    if not node.level:
        return node.module
    base = package.split(".")
    base = ".".join(base[:len(base) - node.level + 1])
    return f"{base}.{node.module}" if node.module else base


def l_sprinkler(EI, mass_flow=2.0):
    """Two straight bodies, (0, 0, 0)-(0.5, 0, 0) and on to (0.5, 0.3, 0), rigidly joined,
    hinged to the ground about z at the inlet; fluid 1 kg/m."""
    from pipeflex.multibody import MultibodyBuilder, flexible_body
    sec = pf.PipeSection(EI=EI, EA=1e3 * EI, GJ=EI / 1.3, pipe_mass=0.5, fluid_mass=1.0,
                         rotary_inertia=(1e-4, 0.0, 0.0))
    b = MultibodyBuilder()
    j0 = b.add_body_between(flexible_body(length=0.5, n_elements=4, section=sec), (0, 0, 0), (0.5, 0, 0))
    j1 = b.add_body_between(flexible_body(length=0.3, n_elements=4, section=sec), (0.5, 0, 0), (0.5, 0.3, 0))
    b.rigid(j0, "end", j1, "start")
    b.hinge(j0, "start", (0, 0, 1))
    return b.build(mass_flow=mass_flow)


def assembled_matrix(model, s, wK, wC, wM=0.0):
    """The element assembler's weighted tangent wK K + wC C + wM M (dense) at core state s."""
    n = model.n_dofs
    _, (i, j, v) = _core.assemble(model.core, s, model.load_state(), 1.0, wK, wC, wM)
    X = np.zeros((n, n))
    np.add.at(X, (i, j), v)
    return X


def assembled_residual(model, s):
    """The element assembler's reduced residual at core state s."""
    return _core.assemble(model.core, s, model.load_state(), 1.0, 0.0, 0.0, 0.0, False)[0]


def moving_state(model, seed=1):
    """A deformed, moving and accelerating core state (rotations of order 0.3 rad)."""
    rng = np.random.default_rng(seed)
    s = model.initial_state()
    _core.add_increment(model.core, s, 0.1 * rng.standard_normal(model.n_dofs), "q")
    _core.add_increment(model.core, s, 0.7 * rng.standard_normal(model.n_dofs), "v")
    _core.add_increment(model.core, s, rng.standard_normal(model.n_dofs), "a")
    return s


def moving_body_state(system, seed=3):
    """A turned, deformed, moving state of a system of floating-frame bodies (frames moved
    and turned, modal coordinates and velocities random)."""
    from pipeflex.rotation import rotation_exp

    rng = np.random.default_rng(seed)
    st = system.initial_state()
    for j in range(len(system.bodies)):
        st.r[j] += 0.05 * rng.standard_normal(3)
        st.R[j] = rotation_exp(0.3 * rng.standard_normal(3)) @ st.R[j]
        e = system.eta(st, j)
        e += 1e-3 * rng.standard_normal(e.size)
    st.v[:] = rng.standard_normal(st.v.size)
    return st


def part_of(with_part, without, state, **kw):
    """A part's share of a system of bodies' residual and tangent: the difference of the
    systems with and without it (the bodies' and joints' terms cancel)."""
    F1, _, _, S1 = with_part.evaluate(state, mass_flow=0.0, **kw)
    F0, _, _, S0 = without.evaluate(state, mass_flow=0.0, **kw)
    return F1 - F0, (None if S1 is None else S1 - S0)
