"""pipeflex.plot: drawings checked by their numbers (centre lines from the shape
functions, mode shapes, crossings, chart data), not only by existing."""
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import pipeflex as pf  # noqa: E402
from pipeflex import plot  # noqa: E402
from pipeflex.plot.centreline import centre_line, end_data, hermite, mode_displacement  # noqa: E402
from pipeflex.work_precision import Run, work_precision_figure  # noqa: E402


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def _line_points(ax):
    """(n, 3) points of each Line3D on 3D axes."""
    return [np.column_stack(line.get_data_3d()) for line in ax.lines]


def _loaded_cantilever(P=1e-4, n_elements=1, EI=1.0, L=1.0):
    sec = pf.PipeSection(EI=EI, pipe_mass=1.0)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (L, 0.0, 0.0), n_elements, sec)
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, P, 0.0))
    m = b.build()
    return m, pf.static_equilibrium(m).state


def test_import_pipeflex_does_not_import_matplotlib():
    code = ("import sys, pipeflex, pipeflex.plot, pipeflex.plotting\n"
            "print(any(m == 'matplotlib' or m.startswith('matplotlib.') for m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_hermite_interpolates_ends_and_tangents():
    xp, tp, xq, tq = np.zeros(3), np.array([1.0, 0.5, 0.0]), np.array([1.0, 0.2, 0.1]), np.array([0.8, -0.3, 0.2])
    r = hermite(xp, tp, xq, tq, [0.0, 1.0])
    np.testing.assert_allclose(r, [xp, xq], atol=1e-15)
    d = hermite(xp, tp, xq, tq, [0.0, 1.0], derivative=True)
    np.testing.assert_allclose(d, [tp, tq], atol=1e-15)
    # the derivative is that of the curve
    h = 1e-6
    fd = (hermite(xp, tp, xq, tq, [0.3 + h]) - hermite(xp, tp, xq, tq, [0.3 - h])) / (2 * h)
    np.testing.assert_allclose(hermite(xp, tp, xq, tq, [0.3], derivative=True), fd, atol=1e-8)


def test_deformed_centre_line_through_the_nodes_with_the_end_tangents():
    """A 2-element cantilever under a large tip force: each drawn element starts and ends at
    its nodes, with the tangents l0 R e_x of the deformed end triads."""
    m, st = _loaded_cantilever(P=2.0, n_elements=2)
    q = np.asarray(st.q).reshape(-1, 6)
    assert q[2, 1] > 0.3  # a large deflection [m]
    ax = plot.model(m, st)
    lines = _line_points(ax)[:2]  # the two elements' centre lines come first
    for e, pts in zip(m.elements, lines):
        p, r = e.nodes
        np.testing.assert_allclose(pts[0], q[p, :3], atol=1e-14)
        np.testing.assert_allclose(pts[-1], q[r, :3], atol=1e-14)
    for e, (xp, tp, xq, tq) in zip(m.elements, end_data(m, st)):
        for node, t in zip(e.nodes, (tp, tq)):
            np.testing.assert_allclose(t, e.length * st.rotation(node)[:, 0], atol=1e-14)
    # the curve is not the chord: the shape functions bend it
    mid = lines[1][len(lines[1]) // 2]
    chord_mid = 0.5 * (q[1, :3] + q[2, :3])
    assert np.linalg.norm(mid - chord_mid) > 1e-3


def test_one_element_centre_line_is_the_exact_beam_deflection():
    """Small tip force P on a 1-element cantilever: the cubic Hermite centre line is the
    exact deflection P x^2 (3L - x) / (6 EI) (Euler-Bernoulli), between the nodes too."""
    P, EI, L = 1e-4, 1.0, 1.0
    m, st = _loaded_cantilever(P=P, EI=EI, L=L)
    pts = centre_line(m, st, n_points=11)[0]
    x = pts[:, 0]
    np.testing.assert_allclose(pts[:, 1], P * x**2 * (3 * L - x) / (6 * EI), rtol=1e-6, atol=1e-12)


def test_rigid_mode_is_drawn_straight_and_a_bending_mode_is_not():
    """A straight pipe hinged about z at one end: the rigid rotation about the hinge, in
    reduced coordinates, is drawn as a straight line through the rotated nodes."""
    sec = pf.PipeSection(EI=1.0, pipe_mass=1.0)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 3, sec)
    b.hinge(n0, (0.0, 0.0, 1.0))
    m = b.build()
    d = np.zeros(6 * m.n_nodes)
    for i in range(m.n_nodes):
        d[6 * i:6 * i + 3] = np.cross([0.0, 0.0, 1.0], m.positions[i])
        d[6 * i + 5] = 1.0
    T = m.basis.toarray()
    v = np.linalg.lstsq(T, d, rcond=None)[0]
    np.testing.assert_allclose(T @ v, d, atol=1e-14)  # in the model's reduced coordinates
    ax = plot.mode_shape(m, v, scale=0.4, reference=False)
    pts = np.vstack(_line_points(ax))
    a, c = pts[0], pts[-1]
    u = (c - a) / np.linalg.norm(c - a)
    off = pts - a - np.outer((pts - a) @ u, u)
    assert np.abs(off).max() < 1e-14
    np.testing.assert_allclose(c, m.positions[nodes[-1]] + 0.4 * np.array([0.0, 1.0, 0.0]), atol=1e-14)
    # the first bending mode of the clamped pipe is curved between the nodes
    cant = pf.scenes.cantilever_pipe(n_elements=2)
    eig = pf.eigenvalues(pf.linearize(cant), vectors=True)
    first = np.flatnonzero(eig.values.imag > 0)[0]
    ax = plot.mode_shape(cant, eig.vectors[:, first], scale=0.3, reference=False)
    pts = _line_points(ax)[0]  # the first element
    chord = pts[-1] - pts[0]
    off = pts - pts[0] - np.outer((pts - pts[0]) @ chord / (chord @ chord), chord)
    assert np.abs(off).max() > 1e-3


def test_mode_displacement_normalises_and_turns_complex_modes_real():
    cant = pf.scenes.cantilever_pipe(n_elements=2)
    eig = pf.eigenvalues(pf.linearize(cant), vectors=True)
    v = eig.vectors[:, np.flatnonzero(eig.values.imag > 0)[0]]
    d = mode_displacement(cant, v * (0.3 - 2.0j))
    assert np.isrealobj(d)
    assert np.linalg.norm(d.reshape(-1, 6)[:, :3], axis=1).max() == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(np.abs(d), np.abs(mode_displacement(cant, v)), atol=1e-12)
    with pytest.raises(ValueError, match="entries"):
        mode_displacement(cant, np.ones(5))


def test_mode_shape_component_matches_the_rotating_transverse_shapes():
    """The in-plane mode 2 of the rotating beam at gamma = 5: the drawn tangential
    displacement at the nodes is rotating_frequencies' transverse_shapes (scaled alike)."""
    beam = pf.scenes.rotating_cantilever()
    c = pf.campbell(beam, gamma=[0.0, 5.0], n_modes=2)
    ax = plot.mode_shape(beam, c.modes[1, 1], component=(0.0, 1.0, 0.0))
    ys = [line.get_ydata() for line in ax.lines]
    nodal = np.array([ys[0][0]] + [y[-1] for y in ys])
    ref = pf.rotating_frequencies(beam, gamma=[5.0], n_modes=2).transverse_shapes[0, 1, :, 1]
    ref = ref / ref[np.argmax(np.abs(ref))]
    np.testing.assert_allclose(nodal, ref, atol=1e-9)
    assert ax.get_xlabel() == "arc length $s$ [m]"


def test_supports_and_loads():
    assert plot.supports(pf.scenes.cantilever_pipe(n_elements=2)) == {0: ("clamp", None)}
    kind, axis = plot.supports(pf.scenes.sprinkler(EI=10.0))[0]
    assert kind == "hinge" and abs(axis @ [0, 0, 1]) == pytest.approx(1.0)
    hub = plot.supports(pf.scenes.rotating_cantilever())
    assert list(hub) == [0] and hub[0][0] == "hub"  # the planar rows of ANCF nodes are no supports
    b = pf.ModelBuilder()
    nodes = b.add_ancf_beam((0, 0, 0), (1, 0, 0), 3, pf.PipeSection(EI=1.0, EA=100.0, pipe_mass=1.0))
    b.clamp(nodes[0])
    b.pin(nodes[-1])
    assert plot.supports(b.build()) == {0: ("clamp", None), 3: ("pin", None)}
    m, _ = _loaded_cantilever(P=3.0, n_elements=2)
    ax = plot.model(m, plane="xy")
    (q,) = [c for c in ax.collections if "force" in str(c.get_label())]
    assert "largest 3 N" in q.get_label()
    np.testing.assert_allclose(q.get_offsets(), [[1.0, 0.0]])  # at the tip
    np.testing.assert_allclose([q.U[0], q.V[0]], [0.0, 0.2])    # along +y, 0.2 of the model's size
    assert ax.get_xlabel() == "$x$ [m]" and ax.get_ylabel() == "$y$ [m]"
    ax3 = plot.model(m)
    assert ax3.get_zlabel() == "$z$ [m]"


def test_flow_arrows_point_along_the_flow():
    m = pf.scenes.cantilever_pipe(n_elements=3)
    ax = plot.model(m, plane="xy")
    (q,) = [c for c in ax.collections if "flow" in str(c.get_label())]
    assert len(q.U) == 3 and np.all(np.asarray(q.U) > 0) and np.allclose(q.V, 0)


def test_campbell_chart_marks_the_crossings():
    beam = pf.scenes.rotating_cantilever()
    c = pf.campbell(beam, gamma=np.linspace(0.0, 6.0, 13), n_modes=3)
    ax = plot.campbell(c)
    (marks,) = [line for line in ax.lines if line.get_label() == r"$\omega = k\Omega$"]
    np.testing.assert_allclose(marks.get_xdata(), c.crossing_speed / beam.info["omega0"])
    assert len(marks.get_xdata()) == 3  # omega_1 meets 3 Omega, 2 Omega, Omega
    assert ax.get_xlabel() == r"$\gamma = \Omega/\omega_0$ [-]"
    ax2 = plot.campbell(c, dimensionless=False)
    assert ax2.get_ylabel() == r"frequency $\omega$ [rad/s]"


def test_work_precision_chart_and_the_old_function():
    runs = [Run("generalized_alpha", h, 0.0, e, t) for h, e, t in ((1e-2, 1e-3, 0.1), (5e-3, 2.5e-4, 0.2))]
    runs += [Run("ida", r, 0.0, e, t) for r, e, t in ((1e-4, 1e-4, 0.3), (1e-6, 1e-6, 0.9))]
    ax = plot.work_precision(runs, reference_name="Richardson extrapolation", target=1e-5,
                             quantity="mean $\\omega$ [rad/s]")
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert "Richardson extrapolation" in ax.get_ylabel()
    target = [line for line in ax.lines if line.get_label().startswith("target")][0]
    np.testing.assert_allclose(target.get_ydata(), [1e-5, 1e-5])
    ida = [line for line in ax.lines if line.get_label().startswith("IDA")][0]
    np.testing.assert_allclose(ida.get_xdata(), [0.3, 0.9])
    np.testing.assert_allclose(ida.get_ydata(), [1e-4, 1e-6])
    fig = work_precision_figure(runs, title="t", quantity="q")
    assert len([line for line in fig.axes[0].lines if line.get_label().startswith("generalised")]) == 1


def test_work_precision_charts_named_settings_beside_the_defaults():
    from helpers import fluttering_cantilever
    from pipeflex.work_precision import work_precision

    m, st = fluttering_cantilever()

    def tip(r):
        return r.x[-1, -1, 1]

    damped = {"damped": dict(rho_inf=0.6, newton_tol=1e-6, work=False)}
    runs = work_precision(m, 0.1, tip, 0.0, steps=(2e-3, 1e-3), state=st, settings=damped)
    assert [(r.integrator, r.setting, r.label) for r in runs] == [
        ("generalized_alpha", 2e-3, None), ("generalized_alpha", 1e-3, None),
        ("generalized_alpha", 2e-3, "damped"), ("generalized_alpha", 1e-3, "damped")]
    assert runs[0].value != runs[2].value  # the damped setting ran, not the defaults again
    assert all(np.isfinite(r.error) and r.wall_time > 0.0 for r in runs)
    labels = [line.get_label() for line in plot.work_precision(runs).lines]
    assert labels == ["generalised-alpha (step $h$ [s])", "generalised-alpha, damped (step $h$ [s])"]
    with pytest.raises(ValueError, match=r"settings\['damped'\] sets \['step'\]"):
        work_precision(m, 0.1, tip, 0.0, steps=(1e-3,), settings={"damped": dict(step=1e-3)})
    with pytest.raises(TypeError, match="settings must map names"):
        work_precision(m, 0.1, tip, 0.0, steps=(1e-3,), settings={"damped": 0.6})


def test_stability_map():
    beta = np.linspace(0.1, 0.9, 5)
    ax = plot.stability_map(beta, 5 + beta, 10 * beta, kind=["flutter"] * 4 + ["divergence"])
    np.testing.assert_allclose(ax.lines[0].get_ydata(), 5 + beta)
    np.testing.assert_allclose(ax.frequency_axes.lines[0].get_ydata(), 10 * beta)
    assert "[-]" in ax.get_xlabel()
    with pytest.raises(ValueError):
        plot.stability_map(beta, beta[:2], None)


def test_root_locus_alias_module():
    import pipeflex.plotting as old

    assert old.root_locus_figure is plot.root_locus_figure and old.eigenvalue_paths is plot.eigenvalue_paths
    m = pf.scenes.cantilever_pipe(n_elements=2)
    paths = plot.eigenvalue_paths(m, [0.0, 1.0], n_modes=2)
    axes = plot.root_locus(paths, [0.0, 1.0], panels=("frequency", "growth"), critical=0.5)
    np.testing.assert_allclose(axes[0].lines[0].get_ydata(), paths[:, 0].imag)


def test_animation_frames_and_gif(tmp_path):
    from PIL import Image

    sec = pf.PipeSection(EI=1.0, pipe_mass=1.0, rotary_inertia=(1e-3, 1e-3, 1e-3))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), 2, sec)
    b.clamp(n0)
    b.add_load(2, force=(0.0, 0.5, 0.0))  # a step load at the tip
    m = b.build()
    r = pf.simulate(m, 0.5, n_outputs=5, progress=False)
    assert r.x[-1, 2, 1] > 0.01
    anim = plot.animate(r, m, plane="xy", trace=2)
    anim._func(len(r.t) - 1)  # draw the last frame
    tip = anim.ax.lines[1].get_xydata()[-1]
    np.testing.assert_allclose(tip, r.x[-1, 2, :2], atol=1e-14)  # the second element ends at the tip
    path = plot.save(anim, tmp_path / "cantilever.mp4", fps=5)
    assert path.exists() and path.suffix in (".mp4", ".gif")
    if path.suffix == ".gif":
        assert Image.open(path).n_frames == len(r.t)


def test_seed002_mode_shape_figure_has_the_transverse_shapes_at_the_nodes():
    """Figs. 11-12 drawn with the shape functions: at the nodes the curves are
    rotating_frequencies' transverse_shapes (largest 1, tip positive), between them cubic."""
    from pipeflex.seeds.seed002 import studies
    from pipeflex.seeds.seed002.references import SLENDERNESS

    fig = studies.mode_shape_figure()
    for ax, (R, N) in zip(fig.axes, ((0.0, 0.0), (2.0, 3.0))):
        beam = pf.scenes.rotating_cantilever(hub_radius_ratio=R, tip_mass_ratio=N, slenderness=SLENDERNESS)
        ref = pf.rotating_frequencies(beam, gamma=[0.0, 50.0], n_modes=3).transverse_shapes[..., 1]
        n_el = len(beam.elements)
        lines = [line for line in ax.lines]
        for k in range(2):
            for j in range(3):
                curve = lines[(3 * k + j) * n_el:(3 * k + j + 1) * n_el]
                nodal = np.array([curve[0].get_ydata()[0]] + [c.get_ydata()[-1] for c in curve])
                s = ref[k, j] / np.abs(ref[k, j]).max() * np.sign(ref[k, j, -1])
                np.testing.assert_allclose(nodal, s, atol=1e-9)


# -- line charts: time histories, parameter curves, comparisons, error-cost, paths, bifurcation

def _xy(line):
    return np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)


def test_time_history_draws_each_series_scaled_with_units():
    t = np.linspace(0.0, 1.0, 11)
    ax = plot.time_history([t, t[:5]], [np.sin(t), np.cos(t[:5])], quantity="tip deflection $w$", unit="mm",
                           scale=1e3, labels=["a", "b"], styles=["--", dict(color="k")])
    assert ax.get_xlabel() == "time $t$ [s]" and ax.get_ylabel() == "tip deflection $w$ [mm]"
    (x0, y0), (x1, y1) = (_xy(line) for line in ax.lines)
    np.testing.assert_allclose(y0, 1e3 * np.sin(t))
    np.testing.assert_allclose(x1, t[:5])
    np.testing.assert_allclose(y1, 1e3 * np.cos(t[:5]))
    assert ax.lines[0].get_linestyle() == "--" and ax.lines[1].get_color() == "k"
    assert [x.get_text() for x in ax.get_legend().get_texts()] == ["a", "b"]
    with pytest.raises(ValueError, match="curve 0"):
        plot.time_history(t, t[:3], quantity="q", unit="m")


def test_parameter_curves_shared_abscissa_log_axes():
    n = np.array([1.0, 2.0, 4.0, 8.0])
    ax = plot.parameter_curves(n, [n**-2, n**-4], xlabel="elements $n$ [-]", ylabel="error [kg/s]",
                               xscale="log", yscale="log", labels=["order 2", None])
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    np.testing.assert_allclose(_xy(ax.lines[1])[1], n**-4)
    assert [x.get_text() for x in ax.get_legend().get_texts()] == ["order 2"]
    assert ax.get_ylabel() == "error [kg/s]"


def test_comparison_lines_ours_circles_published_same_colour():
    g = np.linspace(0.0, 10.0, 21)
    gp = np.array([0.0, 5.0, 10.0])
    ax = plot.comparison(g, [g + 1.0, 2 * g], [[1.0, 6.1, 11.0], [0.0, 9.9, 20.0]], x_published=gp,
                         labels=["$R/L$ = 0", "$R/L$ = 1"], xlabel=r"$\gamma$ [-]", ylabel=r"$\omega/\omega_0$ [-]")
    line0, pub0, line1, pub1 = ax.lines
    np.testing.assert_allclose(_xy(line0)[1], g + 1.0)
    np.testing.assert_allclose(_xy(pub1)[0], gp)
    np.testing.assert_allclose(_xy(pub1)[1], [0.0, 9.9, 20.0])
    assert pub0.get_color() == line0.get_color() and pub0.get_marker() == "o" and pub0.get_linestyle() == "None"
    texts = [x.get_text() for x in ax.get_legend().get_texts()]
    assert texts == ["$R/L$ = 0", "$R/L$ = 1", "lines: ours", "circles: published"]
    with pytest.raises(ValueError, match="published"):
        plot.comparison(g, [g, g], [[1.0, 2.0, 3.0]], x_published=gp, xlabel="x", ylabel="y")


def test_error_cost_groups_floor_and_tolerance():
    ax = plot.error_cost([0.1, 0.2, 0.05], [1e-2, 0.0, 1e-4], groups=["A", "A", "B"], labels=["a1", "a2", "b1"],
                         tolerance=1e-3, floor=1e-9, xlabel="wall time [s]")
    a, b, tol = ax.lines
    np.testing.assert_allclose(_xy(a)[1], [1e-2, 1e-9])        # 0 drawn at the floor
    np.testing.assert_allclose(_xy(b)[0], [0.05])
    assert a.get_marker() != b.get_marker()
    np.testing.assert_allclose(_xy(tol)[1], [1e-3, 1e-3])
    assert [x.get_text() for x in ax.texts] == ["a1", "a2", "b1"]
    assert [x.get_text() for x in ax.get_legend().get_texts()] == ["A", "B", "tolerance 0.001"]
    assert ax.get_xscale() == ax.get_yscale() == "log" and ax.get_ylabel() == "relative error [-]"


def test_paths_projects_on_the_plane():
    p = np.array([[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]])
    ax = plot.paths([p], plane="xz", labels=["shape"])
    np.testing.assert_allclose(np.column_stack(_xy(ax.lines[0])), p[:, [0, 2]])
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("$x$ [m]", "$z$ [m]")
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        plot.paths([p[:, :2]])


def test_deviation_map_log_values_and_flags():
    d = np.array([[1e-5, -2e-3], [0.0, 1e-2]])
    ax = plot.deviation_map(d, row_labels=["a", "b"], column_labels=["1", "2"], flag=1e-3,
                            flag_mask=[[True, True], [True, False]], colorbar=False)
    np.testing.assert_allclose(ax.deviation_image.get_array(), np.log10([[1e-5, 2e-3], [1e-8, 1e-2]]))
    assert len(ax.patches) == 1 and ax.patches[0].get_xy() == (0.5, -0.5)   # (row 0, column 1) only


def _branch(stable):
    k = len(stable)
    amp = np.zeros((k, 3, 3))
    amp[:, 2, 1] = 0.1 * np.sqrt(np.arange(1, k + 1))
    return pf.OrbitBranch(mass_flow=25.0 + np.arange(1, k + 1), period=0.4 + 0.01 * np.arange(1, k + 1),
                          amplitude=amp, stable=np.asarray(stable), max_multiplier=np.ones(k), folds=np.zeros(0),
                          hopf=(25.0, 2 * np.pi / 0.4))


def test_bifurcation_amplitude_from_the_hopf_point_solid_stable_dashed_unstable():
    b = _branch([True, True, False, False])
    ax = plot.bifurcation(b, node=2, labels=["4 elements"])
    lines = [ln for ln in ax.lines if ln.get_marker() != "o"]
    # one line per segment: Hopf point (25, 0), then orbits 1, 2 stable: solid to 27 kg/s; dashed from 27 on
    assert [ln.get_linestyle() for ln in lines] == ["-", "-", "--", "--"]
    np.testing.assert_allclose(np.concatenate([_xy(ln)[0][:1] for ln in lines] + [_xy(lines[-1])[0][1:]]),
                               [25.0, 26.0, 27.0, 28.0, 29.0])
    np.testing.assert_allclose(np.concatenate([_xy(ln)[1][:1] for ln in lines] + [_xy(lines[-1])[1][1:]]),
                               [0.0, 0.1, 0.1 * np.sqrt(2), 0.1 * np.sqrt(3), 0.2])
    hopf = [ln for ln in ax.lines if ln.get_marker() == "o"]
    np.testing.assert_allclose(np.ravel(_xy(hopf[0])), [25.0, 0.0])
    assert ax.get_xlabel() == r"mass flow $\dot m$ [kg/s]" and ax.get_ylabel() == "amplitude $A_y$ [m]"
    assert [x.get_text() for x in ax.get_legend().get_texts()] == ["4 elements", "stable", "unstable", "Hopf point"]


def test_bifurcation_period_explicit_stability_and_several_branches():
    b1, b2 = _branch([True, True, True]), _branch([True, True])
    ax = plot.bifurcation([b1, b2], node=[2, 1], quantity="period", stable=[[True, False, False], []],
                          legend=False)
    lines = [ln for ln in ax.lines if ln.get_marker() != "o"]
    assert [ln.get_linestyle() for ln in lines] == ["-", "--", "--", "-", "-"]   # b2: its own (all stable)
    np.testing.assert_allclose(_xy(lines[0])[1], [0.4, 0.41])            # 2 pi / omega_c at the Hopf point
    assert lines[3].get_color() != lines[0].get_color() and ax.get_ylabel() == "period $T$ [s]"
    with pytest.raises(ValueError, match="stabilities"):
        plot.bifurcation(b1, node=2, stable=[True])
    with pytest.raises(ValueError, match="quantity"):
        plot.bifurcation(b1, node=2, quantity="energy")
