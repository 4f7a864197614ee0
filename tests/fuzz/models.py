"""Random valid pipeflex models and the analyses run on them.

A *case* is a plain dict (JSON-serialisable, so a failure is reproduced from its
printout with :func:`run_case`): the model description and the analysis to run.
:func:`cases` is the hypothesis strategy; :func:`run_case` builds the model, runs the
analysis and returns an outcome:

* ``"ok"``: the analysis returned and every number it returned is finite (where the
  result documents NaN, e.g. the out-of-plane frequencies of a planar model, those
  entries are skipped);
* the name of a documented exception (``ValueError``, ``TypeError``,
  ``ConvergenceError``, ``SingularMatrixError``): an honest refusal;
* anything else raises :class:`Bug` (a non-finite result without an exception, or an
  undocumented exception type, with the original traceback chained).

Used by the fast property tests (tests/test_properties.py) and by the long fuzz run
(tests/fuzz/run_fuzz.py, ``make fuzz``).
"""
from __future__ import annotations

import json
import math
import warnings

import numpy as np
from hypothesis import strategies as st

import pipeflex as pf

DOCUMENTED = (ValueError, TypeError, pf.ConvergenceError)
FAMILIES = ("static", "eigen", "critical", "simulate", "ancf", "multibody")


class Bug(AssertionError):
    """An outcome that is a bug (see the module docstring)."""


# -- building blocks ------------------------------------------------------------------

def log_uniform(lo, hi):
    return st.floats(math.log10(lo), math.log10(hi)).map(lambda e: float(10.0**e))


unit = st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: 0.2 < math.sqrt(sum(x * x for x in v)))


def _norm(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


@st.composite
def sections(draw, fluid=True, shear=True, rotary=None):
    EI = draw(log_uniform(1e-2, 1e4))
    s = dict(EI=EI, pipe_mass=draw(log_uniform(0.05, 50.0)),
             fluid_mass=draw(log_uniform(0.05, 50.0)) if fluid else 0.0)
    if draw(st.booleans()):
        s["EIz"] = EI * draw(log_uniform(0.2, 5.0))
    if draw(st.booleans()):
        s["EA"] = EI * draw(log_uniform(1e1, 1e7))
    if draw(st.booleans()):
        s["GJ"] = EI * draw(log_uniform(0.2, 2.0))
    if shear and draw(st.booleans()):
        s["GAy"] = s["GAz"] = EI * draw(log_uniform(1e2, 1e6))
    if fluid and draw(st.booleans()):
        s["kv"] = draw(st.sampled_from([1.0, 4.0 / 3.0]))
    if rotary or (rotary is None and draw(st.booleans())):
        r = draw(log_uniform(1e-5, 1e-2)) * s["pipe_mass"]
        s["rotary_inertia"] = (2 * r, r, r)
    return s


@st.composite
def segments(draw, max_elements):
    """1-3 lines and arcs, at most ``max_elements`` elements in all."""
    out, left = [], max_elements
    for _ in range(draw(st.integers(1, 3))):
        if left <= 0:
            break
        n = draw(st.integers(1, min(4, left)))
        left -= n
        if draw(st.booleans()):
            out.append(dict(kind="line", direction=draw(unit), length=draw(log_uniform(0.1, 3.0)), n=n))
        else:
            sign = draw(st.sampled_from([-1.0, 1.0]))
            out.append(dict(kind="arc", normal=draw(unit), radial=draw(unit), radius=draw(log_uniform(0.05, 2.0)),
                            angle=sign * draw(st.floats(0.05, min(2 * math.pi, math.pi * n))), n=n))
    return out


SUPPORTS = ("clamp", "clamp", "clamp", "clamp_both", "pin_pin", "hinge_roller", "fix_random")


@st.composite
def pipe_models(draw, max_elements=8, fluid=None, supports=SUPPORTS, rotary=None, loads=1.0):
    """A pipe model description (:func:`build_pipe`): lines and arcs of 1-2 sections,
    supports, loads up to ``loads`` times the stiffness level, gravity, a point mass and
    a mass flow (in flow units); ``fluid`` None: with fluid 4 times in 5."""
    if fluid is None:
        fluid = draw(st.integers(0, 4)) > 0
    m = dict(sections=[draw(sections(fluid=fluid, rotary=rotary)) for _ in range(draw(st.integers(1, 2)))],
             segments=draw(segments(max_elements)), support=draw(st.sampled_from(supports)))
    if m["support"] == "fix_random":
        m["fixed"] = [draw(st.lists(st.sampled_from(pf.model.COMPONENTS), min_size=1, max_size=6, unique=True))
                      for _ in range(2)]
    if m["support"] == "hinge_roller":
        m["axis"] = draw(unit)
    scale = max(s["EI"] for s in m["sections"])
    m["loads"] = [dict(node=draw(st.integers(0, 20)), force=draw(st.tuples(*[st.floats(-1, 1)] * 3)),
                       moment=draw(st.tuples(*[st.floats(-1, 1)] * 3)), follower=draw(st.booleans()),
                       level=scale * draw(log_uniform(1e-4 * loads, loads)))
                  for _ in range(draw(st.integers(0, 2)))]
    m["gravity"] = draw(st.none() | st.tuples(*[st.floats(-20.0, 20.0)] * 3))
    m["point_masses"] = [dict(node=draw(st.integers(0, 20)), mass=draw(log_uniform(1e-3, 10.0)),
                              inertia=draw(st.tuples(*[st.floats(0.0, 0.1)] * 3)))
                         for _ in range(draw(st.integers(0, 1)))]
    m["flow"] = draw(st.floats(0.0, 3.0)) if fluid else 0.0  # in flow units, Model.flow_scale()
    return m


def build_pipe(m):
    """The model of a ``pipe_models`` description, and its mass flow [kg/s]."""
    secs = [pf.PipeSection(**s) for s in m["sections"]]
    b = pf.ModelBuilder()
    nodes = [b.add_node((0.0, 0.0, 0.0))]
    for k, g in enumerate(m["segments"]):
        sec = secs[k % len(secs)]
        x0 = b._positions[nodes[-1]]
        if g["kind"] == "line":
            nodes += b.add_line(nodes[-1], x0 + g["length"] * _norm(g["direction"]), g["n"], sec)[1:]
        else:
            k_ = _norm(g["normal"])
            w = np.asarray(g["radial"], float) - np.dot(g["radial"], k_) * k_
            if np.linalg.norm(w) < 1e-3:  # radial direction along the normal: any perpendicular
                w = np.linalg.svd(k_.reshape(1, 3))[2][1]
            center = x0 + g["radius"] * _norm(w)
            nodes += b.add_arc(nodes[-1], center=center, angle=g["angle"], normal=k_, n_elements=g["n"],
                               section=sec)[1:]
    first, last = nodes[0], nodes[-1]
    support = m["support"]
    if support == "clamp":
        b.clamp(first)
    elif support == "clamp_both":
        b.clamp(first)
        b.clamp(last)
    elif support == "pin_pin":
        b.pin(first)
        b.pin(last)
        b.fix_rotation(first, (1.0, 0.0, 0.0))
    elif support == "hinge_roller":
        b.hinge(first, m["axis"])
        b.axial_support(last, m["axis"])
    else:
        b.fix(first, m["fixed"][0])
        b.fix(last, m["fixed"][1])
    for ld in m["loads"]:
        n = nodes[ld["node"] % len(nodes)]
        b.add_load(n, force=ld["level"] * np.asarray(ld["force"]), moment=ld["level"] * np.asarray(ld["moment"]),
                   follower=ld["follower"])
    if m["gravity"] is not None:
        b.set_gravity(m["gravity"])
    for pm in m["point_masses"]:
        b.add_point_mass(nodes[pm["node"] % len(nodes)], pm["mass"], pm["inertia"])
    model = b.build()
    mdot = m["flow"] * model.flow_scale() if m["flow"] else 0.0
    return model, mdot


@st.composite
def ancf_models(draw):
    """A planar ANCF beam: a builder model (clamped, or on a hub) for static and
    simulate, or the seed's rotating cantilever for rotating_frequencies."""
    m = dict(n=draw(st.integers(1, 4)), elastic=draw(st.sampled_from(["A", "0"])))
    m["kind"] = draw(st.sampled_from(["static", "simulate", "rotating"]))
    if m["kind"] == "rotating":
        m.update(hub_radius_ratio=draw(st.floats(0.0, 3.0)), tip_mass_ratio=draw(st.floats(0.0, 2.0)),
                 slenderness=draw(log_uniform(10.0, 1e3)), gamma=draw(st.lists(st.floats(0.0, 12.0), min_size=1,
                                                                                   max_size=3)),
                 linearization=draw(st.sampled_from(["small_deformation", "steady_state"])))
        return m
    EI = draw(log_uniform(1e-2, 1e4))
    m.update(EI=EI, EA=EI * draw(log_uniform(1e2, 1e6)), mass=draw(log_uniform(0.05, 50.0)),
             length=draw(log_uniform(0.1, 3.0)), angle=draw(st.floats(-math.pi, math.pi)),
             hub=draw(st.booleans()), omega=draw(st.floats(-5.0, 5.0)), spin_up=draw(st.floats(0.0, 2.0)),
             gravity=draw(st.none() | st.tuples(st.floats(-20.0, 20.0), st.floats(-20.0, 20.0), st.just(0.0))),
             load=draw(st.tuples(st.floats(-1, 1), st.floats(-1, 1))), level=EI * draw(log_uniform(1e-3, 3.0)))
    if m["kind"] == "simulate":
        m.update(draw(ga_runs()))
    return m


def build_ancf(m):
    sec = pf.PipeSection(EI=m["EI"], EA=m["EA"], pipe_mass=m["mass"])
    b = pf.ModelBuilder()
    d = np.array([math.cos(m["angle"]), math.sin(m["angle"]), 0.0])
    nodes = b.add_ancf_beam((0.1, 0.0, 0.0), np.array([0.1, 0.0, 0.0]) + m["length"] * d, m["n"], sec,
                            elastic=m["elastic"])
    if m["hub"]:
        b.rotating_hub(nodes[0], omega=m["omega"], spin_up_time=m["spin_up"])
    else:
        b.clamp(nodes[0])
    b.add_load(nodes[-1], force=(m["level"] * m["load"][0], m["level"] * m["load"][1], 0.0))
    if m["gravity"] is not None:
        b.set_gravity(m["gravity"])
    return b.build()


@st.composite
def ga_runs(draw):
    h = draw(log_uniform(1e-5, 1e-2))
    # min_step: without it a run whose Newton keeps failing halves its step without bound
    # (reported: ~2e6 steps, 100 s, for 43 steps asked; max_steps is not checked then)
    return dict(step=h, n_steps=draw(st.integers(1, 60)), rho_inf=draw(st.floats(0.0, 1.0)),
                n_outputs=draw(st.integers(2, 6)), kick=draw(st.floats(0.0, 1.0)), kick_node=draw(st.integers(0, 20)))


@st.composite
def multibody_models(draw):
    fluid = draw(st.integers(0, 3)) > 0
    sec = draw(sections(fluid=fluid, shear=False))
    sec.pop("kv", None)
    n_bodies = draw(st.integers(1, 3))
    L = draw(log_uniform(0.1, 2.0))
    m = dict(section=sec, n_bodies=n_bodies, length=L, n_elements=draw(st.sampled_from([2, 4, 6])),
             internal_modes=draw(st.integers(0, 2)), direction=draw(unit),
             curvature=draw(st.floats(-1.5, 1.5)) / L if n_bodies == 1 and draw(st.booleans()) else 0.0,
             base=draw(st.sampled_from(["fix", "fix", "hinge", "spherical"])), axis=draw(unit),
             joints=[draw(st.sampled_from(["rigid", "rigid", "hinge", "spherical"])) for _ in range(n_bodies - 1)],
             roller=draw(st.booleans()), fix_end=draw(st.integers(0, 9)) == 0, gravity=draw(st.none() | st.tuples(*[st.floats(-20.0, 20.0)] * 3)),
             load=draw(st.tuples(*[st.floats(-1, 1)] * 3)), level=sec["EI"] / L**2 * draw(log_uniform(1e-3, 1.0)),
             flow=draw(st.floats(0.0, 3.0)) if fluid else 0.0)
    m["analysis"] = draw(st.sampled_from(["static", "eigen", "critical", "simulate"]))
    if m["analysis"] == "simulate":
        m.update(draw(ga_runs()))
        m["rho_inf"] = min(m["rho_inf"], 0.95)
    return m


def build_multibody(m):
    from pipeflex.multibody import MultibodyBuilder, flexible_body

    sec = pf.PipeSection(**m["section"])
    body = flexible_body(length=m["length"], n_elements=m["n_elements"], section=sec,
                         internal_modes=m["internal_modes"], curvature=m["curvature"])
    b = MultibodyBuilder()
    d = _norm(m["direction"])
    for j in range(m["n_bodies"]):
        if m["curvature"]:
            b.add_body(body, position=(0.0, 0.0, 0.0))
        else:
            b.add_body_between(body, j * m["length"] * d, (j + 1) * m["length"] * d)
    if m["base"] == "fix":
        b.fix(0, "start")
    elif m["base"] == "hinge":
        b.hinge(0, "start", m["axis"])
    else:
        b.spherical(0, "start")
    for j, kind in enumerate(m["joints"]):
        if kind == "rigid":
            b.rigid(j, "end", j + 1, "start")
        elif kind == "hinge":
            b.hinge(j, "end", m["axis"], j + 1, "start")
        else:
            b.spherical(j, "end", j + 1, "start")
    last = m["n_bodies"] - 1
    if m["roller"]:
        b.roller(last, "end", d)
    if m.get("fix_end"):
        b.fix(last, "end")
    b.add_load(last, "end", force=tuple(m["level"] * x for x in m["load"]))
    if m["gravity"] is not None:
        b.set_gravity(m["gravity"])
    system = b.build()
    mdot = m["flow"] * system.flow_scale() if m["flow"] else 0.0
    return system, mdot


# -- cases --------------------------------------------------------------------------

@st.composite
def cases(draw, family):
    """One model and the analysis to run on it; ``family`` in :data:`FAMILIES`."""
    if family == "static":
        return dict(family=family, model=draw(pipe_models()), load_steps=draw(st.integers(1, 4)))
    if family == "eigen":
        return dict(family=family, model=draw(pipe_models()), sparse=draw(st.integers(0, 3)) == 0)
    if family == "critical":
        return dict(family=family, model=draw(pipe_models(max_elements=4, fluid=True, loads=0.1,
                                                           supports=("clamp", "clamp", "clamp", "clamp_both"))),
                    steps_per_unit=draw(st.integers(1, 4)), mass_flow_max=draw(st.none() | st.floats(0.5, 10.0)))
    if family == "simulate":
        c = dict(family=family, model=draw(pipe_models(max_elements=6, rotary=True)),
                 integrator=draw(st.sampled_from(["generalized_alpha", "generalized_alpha", "ida"])))
        c.update(draw(ga_runs()))
        if c["integrator"] == "ida":
            c["t_end"] = draw(log_uniform(1e-5, 3e-3))
        return c
    if family == "ancf":
        return dict(family=family, model=draw(ancf_models()))
    if family == "multibody":
        return dict(family=family, model=draw(multibody_models()))
    raise ValueError(family)


def conservative(m) -> bool:
    """A pipe model description without flow, follower loads or moments. A dead moment
    (about fixed global axes) is not conservative in three dimensions: its load stiffness
    is skew (-M~/2 at the loaded node, M~ the cross-product matrix of M), a circulatory
    force that splits the equal frequencies of two bending planes into a growing pair
    (Ziegler's axial moment)."""
    return (not m["flow"] and not any(ld["follower"] for ld in m["loads"])
            and not any(ld["level"] * np.any(np.asarray(ld["moment"], float) != 0.0) for ld in m["loads"]))


def symmetric_undamped(lin) -> bool:
    """C = 0 and K, M symmetric to 1e-9 (eigen's own test): the eigenvalues are +-sqrt of
    a symmetric pencil's, none a growing oscillation, whatever the model description."""
    from pipeflex.analysis.eigen import _nearly_symmetric

    K, C, M = (x.toarray() for x in (lin.K, lin.C, lin.M))
    return not np.any(C) and _nearly_symmetric(K) and _nearly_symmetric(M)


def _finite(name, *arrays):
    for a in arrays:
        a = np.asarray(a)
        if a.size and not np.all(np.isfinite(a)):
            raise Bug(f"{name}: a non-finite result without an exception")


def _kick(model, state, c):
    """A random initial velocity at one node (transverse and rotational)."""
    if c["kick"]:
        n = c["kick_node"] % len(model.positions)
        v = np.array(state.v)
        v[6 * n:6 * n + 6] += c["kick"] * np.array([0.3, 1.0, -0.5, 0.2, -0.4, 0.1])
        state.v = model.basis @ (model.basis.T @ v)  # only free directions
    return state


def _run(c):
    fam, m = c["family"], c["model"]
    if fam == "static":
        model, mdot = build_pipe(m)
        r = pf.static_equilibrium(model, mass_flow=mdot, load_steps=c["load_steps"])
        _finite("static_equilibrium", r.state.q, r.residual)
    elif fam == "eigen":
        model, mdot = build_pipe(m)
        lin = pf.linearize(model, mass_flow=mdot)
        _finite("linearize", lin.M.data, lin.C.data, lin.K.data)
        n = lin.M.shape[0]
        if c["sparse"] and n > 8:
            eig = pf.eigenvalues(lin, n_modes=4)
        else:
            eig = pf.eigenvalues(lin)
        _finite("eigenvalues", eig.values)
        kind = pf.stability(eig)
        if kind not in ("stable", "divergence", "flutter"):
            raise Bug("stability: not one of stable, divergence, flutter")
        if kind == "flutter" and (conservative(m) or symmetric_undamped(lin)):
            # M, K symmetric and C = 0: the eigenvalues are +-sqrt(real), no growing oscillation
            raise Bug("stability: 'flutter' of a conservative model (no flow, follower load or moment; or C = 0 "
                      f"and K, M symmetric): round-off eigenvalues called growing (largest Re "
                      f"{eig.values.real.max():.3g} 1/s)")
    elif fam == "critical":
        model, _ = build_pipe(m)
        try:
            r = pf.critical_mass_flow(model, steps_per_unit=c["steps_per_unit"],
                                      mass_flow_max=None if c["mass_flow_max"] is None
                                      else c["mass_flow_max"] * model.flow_scale())
        except ValueError as e:
            if "the model is a mechanism" in str(e):  # stability() must agree, on the same state:
                try:  # the equilibrium without flow the scan starts from (not the reference)
                    rest = pf.static_equilibrium(model, mass_flow=0.0).state
                    kind = pf.stability(pf.eigenvalues(pf.linearize(model, rest, mass_flow=0.0)))
                except (ValueError, pf.ConvergenceError):
                    raise e from None
                raise Bug(f"critical_mass_flow calls the model a mechanism, stability() calls it {kind!r} "
                          f"(the two mechanism tests disagree)") from e
            raise
        _finite("critical_mass_flow", r.mass_flow, r.frequency, r.eigenvalue)
        if r.kind not in ("divergence", "flutter"):
            raise Bug(f"critical_mass_flow: kind {r.kind!r}")
    elif fam == "simulate":
        model, mdot = build_pipe(m)
        st0 = _kick(model, model.initial_state(), c)
        if c["integrator"] == "ida":
            r = pf.simulate(model, c["t_end"], integrator="ida", state=st0, mass_flow=mdot,
                            n_outputs=c["n_outputs"], progress=False, max_steps=20000)
        else:
            r = pf.simulate(model, c["n_steps"] * c["step"], integrator="generalized_alpha", state=st0,
                            mass_flow=mdot, step=c["step"], rho_inf=c["rho_inf"], n_outputs=c["n_outputs"],
                            min_step=c["step"] / 256, progress=False)
        _finite("simulate", r.x, r.R, r.xd, r.omega, r.energy, r.fluid_work, r.load_work)
    elif fam == "ancf":
        if m["kind"] == "rotating":
            model = pf.scenes.rotating_cantilever(n_elements=m["n"], elastic=m["elastic"],
                                                  hub_radius_ratio=m["hub_radius_ratio"],
                                                  tip_mass_ratio=m["tip_mass_ratio"], slenderness=m["slenderness"])
            r = pf.rotating_frequencies(model, gamma=m["gamma"], linearization=m["linearization"])
            _finite("rotating_frequencies", r.growth, r.max_strain)
            for fam_ in (r.transverse, r.longitudinal):  # documented: NaN pads the modes a model lacks
                pad = np.isnan(fam_)
                if np.any(pad[:, :-1] & ~pad[:, 1:]) or np.any(np.isinf(fam_)):
                    raise Bug("rotating_frequencies: a NaN before a frequency, or an infinite one")
        elif m["kind"] == "static":
            model = build_ancf(m)
            r = pf.static_equilibrium(model)
            _finite("static_equilibrium", r.state.q)
        else:
            model = build_ancf(m)
            r = pf.simulate(model, m["n_steps"] * m["step"], integrator="generalized_alpha", step=m["step"],
                            rho_inf=m["rho_inf"], n_outputs=m["n_outputs"], min_step=m["step"] / 256,
                            progress=False)
            _finite("simulate", r.x, r.energy)
    elif fam == "multibody":
        from pipeflex import multibody as mb

        system, mdot = build_multibody(m)
        a = m["analysis"]
        if a == "static":
            r = mb.static_equilibrium(system, mass_flow=mdot)
            _finite("multibody.static_equilibrium", r.state.eta, r.state.lam, r.state.r)
        elif a == "eigen":
            eig = pf.eigenvalues(pf.linearize(system, mass_flow=mdot))
            _finite("eigenvalues", eig.values)
        elif a == "critical":
            r = pf.critical_mass_flow(system, steps_per_unit=2)
            _finite("critical_mass_flow", r.mass_flow, r.frequency)
        else:
            r = mb.simulate(system, m["n_steps"] * m["step"], step=m["step"], mass_flow=mdot,
                            rho_inf=m["rho_inf"], n_outputs=m["n_outputs"])
            _finite("multibody.simulate", r.r, r.bodies.R, r.eta, r.v, r.drift)
    else:
        raise ValueError(fam)


def run_case(c) -> str:
    """Run one case; return "ok" or the documented exception's type name; raise
    :class:`Bug` otherwise. numpy floating-point warnings are errors here (an overflow
    that would turn into a NaN result is a bug unless turned into a documented error)."""
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            _run(c)
        return "ok"
    except pf.ConvergenceError as e:
        return type(e).__name__
    except (ValueError, TypeError) as e:
        if isinstance(e, np.linalg.LinAlgError):
            raise Bug(f"undocumented LinAlgError: {e} (from {_pipeflex_frame(e)})") from e
        where = _raised_in(e)
        if "/pipeflex/" not in where.replace("\\", "/"):
            # numpy's or scipy's own ValueError (e.g. "need at least one array to
            # concatenate"): not a refusal by pipeflex, naming no parameter
            raise Bug(f"{type(e).__name__} leaked from {where}: {e}") from e
        return type(e).__name__
    except Bug:
        raise
    except KeyboardInterrupt:
        raise
    except BaseException as e:  # noqa: BLE001 - anything else is the bug we look for
        raise Bug(f"undocumented {type(e).__name__}: {e} (from {_pipeflex_frame(e)})") from e


def _raised_in(e) -> str:
    """The file of the innermost Python frame of an exception's traceback."""
    tb = e.__traceback__
    while tb.tb_next is not None:
        tb = tb.tb_next
    return tb.tb_frame.f_code.co_filename


def _pipeflex_frame(e) -> str:
    """file:line of the innermost pipeflex frame of an exception's traceback."""
    where, tb = "?", e.__traceback__
    while tb is not None:
        f = tb.tb_frame.f_code.co_filename.replace("\\", "/")
        if "/pipeflex/" in f:
            where = f"{f.split('/pipeflex/')[-1]}:{tb.tb_lineno}"
        tb = tb.tb_next
    return where


def dumps(c) -> str:
    return json.dumps(c, sort_keys=True, default=float)
