"""ParaView export (result.to_vtk): the files read back with meshio hold the result's positions."""
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import pipeflex as pf

meshio = pytest.importorskip("meshio")


def pvd_entries(path):
    """(timestep, file) of each DataSet of a .pvd."""
    root = ET.parse(path).getroot()
    return [(float(d.get("timestep")), d.get("file")) for d in root.iter("DataSet")]


@pytest.fixture(scope="module")
def meter_run():
    model = pf.scenes.coriolis_meter(leg_length=0.3, drive_force=50.0)
    return model, pf.simulate(model, 0.01, n_outputs=6)


def test_transient_points_and_data(tmp_path, meter_run):
    model, res = meter_run
    paths = res.to_vtk(tmp_path / "vtk", model, tube=True, radius=0.0254, n_sides=8)
    assert [p.name for p in paths] == ["pipeflex.pvd", "pipeflex_tube.pvd"]
    entries = pvd_entries(paths[0])
    assert [t for t, _ in entries] == res.t.tolist()  # every output time, exactly
    for k, (_, name) in enumerate(entries):
        mesh = meshio.read(tmp_path / "vtk" / name)
        assert np.array_equal(mesh.points, res.x[k])
        lines = mesh.cells_dict["line"]
        assert lines.tolist() == [list(e.nodes) for e in model.elements]
        assert np.array_equal(mesh.point_data["displacement"], res.x[k] - model.positions)
        assert np.array_equal(mesh.point_data["velocity"], res.xd[k])
        assert np.array_equal(mesh.point_data["angular_velocity"], res.omega[k])
    # the driven apex moved, and its rotation vector is that of R R_ref^T (small here)
    assert np.abs(mesh.point_data["displacement"]).max() > 0
    rot = mesh.point_data["rotation"]
    assert np.abs(rot).max() < 0.1 and np.abs(rot).max() > 0
    tube = meshio.read(tmp_path / "vtk" / pvd_entries(paths[1])[-1][1])
    quads = tube.cells_dict["quad"]
    assert quads.shape == (8 * len(model.elements), 4)
    # every ring point lies at the radius from its element's axis end
    ends = res.x[-1][np.repeat(np.array([e.nodes for e in model.elements]), 8, axis=1).ravel()]
    assert np.allclose(np.linalg.norm(tube.points - ends, axis=1), 0.0254, rtol=1e-12)


def test_every_and_name(tmp_path, meter_run):
    model, res = meter_run
    (pvd,) = res.to_vtk(tmp_path, model, name="meter", every=2)
    entries = pvd_entries(pvd)
    assert [t for t, _ in entries] == res.t[::2].tolist()
    assert all(f.startswith("meter_") and (tmp_path / f).is_file() for _, f in entries)


def test_ancf_model_lies_in_its_plane(tmp_path):
    beam = pf.scenes.rotating_cantilever(n_elements=3, omega=2.0, spin_up_time=1.0)
    res = pf.simulate(beam, 0.1, n_outputs=3)
    (pvd,) = res.to_vtk(tmp_path, beam)
    mesh = meshio.read(tmp_path / pvd_entries(pvd)[-1][1])
    assert np.array_equal(mesh.points, res.x[-1]) and np.all(mesh.points[:, 2] == 0.0)


def test_static_result(tmp_path):
    model = pf.scenes.cantilever_pipe(n_elements=4)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 4, model.elements[0].section)
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, 0.0, -1.0))
    model = b.build()
    res = pf.static_equilibrium(model)
    (pvd,) = res.to_vtk(tmp_path, model)
    assert [t for t, _ in pvd_entries(pvd)] == [0.0]
    mesh = meshio.read(tmp_path / pvd_entries(pvd)[0][1])
    q = np.asarray(res.state.q).reshape(-1, 6)[:, :3]
    assert np.array_equal(mesh.points, q) and mesh.points[-1, 2] < 0


def test_bodies(tmp_path):
    system = pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, tip_force=1.0)
    res = pf.simulate(system, 0.005, n_outputs=3)
    (pvd,) = res.to_vtk(tmp_path)
    mesh = meshio.read(tmp_path / pvd_entries(pvd)[-1][1])
    expected = np.concatenate([[res.node_position(j, i)[-1] for i in range(len(s))]
                               for j, s in enumerate(res.bodies.nodes_s)])
    assert np.allclose(mesh.points, expected, rtol=0, atol=4 * np.spacing(np.abs(expected).max()))
    assert len(mesh.cells_dict["line"]) == sum(len(s) - 1 for s in res.bodies.nodes_s)


def test_bad_input(tmp_path, meter_run):
    model, res = meter_run
    (tmp_path / "a_file").write_text("x")
    with pytest.raises(ValueError, match="folder .*a_file.* is a file"):
        res.to_vtk(tmp_path / "a_file", model)
    with pytest.raises(TypeError, match="pass the model"):
        res.to_vtk(tmp_path / "v")
    with pytest.raises(ValueError, match="radius must be > 0"):
        res.to_vtk(tmp_path / "v", model, tube=True, radius=-1.0)
    with pytest.raises(ValueError, match="n_sides must be >= 3"):
        res.to_vtk(tmp_path / "v", model, tube=True, n_sides=2)


def test_missing_meshio_says_how_to_install(monkeypatch, tmp_path, meter_run):
    import sys

    model, res = meter_run
    monkeypatch.setitem(sys.modules, "meshio", None)  # import meshio then raises ImportError
    with pytest.raises(ImportError, match="apt install python3-meshio"):
        res.to_vtk(tmp_path, model)


def cantilever(force, moment=(0.0, 0.0, 0.0), *, n=8, L=2.0):
    """A clamped tube along x under a tip force and moment; its static result."""
    section = pf.PipeSection.tube(outer_diameter=0.06, inner_diameter=0.05, E=2e11, G=8e10, density=7800.0)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    tip = b.add_line(n0, (L, 0.0, 0.0), n, section)[-1]
    b.clamp(n0)
    b.add_load(tip, force=force, moment=moment)
    model = b.build()
    return model, pf.static_equilibrium(model)


def test_section_forces_of_a_cantilever(tmp_path):
    """Cell data from the elements' constitutive law: under a tip force F the bending moment
    at each element midpoint is the statics' F (L - x) (M_y = -F_z (L - x) on the +x face,
    M_z = +F_y (L - x)), the shear force F; an axial force and a torque carry through."""
    F, L, n = 40.0, 2.0, 8
    x_mid = (np.arange(n) + 0.5) * L / n
    cases = [((0.0, 0.0, F), (0.0, 0.0, 0.0), {"bending_moment_y": -F * (L - x_mid), "shear_force_z": F}),
             ((0.0, F, 0.0), (0.0, 0.0, 0.0), {"bending_moment_z": F * (L - x_mid), "shear_force_y": F}),
             ((F, 0.0, 0.0), (0.0, 0.0, 0.0), {"axial_force": F}),
             ((0.0, 0.0, 0.0), (F, 0.0, 0.0), {"torsion_moment": F})]
    for k, (force, moment, expected) in enumerate(cases):
        model, static = cantilever(force, moment, n=n, L=L)
        (pvd,) = static.to_vtk(tmp_path / str(k), model)
        mesh = meshio.read(tmp_path / str(k) / pvd_entries(pvd)[0][1])
        assert set(pf.vtk.SECTION_FORCES) <= set(mesh.cell_data)
        for name in pf.vtk.SECTION_FORCES:
            value = mesh.cell_data[name][0]
            # the tip deflects by ~1e-4 L: the moments' lever arms change by that much
            np.testing.assert_allclose(value, np.broadcast_to(expected.get(name, 0.0), (n,)), rtol=1e-3,
                                       atol=1e-3 * F * L, err_msg=name)


def test_section_forces_in_a_transient_and_nan_on_ancf(tmp_path, meter_run):
    model, res = meter_run
    (pvd,) = res.to_vtk(tmp_path, model)
    mesh = meshio.read(tmp_path / pvd_entries(pvd)[-1][1])
    forces = np.array([mesh.cell_data[name][0] for name in pf.vtk.SECTION_FORCES])
    assert forces.shape == (6, len(model.elements)) and np.all(np.isfinite(forces))
    assert np.abs(forces[2:4]).max() > 0  # the drive bends the legs
    beam = pf.scenes.rotating_cantilever(n_elements=3, omega=2.0, spin_up_time=1.0)
    (pvd,) = pf.simulate(beam, 0.05, n_outputs=2).to_vtk(tmp_path / "ancf", beam)
    mesh = meshio.read(tmp_path / "ancf" / pvd_entries(pvd)[-1][1])
    assert all(np.all(np.isnan(mesh.cell_data[name][0])) for name in pf.vtk.SECTION_FORCES)


def test_tube_radius_from_the_section(tmp_path):
    """PipeSection.tube records its outer diameter; to_vtk draws the tube with it when
    radius= is not given; a section without one falls back to 2 % of the model's size."""
    model, static = cantilever((0.0, 0.0, 1.0))
    assert model.elements[0].section.outer_diameter == 0.06
    paths = static.to_vtk(tmp_path, model, tube=True, n_sides=6)
    tube = meshio.read(tmp_path / pvd_entries(paths[1])[0][1])
    ends = static.state.q.reshape(-1, 6)[:, :3][np.repeat(np.array([e.nodes for e in model.elements]), 6,
                                                            axis=1).ravel()]
    np.testing.assert_allclose(np.linalg.norm(tube.points - ends, axis=1), 0.03, rtol=1e-12)
    with pytest.raises(ValueError, match="outer_diameter"):
        pf.PipeSection(EI=1.0, pipe_mass=1.0, outer_diameter=-0.1)
