"""The energy the damping forces dissipate in a transient (TransientResult.dissipated) and
the energy balance E - E0 - W + D of damped models: Kelvin-Voigt and external viscous
damping of the pipe and ANCF elements, the axial and ground spring-dampers (translational
and rotational), under generalised-alpha and IDA."""
import numpy as np
import pytest

import pipeflex as pf

L, N_EL = 1.0, 4  # cantilever length [m], elements
SECTION = dict(EI=10.0, EA=2e3, GJ=8.0, pipe_mass=1.0, fluid_mass=0.0, rotary_inertia=(1e-3, 1e-3, 1e-3))
UNDAMPED = pf.PipeSection(**SECTION)
KV = dict(eta_bending=2e-3, eta_torsion=2e-3, eta_axial=1e-4, c_ext=0.3)


def cantilever(*, section=UNDAMPED, spring=None):
    """A pipe cantilever along x clamped at node 0; ``spring``: "axial" (a spring-damper
    from the tip to a fixed node) or "ground" (translational and rotational dashpots at
    the tip)."""
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(root, (L, 0.0, 0.0), N_EL, section)
    b.clamp(root)
    tip = nodes[-1]
    if spring == "axial":
        anchor = b.add_node((L, 0.5, 0.2))
        b.clamp(anchor)
        b.add_spring(tip, anchor, stiffness=20.0, damping=0.4)
    elif spring == "ground":
        b.add_ground_spring(tip, stiffness=(0.0, 5.0, 0.0), damping=(0.2, 0.3, 0.1),
                            rotational_damping=(0.01, 0.02, 0.03))
    return b.build(), tip


def swinging(model, tip):
    """The cantilever in its reference shape moving in the shape of its first bending mode,
    roughly: v = V (x / L)^2 across (along y, and z for pipe elements) with the matching
    rotation (or slope) rates; V = 1 m/s at the tip. A smooth start: the damping acts on
    the resolved low modes (an impulse would excite modes faster than the step)."""
    s = model.initial_state()
    v = np.array(s.v)
    x = np.array(model.positions)[:, 0]
    free = np.abs(np.array(model.positions)[:, 1]) < 1e-12  # the beam's nodes, not a spring's anchor
    planar = tip in model.ancf_nodes  # the ANCF beam moves in the x-y plane
    for i in np.flatnonzero(free):
        u, du = (x[i] / L) ** 2, 2.0 * x[i] / L ** 2  # shape, slope [1/m]
        v[6 * i + 1] = u
        if planar:
            v[6 * i + 4] = du  # the slope's rate
        else:
            v[6 * i + 2] = 0.5 * u
            v[6 * i + 4], v[6 * i + 5] = -0.5 * du, du  # small rotations about y and z
    s.v = v
    return s


def run(model, tip, *, t_end=0.5, step=1e-3, **options):
    opts = options if options.get("integrator") == "ida" else \
        dict(integrator="generalized_alpha", step=step, rho_inf=1.0) | options
    return pf.simulate(model, t_end, state=swinging(model, tip), n_outputs=51, progress=False, **opts)


def imbalance(r):
    """The largest size of the energy balance relative to the initial energy."""
    return np.abs(r.energy_balance()).max() / r.energy[0]


def damped_model(case):
    """The cantilever with Kelvin-Voigt and viscous damping, or with a spring's dashpots."""
    if case == "kelvin-voigt":
        return cantilever(section=pf.PipeSection(**SECTION, **KV))
    if case == "ancf":
        b = pf.ModelBuilder()
        nodes = b.add_ancf_beam((0.0, 0.0, 0.0), (L, 0.0, 0.0), N_EL,
                                pf.PipeSection(EI=10.0, EA=2e3, pipe_mass=1.0, eta_bending=2e-3, eta_axial=1e-4,
                                               c_ext=0.3))
        b.clamp(nodes[0])
        return b.build(), nodes[-1]
    return cantilever(spring="axial" if case == "axial dashpot" else "ground")


@pytest.mark.parametrize("case", ["kelvin-voigt", "ancf", "axial dashpot", "ground dashpots"])
def test_the_dissipated_energy_closes_the_balance_of_a_damped_swing(case):
    model, tip = damped_model(case)
    r = run(model, tip)
    D = r.dissipated
    assert D[0] == 0.0
    assert np.all(np.diff(D) >= 0.0) and D[-1] > 0.0
    # a sizeable part of the motion's energy is dissipated: without D the balance is off by it
    without = np.abs(r.energy - r.energy[0] - r.fluid_work - r.load_work).max() / r.energy[0]
    assert without > 0.02, without
    # with it, the balance is back at the integrator's accuracy: orders of magnitude smaller
    assert imbalance(r) < 2e-3 * without, (imbalance(r), without)


@pytest.mark.parametrize("case", ["kelvin-voigt", "axial dashpot"])
def test_the_balance_of_a_damped_swing_converges_at_second_order(case):
    model, tip = damped_model(case)
    errors = [np.abs(run(model, tip, step=h).energy_balance()[-1]) for h in (2e-3, 1e-3, 5e-4)]
    rates = [errors[k] / errors[k + 1] for k in range(2)]
    assert all(3.5 < x < 4.5 for x in rates), (errors, rates)


def test_ida_integrates_the_dissipated_energy_too():
    model, tip = damped_model("kelvin-voigt")
    ga = run(model, tip, step=1e-3)
    ida = run(model, tip, integrator="ida", rtol=1e-8, atol=1e-10)
    assert np.all(np.diff(ida.dissipated) >= 0.0)
    np.testing.assert_allclose(ida.dissipated, ga.dissipated, rtol=0.0, atol=5e-4 * ga.dissipated[-1])
    assert imbalance(ida) < 1e-5 * ida.dissipated[-1] / ida.energy[0]


def test_undamped_runs_dissipate_nothing():
    model, tip = cantilever()
    r = run(model, tip)
    assert np.all(r.dissipated == 0.0)
    assert np.all(run(model, tip, integrator="ida", rtol=1e-6).dissipated == 0.0)


def test_without_work_the_dissipated_energy_is_nan_and_xarray_has_it():
    model, tip = damped_model("axial dashpot")
    assert np.all(np.isnan(run(model, tip, work=False).dissipated))
    pytest.importorskip("xarray")
    ds = run(model, tip).to_xarray()
    assert ds.dissipated.attrs["units"] == "J"
