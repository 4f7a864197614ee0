"""The consistency findings of ``make fuzz``, replayed as plain models.

* "flutter" of a model with a dead moment is no round-off: a moment about fixed global
  axes is not conservative in three dimensions. Its load stiffness is skew (-M~/2 at the
  loaded node, the reference state), a circulatory force; it splits each double
  frequency of a pipe with equal bending stiffnesses into a growing and a decaying pair
  (Ziegler's cantilever under an axial torque), at a rate first order in the moment. The
  fuzz's rule of a conservative model excludes moments.
* ``critical_mass_flow`` and ``stability()`` call a model a mechanism by one rule
  (:func:`pipeflex.analysis.eigen.mechanism`); the fuzz had compared the scan's
  equilibrium without flow with the reference state, whose stiffnesses differ.
"""
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

import pipeflex as pf
from pipeflex.analysis import critical, eigen

sys.path.insert(0, str(Path(__file__).parent / "fuzz"))
import models  # noqa: E402  (tests/fuzz/models.py: the fuzz's cases and rules)


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def cantilever(moment, *, n_elements=4):
    """A clamped pipe 1 m along x, equal bending stiffnesses, a dead moment [N m] at its tip."""
    sec = pf.PipeSection(EI=1.0, pipe_mass=0.13273079594916565, fluid_mass=1.0, EA=100.0, GJ=1.0,
                         rotary_inertia=(7.451289576848557e-4, 3.725644788424279e-4, 3.725644788424279e-4))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    tip = b.add_line(n0, (1.0, 0.0, 0.0), n_elements, sec)[-1]
    b.clamp(n0)
    b.add_load(tip, moment=moment)
    return b.build()


def dense(lin):
    return lin.K.toarray(), lin.C.toarray(), lin.M.toarray()


def circulatory_growth(K, M):
    """First-order growth rate [1/s] of each double frequency of the pencil split by K's
    skew part S: Re lambda = |x1^T S x2| / (2 omega), x1, x2 the M-orthonormal modes of
    the symmetric part (the pair's value does not depend on the basis of their plane)."""
    Ks, S = 0.5 * (K + K.T), 0.5 * (K - K.T)
    w, X = sla.eigh(Ks, M)
    return max(abs(X[:, j] @ S @ X[:, j + 1]) / (2.0 * np.sqrt(w[j]))
               for j in range(len(w) - 1) if w[j] > 0 and w[j + 1] - w[j] <= 1e-8 * w[j])


def test_an_axial_dead_moment_makes_a_cantilever_flutter():
    """The moment's load stiffness is exactly the skew -M~/2 at the tip's rotations; the
    growth is the circulatory split of the double frequencies to first order (2e-8
    relative at 0.01 N m), linear in the moment, far above the eigenvalues' round-off;
    without the moment the pipe is stable; at the equilibrium under the moment it
    flutters alike."""
    model = cantilever((0.01, 0.0, 0.0))
    lin = pf.linearize(model, mass_flow=0.0)
    K, C, M = dense(lin)
    assert not np.any(C) and np.array_equal(M, M.T)
    skew = np.argwhere(K != K.T)
    labels = {model.dof_labels[i] for i in skew.ravel()}
    assert labels == {(4, "ry"), (4, "rz")}  # the tip's transverse rotations only
    iy, iz = model.dof_labels.index((4, "ry")), model.dof_labels.index((4, "rz"))
    assert 0.5 * (K[iy, iz] - K[iz, iy]) == pytest.approx(0.005, rel=1e-12)  # M_x / 2

    eig = pf.eigenvalues(lin)
    assert pf.stability(eig) == "flutter"
    i = int(np.argmax(eig.values.real))
    growth = eig.values[i].real
    assert growth > 1e5 * eig.noise[i]
    assert growth == pytest.approx(circulatory_growth(K, M), rel=1e-6)
    assert abs(eig.values[i].imag) == pytest.approx(520.61, rel=1e-4)
    half = pf.eigenvalues(pf.linearize(cantilever((0.005, 0.0, 0.0)), mass_flow=0.0))
    assert half.values.real.max() == pytest.approx(0.5 * growth, rel=1e-6)  # first order in the moment
    assert pf.stability(pf.eigenvalues(pf.linearize(cantilever((0.0, 0.0, 0.0)), mass_flow=0.0))) == "stable"
    # the same at the equilibrium under the torque (twisted by 0.01 rad): the skew part stays M / 2
    twisted = pf.linearize(model, pf.static_equilibrium(model, mass_flow=0.0).state, mass_flow=0.0)
    Kt = twisted.K.toarray()
    assert np.abs(Kt - Kt.T).max() == pytest.approx(0.01, rel=1e-9)
    at_rest = pf.eigenvalues(twisted)
    assert pf.stability(at_rest) == "flutter" and at_rest.values.real.max() == pytest.approx(growth, rel=1e-3)


def fuzz_case_with_a_dead_moment(level=0.03162277660168379):
    """The fuzz run's eigen case: a clamped pipe of 4 elements along (-1/3, -1, -6e-5), a
    dead moment 0.284 level N m about -x at its middle node, no flow."""
    sec = pf.PipeSection(EI=1.0, pipe_mass=0.13273079594916565, fluid_mass=1.0, EA=100.0, GJ=1.0,
                         rotary_inertia=(7.451289576848557e-4, 3.725644788424279e-4, 3.725644788424279e-4))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, 1.0000000000000004 * _unit((-1.0 / 3.0, -1.0, -6.103515625e-05)), 4, sec)
    b.clamp(n0)
    b.add_load(nodes[2], moment=level * np.array([-0.2840649024511189, 0.0, 0.0]))
    return b.build()


def test_the_fuzz_case_with_a_dead_moment_flutters_by_its_skew_stiffness():
    """Called "flutter of a conservative model" by the fuzz: its growth (0.0029 1/s) is 1e5
    times its round-off bound, the QZ of (K, M) gives the same, it is the circulatory split
    of a double frequency and halves with the moment. The fuzz now counts a moment as
    nonconservative; C = 0 with K, M symmetric still may not flutter."""
    model = fuzz_case_with_a_dead_moment()
    lin = pf.linearize(model, mass_flow=0.0)
    K, C, M = dense(lin)
    eig = pf.eigenvalues(lin)
    assert pf.stability(eig) == "flutter"
    i = int(np.argmax(eig.values.real))
    growth = eig.values[i].real
    assert growth == pytest.approx(2.884e-3, rel=1e-3) and growth > 1e4 * eig.noise[i]
    mu = sla.eigvals(K, M)  # lambda^2 = -mu, the other path
    assert np.sqrt(-mu.astype(complex)).real.max() == pytest.approx(growth, rel=1e-6)
    assert growth == pytest.approx(circulatory_growth(K, M), rel=1e-3)
    half = pf.eigenvalues(pf.linearize(fuzz_case_with_a_dead_moment(0.5 * 0.03162277660168379), mass_flow=0.0))
    assert half.values.real.max() == pytest.approx(0.5 * growth, rel=1e-3)

    case = dict(flow=0.0, loads=[dict(follower=False, level=1.0, moment=[-0.284, 0.0, 0.0], force=[0.0] * 3)])
    assert not models.conservative(case) and not models.symmetric_undamped(lin)
    case["loads"][0]["moment"] = [0.0] * 3
    assert models.conservative(case)


def clamped_stiff_middle():
    """The fuzz run's critical case: clamped at both ends, a soft first and last element
    (EI = 1 N m^2) holding a middle 1e4 times stiffer in bending (and 1e7 N in shear),
    a dead moment and a point mass. The Jacobi-scaled stiffness's conditioning is
    2.4e-14 at the reference and 1.1e-14 at the equilibrium under the moment, either
    side of MECHANISM_CONDITIONING = 64 eps = 1.4e-14."""
    soft = pf.PipeSection(EI=1.0, EIz=1.2641522815037554, pipe_mass=1.0001405485169472, fluid_mass=1.0,
                          EA=219988.31620280433, GJ=1.0,
                          rotary_inertia=(2.0002810970338988e-05, 1.0001405485169494e-05, 1.0001405485169494e-05))
    stiff = pf.PipeSection(EI=9999.999999999989, EIz=6325.760722161567, pipe_mass=1.0, fluid_mass=0.49999999999999994,
                           GAy=9999999.999999989, GAz=9999999.999999989)
    b = pf.ModelBuilder()
    nodes = [b.add_node((0.0, 0.0, 0.0))]
    end = 1.0190409709929984 * _unit((-0.8296978725029196, 0.5429574555785533, 0.7378832592724492))
    nodes += b.add_line(nodes[-1], end, 1, soft)[1:]
    nodes += b.add_line(nodes[-1], end + _unit((-2.220446049250313e-16, -0.99999, 2.2250738585072014e-308)), 2,
                        stiff)[1:]
    normal = _unit((1.0, 0.5690613661842668, 0.99999))
    radial = np.array([0.6243539326218567, -0.3935955315057734, 0.99999])
    radial -= np.dot(radial, normal) * normal
    x0 = b._positions[nodes[-1]]
    nodes += b.add_arc(nodes[-1], center=x0 + _unit(radial), angle=-1.5, normal=normal, n_elements=1,
                       section=soft)[1:]
    b.clamp(nodes[0])
    b.clamp(nodes[-1])
    b.add_load(nodes[3], moment=1.0146652917673673 * np.array([0.0, 0.5, 0.5]))
    b.add_point_mass(nodes[2], 1.0, (1.192092896e-07, 1e-05, 0.0))
    return b.build()


def test_critical_flow_and_stability_call_a_mechanism_by_one_rule_on_one_state():
    """critical_mass_flow refuses the model as a mechanism at the equilibrium without flow
    its scan starts from; stability() of that equilibrium refuses it alike, naming the
    same free coordinates (the fuzz had asked stability() about the reference state,
    which the rule passes). Both call eigen.mechanism."""
    assert critical.mechanism is eigen.mechanism
    model = clamped_stiff_middle()
    with pytest.raises(ValueError, match=r"the model is a mechanism \(its stiffness at the static equilibrium "
                                         r"without flow is singular, e\.g\. a free hinge; (free: [^)]+)\)") as crit:
        pf.critical_mass_flow(model, steps_per_unit=2, mass_flow_max=10.0 * model.flow_scale())
    rest = pf.static_equilibrium(model, mass_flow=0.0).state
    at_rest = pf.eigenvalues(pf.linearize(model, rest, mass_flow=0.0))
    with pytest.raises(ValueError, match=r"stability: the stiffness is singular, a mechanism \(free: ") as stab:
        pf.stability(at_rest)
    free = str(stab.value).split("(", 1)[1].split(")", 1)[0]
    assert free.startswith("free: ") and free in str(crit.value)
    reference = pf.eigenvalues(pf.linearize(model, mass_flow=0.0))
    assert eigen.stiffness_conditioning(at_rest) < eigen.MECHANISM_CONDITIONING < \
        eigen.stiffness_conditioning(reference)
