"""The seeds' figures as a reader sees them: every legend entry names something drawn,
published values are drawn (open circles, the package's published style) where the seed
has them and nothing computed is drawn in that style, curves that coincide stay visible,
labels do not overprint, trajectories in space have equal axes and enough points to be
smooth, and an axis has more than one tick label. Checked on the drawn artists."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.text import Text  # noqa: E402

from pipeflex import plot  # noqa: E402
from pipeflex.plot.curves import is_published_style  # noqa: E402


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def _visible(line, ax):
    """Has the line at least one finite point inside the axes' limits, drawn with a line or marker?"""
    ls, mk, _ = _parts(line)
    if not line.get_visible() or (ls is None and mk is None):
        return False
    x, y = (np.asarray(v, dtype=float) for v in line.get_data())
    if x.size == 0:
        return False
    (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
    inside = np.isfinite(x) & np.isfinite(y) & (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
    return bool(inside.any())


def _parts(line):
    """(line style or None, marker or None, open marker) of a line."""
    ls = None if line.get_linestyle() in ("None", "none", "") else line.get_linestyle()
    mk = None if line.get_marker() in ("None", "none", "", None) else line.get_marker()
    return ls, mk, str(line.get_markerfacecolor()).lower() == "none"


def assert_legends_show_drawn_artists(fig):
    """Every legend entry stands for something visible in its axes: the labelled line itself,
    or (a proxy handle) visible lines that carry its line style and its marker."""
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is None:
            continue
        lines = [ln for ln in ax.lines if _visible(ln, ax)]
        for handle, text in zip(legend.legend_handles if hasattr(legend, "legend_handles") else legend.legendHandles,
                                legend.get_texts()):
            label = text.get_text()
            own = [ln for ln in ax.lines if ln.get_label() == label]
            if own:
                assert any(_visible(ln, ax) for ln in own), f"legend entry {label!r}: its curve is not visible"
                continue
            if not hasattr(handle, "get_linestyle") or not hasattr(handle, "get_marker"):
                continue  # a patch or collection entry (e.g. a quiver): not a curve
            ls, mk, hollow = _parts(handle)
            if ls is not None:
                assert any(_parts(ln)[0] == ls for ln in lines), f"legend entry {label!r}: no visible {ls} line"
            if mk is not None:
                assert any(_parts(ln)[1] == mk and _parts(ln)[2] == hollow for ln in lines), \
                    f"legend entry {label!r}: no visible marker {mk!r}"


def _published(ax):
    return [ln for ln in ax.lines if is_published_style(ln)]


def _text_boxes(fig, texts):
    """Display boxes of the texts themselves (an annotation's own extent includes its leader line)."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    return [Text.get_window_extent(t, r) for t in texts]


def _no_text_overlap(fig, texts):
    texts = [t for t in texts if t.get_text()]
    boxes = _text_boxes(fig, texts)
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            assert not boxes[i].overlaps(boxes[j]), \
                f"labels {texts[i].get_text()!r} and {texts[j].get_text()!r} overprint"


# -- the shared helpers ------------------------------------------------------------------

def test_published_points_style_and_the_legend_check_can_fail():
    fig, ax = plt.subplots()
    ax.plot([0.0, 1.0], [0.0, 1.0], label="ours")
    line = plot.published_points([0.5], [0.4], ax=ax, color="C0", label="published")
    assert is_published_style(line) and line.get_color() == "C0"
    assert line.get_zorder() > ax.lines[0].get_zorder()
    ax.legend()
    assert_legends_show_drawn_artists(fig)
    ax.plot([], [], label="nothing drawn")
    ax.legend()
    with pytest.raises(AssertionError, match="nothing drawn"):
        assert_legends_show_drawn_artists(fig)
    with pytest.raises(ValueError, match="one length"):
        plot.published_points([0.0, 1.0], [1.0], ax=ax)


def test_label_points_do_not_overlap_in_a_cluster():
    x = np.array([1.0, 1.05, 1.1, 1.15, 1.2, 2.0, 2.02])
    y = np.array([1e-3, 1e-3, 1.02e-3, 1e-3, 0.98e-3, 1e-5, 1e-5])
    ax = plot.error_cost(x, y, groups=list("AABBBAB"), labels=[f"model {k} + 8 modes" for k in range(7)],
                         tolerance=1e-4)
    boxes = _text_boxes(ax.figure, ax.texts)
    assert [t.get_text() for t in ax.texts] == [f"model {k} + 8 modes" for k in range(7)]
    assert not any(boxes[i].overlaps(boxes[j]) for i in range(7) for j in range(i + 1, 7))
    # and no label covers a marker's centre
    centres = ax.transData.transform(np.column_stack([x, y]))
    assert not any(b.contains(*c) for b in boxes for c in centres)
    assert not any(is_published_style(ln) for ln in ax.lines)  # computed: never open circles


def test_log_axis_of_one_and_a_half_decades_has_several_tick_labels():
    n = np.array([24.0, 48.0, 96.0, 192.0, 384.0, 768.0])
    ax = plot.parameter_curves(n, 25.0 + 1.0 / n, xlabel="size [-]", ylabel="flow [kg/s]", xscale="log")
    ax.figure.canvas.draw()
    labels = [t.get_text() for t in ax.get_xticklabels() if t.get_text()
              and ax.get_xlim()[0] <= t.get_position()[0] <= ax.get_xlim()[1]]
    assert len(labels) >= 3, labels


# -- seed 000 ----------------------------------------------------------------------------

def test_sprinkler_fig5_draws_the_published_final_speeds():
    from pipeflex.seeds.seed000 import figures
    from pipeflex.seeds.seed000.references import SPRINKLER

    fig = figures.sprinkler_figure(step=2e-3, t_end=0.4)
    ax = fig.axes[1]
    pub = _published(ax)
    np.testing.assert_allclose(sorted(float(ln.get_ydata()[0]) for ln in pub), sorted(SPRINKLER.values()))
    assert all(float(ln.get_xdata()[0]) == pytest.approx(0.4) for ln in pub)
    curves = [ln for ln in ax.lines if not is_published_style(ln)]
    assert len({ln.get_linestyle() for ln in curves}) == 4  # the seed's four line styles
    assert any("published" in t.get_text() for t in ax.get_legend().get_texts())
    assert_legends_show_drawn_artists(fig)


def test_coriolis_fig8_both_fluids_visible_and_computed_points_not_published_style():
    from pipeflex.seeds.seed000 import coriolis

    flows = np.linspace(0.0, 0.02, 3)
    water = coriolis.time_lag_curve(flows_scaled=flows, fluid_density=coriolis.WATER)
    kero = coriolis.time_lag_curve(flows_scaled=flows, fluid_density=coriolis.KEROSENE,
                                   mass_flow0=water.scales.mass_flow0)
    fig = coriolis.time_lag_figure(water, kero, labels=["water", "kerosene"])
    ax = fig.axes[0]
    assert not _published(ax)
    points = [ln for ln in ax.lines if _parts(ln)[1] is not None]
    fits = [ln for ln in ax.lines if _parts(ln)[1] is None]
    assert len(points) == len(fits) == 2
    # the curves coincide: the one drawn below is larger / wider, with another marker / dash
    (p_w, p_k), (f_w, f_k) = points, fits
    assert p_w.get_marker() != p_k.get_marker() and p_w.get_markersize() > p_k.get_markersize()
    assert p_k.get_zorder() > p_w.get_zorder()
    assert f_w.get_linestyle() != f_k.get_linestyle() and f_w.get_linewidth() > f_k.get_linewidth()
    assert f_k.get_zorder() > f_w.get_zorder()
    assert [t.get_text().split(":")[0] for t in ax.get_legend().get_texts()] == ["water", "kerosene"]
    assert_legends_show_drawn_artists(fig)


def test_coriolis_sketch_labels_do_not_overprint():
    import pipeflex as pf
    from pipeflex.seeds.seed000 import coriolis

    fig = coriolis.geometry_figure(pf.scenes.coriolis_meter(leg_length=coriolis.LEG_FIG8))
    ax = fig.axes[0]
    texts = [t for t in ax.texts if t.get_text()]
    assert {t.get_text() for t in texts} >= {"inlet", "outlet", "S1 (inlet side)", "S2 (outlet side)"}
    _no_text_overlap(fig, texts)
    assert not _published(ax)  # a sensor is a position, not a published value


# -- seed 002 ----------------------------------------------------------------------------

def test_seed002_fig6_diverging_run_is_drawn_up_to_its_failure():
    from pipeflex.seeds.seed002 import studies

    fig = studies.spin_up_figure(t_end=18.0)
    ax = fig.axes[0]
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    diverged = [t for t in texts if "diverged" in t]
    assert len(diverged) == 1 and diverged[0].startswith("Model 0, 1 element")
    assert_legends_show_drawn_artists(fig)
    (line,) = [ln for ln in ax.lines if ln.get_label() == diverged[0]]
    t_fail = float(diverged[0].split("$t$ = ")[1].split(" s")[0])
    assert line.get_xdata()[-1] > t_fail - 1.05  # drawn until shortly before the failure


# -- seed 004 ----------------------------------------------------------------------------

def test_seed004_fig7_published_table2_ticks_and_legend():
    from pipeflex.seeds.seed000.references import TABLE2
    from pipeflex.seeds.seed004 import studies

    data = {"bodies_size": np.array([24, 48, 96, 192, 384, 768]),
            "bodies_flow": np.array([TABLE2[2], TABLE2[4], TABLE2[8], TABLE2[16], TABLE2[32], 25.0055]),
            "modes_size": np.array([24, 32, 40, 48, 56, 72]),
            "modes_flow": np.array([24.96, 25.10, 25.06, 25.01, 25.009, 25.007])}
    fig = studies.fig7_figure(data, TABLE2)
    ax = fig.axes[0]
    (pub,) = _published(ax)
    np.testing.assert_allclose(pub.get_ydata(), [TABLE2[n] for n in sorted(TABLE2)])
    computed = [ln for ln in ax.lines if ln is not pub]
    assert all(ln.get_marker() != "o" for ln in computed)
    assert_legends_show_drawn_artists(fig)
    fig.canvas.draw()
    x0, x1 = ax.get_xlim()
    labels = [t.get_text() for t in ax.get_xticklabels() if t.get_text() and x0 <= t.get_position()[0] <= x1]
    assert len(labels) >= 3, labels


def test_seed004_fig9_draws_table1_both_columns():
    from pipeflex.seeds.seed004 import studies
    from pipeflex.seeds.seed004.references import TABLE1_FFRF, TABLE1_SPACAR

    E = 95.85e9
    run = studies.curved_pipe_run(E, n_bodies=2, elements_per_body=4, t_end=0.2, step=2e-3, n_outputs=11)
    fig9, fig10 = studies.curved_figures({E: run}, {E: (run[1].t, run[2])})
    ax = fig9.axes[0]
    values = sorted(float(ln.get_ydata()[0]) for ln in _published(ax))
    assert values == pytest.approx(sorted([TABLE1_FFRF[E], TABLE1_SPACAR[E]]))
    inset = ax.child_axes  # the zoom on the last 1.5 s
    assert inset and len(_published(inset[0])) == 2
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "published: Table 1, FFRF" in texts and "published: Table 1, Spacar" in texts
    assert_legends_show_drawn_artists(fig9)
    assert_legends_show_drawn_artists(fig10)


def test_seed004_fig12_trajectories_to_scale_from_every_step():
    from pipeflex.seeds.seed004 import studies

    step, t_end = 1e-3, 0.05
    _, res, path = studies.printer_run(0.0, step=step, t_end=t_end)
    assert len(res.t) == round(t_end / step) + 1  # one output per step: the drawn path is the computed one
    paths = {0.0: path, 3.0: path + [1e-3, 0.0, 0.0]}
    fig = studies.printer_figure(paths, t_end=t_end)
    ax = fig.axes[0]
    assert ax.get_aspect() == 1.0
    assert all(len(ln.get_xdata()) == len(res.t) for ln in ax.lines)
    assert_legends_show_drawn_artists(fig)
    (shift,) = fig.axes[1].lines
    np.testing.assert_allclose(shift.get_ydata(), 1.0)  # mm from the path without flow
