"""Error-controlled generalised-alpha (``pf.simulate(model, t_end, rtol=...)``) on seed
004's floating-frame scenes past the times where its step control used to collapse: a
rejected step's retry, at a fraction of the last step, re-corrected the constraints'
violation that the last step's Newton tolerance left (violation / (beta h^2) in its
acceleration), and a run through ringing joints grew each step past what the unfiltered
estimate allowed, so that every step was rejected and retried at half the last. Each run
is checked against a fine fixed step of the same scene, within 3 rtol L, and for steps far
above min_step."""
import numpy as np

import pipeflex as pf
from pipeflex.multibody import static_equilibrium as mb_static
from pipeflex.seeds.seed004 import scenes as seed004_scenes
from pipeflex.seeds.seed004 import studies as seed004_studies


def _fixed(model, t_end, step, **run):
    return pf.simulate(model, t_end, integrator="generalized_alpha", step=step, progress=False, **run)


def test_fluttering_cantilever_of_eight_bodies_runs_by_rtol_past_its_collapse():
    """The FFRF cantilever of seed 004's Fig. 4 (8 bodies, 15 m/s from the static
    deflection): at rtol 1e-3 its step was cut down to min_step (at 0.78 s with these
    outputs; Newton failed at 1.15 s with 401); now the run goes on, the tip within 3 rtol L
    of a 0.25 ms step's path."""
    s = seed004_scenes.ffrf_cantilever_pipe(n_bodies=8, elements_per_body=20, internal_modes=0,
                                            tip_force=seed004_studies.CANTILEVER_TIP_FORCE)
    mdot = s.bodies[0].section.fluid_mass * seed004_studies.CANTILEVER_FLOW_SPEED
    run = dict(state=mb_static(s, mass_flow=0.0).state, mass_flow=mdot, n_outputs=25)
    t_end, L, rtol = 1.2, s.length_scale, 1e-3
    ref = _fixed(s, t_end, 2.5e-4, rho_inf=0.8, **run).node_position(*s.info["tip"])
    assert np.abs(ref[:, 2] - ref[0, 2]).max() > 0.1  # it flutters
    res = pf.simulate(s, t_end, rtol=rtol, progress=False, **run)
    assert res.stats["smallest_step"] > 1e-6, res.stats
    err = float(np.abs(res.node_position(*s.info["tip"]) - ref).max())
    assert err <= 3.0 * rtol * L, err


def test_stiff_semicircle_of_bodies_runs_by_rtol_3e_3():
    """Seed 004's semicircular pipe (8 FFRF bodies, E = 95.85 GPa, flow from rest) at rtol
    3e-3, which failed at 1.8 s ("a step below min_step"; 1.94 s with 401 outputs): to 2 s,
    the free end within 3 rtol L of a 0.25 ms step's path."""
    s = seed004_scenes.ffrf_curved_pipe(E=95.85e9, n_bodies=8, elements_per_body=20, internal_modes=0)
    t_end, L, rtol = 2.0, s.length_scale, 3e-3
    ref = _fixed(s, t_end, 2.5e-4, n_outputs=11, rho_inf=0.8)
    assert np.abs(ref.node_angular_velocity(*s.info["base"])[:, 1]).max() > 5.0  # it spun up
    res = pf.simulate(s, t_end, rtol=rtol, n_outputs=11, progress=False)
    assert res.stats["smallest_step"] > 1e-7, res.stats
    err = float(np.abs(res.node_position(*s.info["tip"]) - ref.node_position(*s.info["tip"])).max())
    assert err <= 3.0 * rtol * L, err


def test_bodies_take_the_controlled_rho_inf_unless_given():
    """Bodies by rtol: rho_inf CONTROLLED_RHO_INF unless given, as element models (the
    joints' stiff modes a flow start rings are damped, not followed by the step)."""
    from pipeflex.analysis import transient

    s = seed004_scenes.ffrf_curved_pipe(E=95.85e9, n_bodies=2, elements_per_body=4, internal_modes=0)
    run = lambda **o: pf.simulate(s, 0.05, rtol=1e-2, n_outputs=2, progress=False, **o)
    default, same, other = run(), run(rho_inf=transient.CONTROLLED_RHO_INF), run(rho_inf=0.8)
    tip = lambda r: r.node_position(*s.info["tip"])
    assert np.array_equal(tip(default), tip(same)) and default.stats["steps"] == same.stats["steps"]
    assert not np.array_equal(tip(default), tip(other))


def test_spin_up_at_rtol_1e_8_meets_the_request():
    """Seed 002's spin-up of benchmarks/bench_peer.py (2 ANCF elements, L = 8 m, 4 rad/s in
    15 s; the tip's deflection at 20 s) at rtol 1e-8: its extrapolated mesh reaches the
    asymptotic range only at the third halving, and stopped at four with 5.5e-8 L; now
    within 3 rtol L of fixed steps of 0.5 and 0.25 ms Richardson-extrapolated."""
    from pipeflex.seeds.seed002 import scenes as seed002_scenes
    from pipeflex.seeds.seed002.studies import tip_deflection

    model = seed002_scenes.spin_up_beam(reference="ref21", n_elements=2, omega=4.0)
    t_end, L, rtol = 20.0, model.length_scale, 1e-8
    tip = lambda res: float(tip_deflection(model, res)[-1])
    tight = dict(rho_inf=1.0, newton_tol=1e-13, max_newton=30, n_outputs=2, work=False)
    fixed = [tip(_fixed(model, t_end, h, **tight)) for h in (5e-4, 2.5e-4)]
    ref = fixed[1] + (fixed[1] - fixed[0]) / 3.0
    res = pf.simulate(model, t_end, rtol=rtol, n_outputs=2, progress=False)
    assert res.metadata["extrapolated"]["halvings"] > 4
    assert abs(tip(res) - ref) <= 3.0 * rtol * L, abs(tip(res) - ref) / L
