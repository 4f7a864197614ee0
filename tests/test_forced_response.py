"""Nonlinear frequency response by shooting: the linear limit against pf.linearize's
M, C, K, the Duffing-like folds of a clamped-clamped beam (hardening by stretching),
the transient sweep's jump, the orbit against a long transient, the backbone, bad input."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.analysis.forced import _with_load

#: the beam's midspan force [N] of the nonlinear tests: a fold pair near 23.7 and 25.3 rad/s
FORCE = 0.15


def beam(n_elements=4, eta=1e-3):
    """Planar clamped-clamped beam (L = 1 m, EI = 1 N m^2, 1 kg/m, EA = 1e4 N: radius of
    gyration 1 cm, so stretching hardens it at cm amplitudes; Kelvin-Voigt eta [s]: first
    mode 22.4 rad/s with the damping ratio eta omega / 2 = 1.1 %); returns it and its
    midspan node."""
    sec = pf.PipeSection(EI=1.0, pipe_mass=1.0, EA=1e4, eta_bending=eta, eta_axial=eta, eta_torsion=eta,
                         rotary_inertia=(1e-3, 1e-4, 1e-4))
    b = pf.ModelBuilder()
    nodes = b.add_line(b.add_node((0.0, 0.0, 0.0)), (1.0, 0.0, 0.0), n_elements, sec)
    b.clamp(nodes[0])
    b.clamp(nodes[-1])
    for k in nodes[1:-1]:
        b.fix(k, ("uz", "rx", "ry"))
    return b.build(), nodes[n_elements // 2]


@pytest.fixture(scope="module")
def model():
    return beam()


@pytest.fixture(scope="module")
def curve(model):
    m, mid = model
    return pf.forced_response(m, load=(mid, (0.0, FORCE, 0.0)), frequencies=(15.0, 40.0), backbone=True)


def test_small_amplitude_is_the_linear_frf():
    """At a tiny force the amplitude is abs(H) F with H from linearize's M, C, K at the
    generalised-alpha (rho_inf = 1, the trapezoidal rule) frequency 2/h tan(Omega h / 2):
    the discrete map's own frequency response, to the shooting's tolerance; the plain
    Omega differs by O((Omega h)^2) (about 3e-3 at 128 steps a period near resonance)."""
    m, mid = beam(eta=5e-3)  # 5.6 % damping: a broad peak, few points
    F, N = 4e-5, 128
    r = pf.forced_response(m, load=(mid, (0.0, F, 0.0)), frequencies=(18.0, 28.0), max_points=60, steps=N,
                           tol=1e-14, newton_tol=1e-14, rho_inf=1.0)
    assert r.frequency.max() >= 28.0 and r.stable.all() and len(r.folds) == 0
    forced, _, _ = _with_load(m, (mid, (0.0, F, 0.0)))
    lin = pf.linearize(forced)
    M, C, K = (a.toarray() for a in (lin.M, lin.C, lin.K))
    k = forced.dof_index(mid, "uy")
    f = np.zeros(len(M))
    f[k] = F

    def frf(w):
        return np.array([abs(np.linalg.solve(-x ** 2 * M + 1j * x * C + K, f)[k]) for x in w])

    h = 2 * np.pi / r.frequency / N
    warped = 2 / h * np.tan(r.frequency * h / 2)
    assert np.abs(r.amplitude / frf(warped) - 1).max() < 1e-5
    plain = np.abs(r.amplitude / frf(r.frequency) - 1).max()
    assert 1e-4 < plain < 1e-2


def test_duffing_folds_bracket_two_stable_and_one_unstable_orbit(curve):
    r = curve
    assert len(r.folds) == 2
    upper, lower = r.folds
    assert 23.0 < lower < upper < 26.0 and upper - lower > 1.0
    # the curve turns back between the folds: the middle branch is unstable with a real
    # multiplier above 1 (a saddle), the outer ones are stable
    bad = ~r.stable
    assert bad.any() and r.max_multiplier[bad].min() > 1.0
    assert np.all((r.frequency[bad] > lower - 0.1) & (r.frequency[bad] < upper + 0.1))
    mu = r.multipliers[np.flatnonzero(bad)[len(np.flatnonzero(bad)) // 2]]
    lead = mu[np.argmax(np.abs(mu))]
    assert abs(lead.imag) < 1e-9 and lead.real > 1.0
    # at Omega between the folds the curve passes three times: stable, unstable, stable
    w_mid = 0.5 * (lower + upper)
    crossings = np.flatnonzero(np.diff(np.sign(r.frequency - w_mid)) != 0)
    assert len(crossings) == 3
    stability = [bool(r.stable[i] and r.stable[i + 1]) for i in crossings]
    assert stability == [True, False, True]
    w, a = r.frequency, r.amplitude
    amps = [a[i] + (w_mid - w[i]) / (w[i + 1] - w[i]) * (a[i + 1] - a[i]) for i in crossings]
    assert amps[0] > amps[1] > amps[2] > 0.0  # upper branch, saddle, lower branch
    assert r.residual.max() <= 1e-9


def test_backbone_bends_with_the_curve(curve, model):
    """The undamped free oscillation's frequency starts at the linear first mode and
    rises with the amplitude (hardening); the upper fold lies near it."""
    m, mid = model
    b = curve.backbone
    lin = pf.eigenvalues(pf.linearize(m))
    w1 = float(np.min(np.abs(lin.values.imag[lin.values.imag > 0])))
    assert b.frequency[0] == pytest.approx(w1, rel=2e-3)
    # hardening: it rises steadily, by 12 % at the curve's largest amplitude
    assert np.all(np.diff(b.frequency) > 0.0) and b.frequency[-1] > 1.1 * w1
    at_fold = np.interp(curve.fold_amplitudes[0], b.amplitude, b.frequency)
    assert at_fold == pytest.approx(curve.folds[0], rel=0.02)


def test_sweep_up_jumps_at_the_upper_fold(curve, model):
    m, mid = model
    upper = curve.folds[0]
    w = np.arange(23.0, 26.6, 0.1)
    sweep = pf.frequency_sweep(m, load=(mid, (0.0, FORCE, 0.0)), frequencies=w, periods=40)
    at, drop = sweep.jump()
    assert drop > 2.0  # the amplitude falls several-fold
    assert at == pytest.approx(upper, rel=0.02)
    # before the jump the sweep rides the upper branch: the stable orbit's amplitude
    below = (w < upper - 0.3) & (w > 23.8)
    top = np.interp(w[below], curve.frequency[:np.argmax(curve.frequency) + 1],
                    curve.amplitude[:np.argmax(curve.frequency) + 1])
    assert np.allclose(sweep.amplitude[below], top, rtol=0.02)


def test_orbit_is_periodic_and_is_the_transients_steady_state(model):
    """Below the folds (one orbit): a long transient from rest at the same step settles
    on the shooting's orbit, state for state at whole periods."""
    m, mid = model
    r = pf.forced_response(m, load=(mid, (0.0, FORCE, 0.0)), frequencies=(20.0, 20.5), max_points=2)
    w, x0 = r.frequency[0], r.starts[0]
    T, n = 2 * np.pi / w, m.n_dofs
    forced, _, _ = _with_load(m, (mid, (0.0, FORCE, 0.0)))
    # periodic: one more period from the start returns there
    from pipeflex.analysis.forced import _Forced, _options
    from pipeflex.analysis.periodic import _chart

    chart = _chart(forced, None)
    sh = _Forced(forced, chart, r.steps, _options(chart, 1e-12, 0.9), r.forcing, 0.0)
    assert sh.defect(sh.residual(sh.map(x0, w), x0), w) <= 1e-9
    periods = 220  # the transient decays as exp(-zeta omega t), zeta omega = 0.25 1/s: 1e-7 after 220 periods
    run = pf.simulate(forced, periods * T, n_outputs=periods * r.steps + 1, step=T / r.steps,
                      load_factor=pf.Sine(omega=w), integrator="generalized_alpha", rho_inf=0.9, progress=False)
    y = run.x[-r.steps - 1:, mid, 1]
    assert np.abs(y).max() == pytest.approx(r.amplitude[0], rel=1e-5)
    # (simulate's Newton stops at its own tolerance: the states agree to 1e-5 of the amplitude)
    assert y[-1] == pytest.approx(chart.positions(x0[:n])[0, mid, 1], abs=1e-5 * r.amplitude[0])


def test_result_plots_converts_and_saves(curve, tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    ax = curve.plot()
    styles = {line.get_linestyle() for line in ax.get_lines()}
    assert {"-", "--", ":"} <= styles
    xr = pytest.importorskip("xarray")
    ds = curve.to_xarray()
    assert isinstance(ds, xr.Dataset) and ds.frequency.attrs["units"] == "rad/s"
    assert ds.multipliers_real.dims == ("point", "multiplier") and len(ds.folds) == 2
    back = pf.FrequencyResponse.load(curve.save(tmp_path / "curve.npz"))
    assert np.array_equal(back.multipliers, curve.multipliers) and np.array_equal(back.folds, curve.folds)
    assert np.array_equal(back.backbone.frequency, curve.backbone.frequency)


@pytest.mark.parametrize("frequencies", [(0.0, 10.0), (-1.0, 10.0), (10.0, 10.0), (5.0, np.inf), (5.0,)])
def test_bad_frequencies(model, frequencies):
    m, mid = model
    with pytest.raises(ValueError, match="frequencies"):
        pf.forced_response(m, load=(mid, (0.0, 1.0, 0.0)), frequencies=frequencies)


def test_no_forcing(model):
    m, mid = model
    with pytest.raises(ValueError, match="no forcing"):
        pf.forced_response(m, frequencies=(10.0, 20.0), node=mid)
    with pytest.raises(ValueError, match="no forcing: the model has no nodal loads"):
        pf.forced_response(m, load_factor=pf.Sine(omega=1.0), frequencies=(10.0, 20.0), node=mid)
    with pytest.raises(ValueError, match="envelope"):
        pf.forced_response(m, load=(mid, (0.0, 1.0, 0.0)), load_factor=pf.Sine(omega=1.0, envelope=0.0),
                           frequencies=(10.0, 20.0))
    with pytest.raises(ValueError, match="load_factor must be a pipeflex.Sine"):
        pf.forced_response(m, load=(mid, (0.0, 1.0, 0.0)), load_factor=2.0, frequencies=(10.0, 20.0))
    with pytest.raises(ValueError, match="frequencies"):
        pf.frequency_sweep(m, load=(mid, (0.0, 1.0, 0.0)), frequencies=[10.0, 0.0])


def test_load_factor_scales_the_models_own_load(model):
    """load_factor= on a model with the load equals load= on the model without it."""
    m, mid = model
    loaded, _, _ = _with_load(m, (mid, (0.0, FORCE, 0.0)))
    a = pf.forced_response(loaded, load_factor=pf.Sine(omega=1.0, envelope=0.5), frequencies=(18.0, 19.0),
                           max_points=3)
    b = pf.forced_response(m, load=(mid, (0.0, 0.5 * FORCE, 0.0)), frequencies=(18.0, 19.0), max_points=3)
    assert a.node == b.node == mid and a.component == b.component == 1
    assert a.amplitude[0] == pytest.approx(b.amplitude[0], rel=1e-8)
    with pytest.raises(ValueError, match="load= adds"):
        pf.forced_response(loaded, load=(mid, (0.0, 1.0, 0.0)), frequencies=(18.0, 19.0))
