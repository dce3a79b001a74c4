"""VTK export: parse the written XML back and check counts, connectivity and point data."""

from __future__ import annotations

import base64
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from knotsim.errors import ConfigError
from knotsim.io.trajectory import TrajectoryWriter, read_trajectory
from knotsim.io.vtk import export_vtk, node_curvature, node_twist
from knotsim.runspec import RunSpec, run

R_RING = 0.05  # ring centreline radius (m)
N_RING = 64
N_ROPE = 11
ROPE_LEN = 0.2
TWIST_RATE = 3.0  # rad/m along the rope
RADII = [0.004, 0.002]  # rope, ring (m)
DTYPES = {"Float64": "<f8", "Float32": "<f4", "Int64": "<i8", "Int32": "<i4", "UInt8": "u1"}


def _geometry(k):
    x = np.linspace(0.0, ROPE_LEN, N_ROPE)
    rope = np.column_stack([x, np.zeros_like(x), np.full_like(x, 0.01 * k)])
    mid = 0.5 * (x[:-1] + x[1:])
    rope_angles = TWIST_RATE * mid  # edge angle grows linearly along the rope
    s = 2 * np.pi * np.arange(N_RING) / N_RING
    ring = np.column_stack([R_RING * np.cos(s), R_RING * np.sin(s), np.zeros_like(s)])
    return np.vstack([rope, ring]), np.concatenate([rope_angles, np.zeros(N_RING)])


@pytest.fixture
def traj_path(tmp_path):
    path = tmp_path / "run" / "trajectory.h5"
    path.parent.mkdir()
    with TrajectoryWriter(
        path,
        [0, N_ROPE, N_ROPE + N_RING],
        [0, N_ROPE - 1, N_ROPE - 1 + N_RING],
        [False, True],
        RADII,
        ["rope", "ring"],
    ) as w:
        for k in range(5):
            pos, ang = _geometry(k)
            w.append(0.25 * k, pos, ang)
    return path


def _decode(da):
    dtype = np.dtype(DTYPES[da.get("type")])
    if da.get("format") == "ascii":
        return np.array(da.text.split(), dtype=dtype)
    raw = base64.b64decode(da.text)
    nbytes = int(np.frombuffer(raw[:8], dtype="<u8")[0])
    assert nbytes == len(raw) - 8
    return np.frombuffer(raw[8:], dtype=dtype)


def _parse(path):
    root = ET.parse(path).getroot()
    assert root.get("type") == "PolyData"
    piece = root.find("PolyData/Piece")
    arrays = {da.get("Name"): _decode(da) for da in piece.find("PointData")}
    return root, piece, arrays


@pytest.mark.parametrize("encoding", ["ascii", "binary"])
def test_vtp_content(traj_path, tmp_path, encoding):
    paths = export_vtk(traj_path, tmp_path / "vtk", encoding=encoding)
    assert [p.name for p in paths] == [f"trajectory_{k:06d}.vtp" for k in range(5)]
    root, piece, pd = _parse(paths[3])
    n = N_ROPE + N_RING
    assert piece.get("NumberOfPoints") == str(n) and piece.get("NumberOfLines") == "2"
    time = root.find("PolyData/FieldData/DataArray")
    assert time.get("Name") == "TimeValue" and float(time.text) == pytest.approx(0.75)
    pts = _decode(piece.find("Points/DataArray")).reshape(-1, 3)
    np.testing.assert_array_equal(pts, _geometry(3)[0])
    lines = {da.get("Name"): _decode(da) for da in piece.find("Lines")}
    # open rope: 0..10; ring closed by repeating its first node
    np.testing.assert_array_equal(lines["offsets"], [N_ROPE, n + 1])
    conn = lines["connectivity"]
    np.testing.assert_array_equal(conn[:N_ROPE], np.arange(N_ROPE))
    np.testing.assert_array_equal(conn[N_ROPE:], np.append(np.arange(N_ROPE, n), N_ROPE))
    assert set(pd) == {"radius", "twist", "bending_strain", "rod_id"}
    np.testing.assert_array_equal(pd["rod_id"], [0] * N_ROPE + [1] * N_RING)
    np.testing.assert_array_equal(pd["radius"], [RADII[0]] * N_ROPE + [RADII[1]] * N_RING)
    # straight rope: no bending; uniform twist at interior nodes, zero at the two ends
    np.testing.assert_allclose(pd["bending_strain"][:N_ROPE], 0.0, atol=1e-12)
    np.testing.assert_allclose(pd["twist"][1 : N_ROPE - 1], TWIST_RATE, rtol=1e-9)
    assert pd["twist"][0] == 0.0 and pd["twist"][N_ROPE - 1] == 0.0
    # ring: curvature 1/R (discrete value converges as N grows), no twist
    np.testing.assert_allclose(pd["bending_strain"][N_ROPE:], RADII[1] / R_RING, rtol=2e-3)
    np.testing.assert_allclose(pd["twist"][N_ROPE:], 0.0, atol=1e-12)
    cells = {da.get("Name"): _decode(da) for da in piece.find("CellData")}
    np.testing.assert_array_equal(cells["rod_id"], [0, 1])


def test_pvd_and_every(traj_path, tmp_path):
    out = tmp_path / "vtk"
    paths = export_vtk(read_trajectory(traj_path), out, every=2, name="knot")
    assert [p.name for p in paths] == ["knot_000000.vtp", "knot_000002.vtp", "knot_000004.vtp"]
    root = ET.parse(out / "knot.pvd").getroot()
    assert root.get("type") == "Collection"
    ds = root.findall("Collection/DataSet")
    assert [d.get("file") for d in ds] == [p.name for p in paths]
    np.testing.assert_allclose([float(d.get("timestep")) for d in ds], [0.0, 0.5, 1.0])
    # a run directory works too, and ascii / binary carry the same values
    export_vtk(traj_path.parent, tmp_path / "a", every=2, encoding="ascii")
    _, _, a = _parse(tmp_path / "a" / "trajectory_000002.vtp")
    _, _, b = _parse(paths[1])
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])


def test_discrete_formulas():
    # right angle at the middle node, edges of length 1: kappa = 2 tan(pi/4) / 1 = 2
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0]])
    np.testing.assert_allclose(node_curvature(pts, closed=False), [0.0, 2.0, 0.0])
    # twist uses the Voronoi length (|e0| + |e1|) / 2 = 1.5
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [3, 0, 0]])
    np.testing.assert_allclose(node_twist(pts, [0.0, 0.3], closed=False), [0.0, 0.2, 0.0])
    with pytest.raises(ConfigError):
        node_twist(pts, [0.0, 0.3, 0.1], closed=False)


def test_bad_arguments(traj_path, tmp_path):
    with pytest.raises(ConfigError):
        export_vtk(traj_path, tmp_path, every=0)
    with pytest.raises(ConfigError):
        export_vtk(traj_path, tmp_path, encoding="raw")
    with pytest.raises(FileNotFoundError):
        export_vtk(tmp_path / "nothing.h5", tmp_path)


def test_readable_by_vtk(traj_path, tmp_path):
    pv = pytest.importorskip("pyvista")
    paths = export_vtk(traj_path, tmp_path / "vtk")
    mesh = pv.read(paths[1])
    assert mesh.n_points == N_ROPE + N_RING and mesh.n_lines == 2
    np.testing.assert_allclose(mesh.points, _geometry(1)[0])
    np.testing.assert_allclose(mesh.point_data["twist"][1 : N_ROPE - 1], TWIST_RATE)


def test_twist_includes_reference_twist():
    # open rod: node i gets theta_i - theta_{i-1} + ref[i-1] over the rest Voronoi length
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [3, 0, 0], [4, 0, 0]])
    th = np.array([0.0, 0.3, 0.1])
    ref = np.array([0.05, -0.2])
    rest = np.array([1.0, 1.0, 3.0])
    np.testing.assert_allclose(node_twist(pts, th, False, ref, rest), [0.0, 0.35 / 1.0, -0.4 / 2.0, 0.0])
    # without the rest lengths: the current Voronoi lengths (1.5 and 1.5)
    np.testing.assert_allclose(node_twist(pts, th, False, ref), [0.0, 0.35 / 1.5, -0.4 / 1.5, 0.0])
    # closed rod: stencil s is node s, between edges s-1 and s
    ring = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    th = np.array([0.1, 0.2, 0.4, 0.8])
    ref = np.array([0.01, 0.02, 0.03, 0.04])
    expect = (th - np.roll(th, 1) + ref) / 1.0
    np.testing.assert_allclose(node_twist(ring, th, True, ref, np.ones(4)), expect)
    with pytest.raises(ConfigError, match="reference_twist"):
        node_twist(ring, th, True, ref[:3])
    with pytest.raises(ConfigError, match="rest_edge_length"):
        node_twist(ring, th, True, ref, np.ones(3))


@pytest.fixture(scope="module")
def twisted_run(tmp_path_factory):
    """examples/twist_end.toml shortened to 0.2 s, its rod wound as a one-turn helix and under
    gravity: one end turned at 1 turn/s while the coil sags, so the reference frames, transported
    in time, carry a reference twist (a straight rod's stays 0)."""
    example = Path(__file__).resolve().parents[2] / "examples" / "twist_end.toml"
    out = tmp_path_factory.mktemp("twist") / "run"
    spec = RunSpec.load(example)
    rod = {k: v for k, v in spec.data["rods"][0].items() if k not in ("length", "direction")}
    rod.update(shape="helix", helix_radius=0.02, pitch=0.04, turns=1.0, n_nodes=31)
    result = run(spec.with_changes(rods=[rod], model={"damping": 0.01, "gravity": [0.0, 0.0, -9.81]},
                                   run={"duration": 0.2, "output_interval": 0.04}), out, progress=False)
    return out, result


def test_vtk_twist_gives_the_logged_twisting_energy(twisted_run, tmp_path):
    out, result = twisted_run
    model = result.simulation.model
    log = result.log
    traj = read_trajectory(out / "trajectory.h5")
    paths = export_vtk(out, tmp_path / "vtk")
    assert len(paths) == traj.n_frames >= 5
    b = model.bend_node  # the rod's interior nodes, in stencil order
    assert np.max(np.abs(traj.state["reference_twist"][-1])) > 0.01  # rad: the case this test is about
    checked = 0
    for k, path in enumerate(paths):
        if traj.time[k] == 0.0:
            continue  # the initial frame has no log row
        twist = _parse(path)[2]["twist"]
        energy = 0.5 * np.sum(model.twist_GJ * model.voronoi_rest * (twist[b] - model.twist_bar / model.voronoi_rest) ** 2)
        row = log.iloc[int(np.argmin(np.abs(log["time"].to_numpy() - traj.time[k])))]
        assert row["energy_twisting"] > 1e-9  # the rod is twisted
        assert energy == pytest.approx(row["energy_twisting"], rel=1e-9)
        # negative control: the edge-angle difference alone misses the reference twist
        bare = node_twist(traj.positions[k], traj.edge_angles[k], False, None, traj.state["rest_edge_length"])
        wrong = 0.5 * np.sum(model.twist_GJ * model.voronoi_rest * bare[b] ** 2)
        assert abs(wrong - row["energy_twisting"]) > 0.01 * row["energy_twisting"]
        checked += 1
    assert checked >= 4


def test_edge_strain_and_tension_give_the_logged_stretching_energy(twisted_run):
    out, result = twisted_run
    model = result.simulation.model
    traj = read_trajectory(out / "trajectory.h5")
    assert traj.units["edge_tension"] == "N" and traj.units["edge_strain"] == "1"
    assert "contact_force" not in traj.fields  # no contact in this run
    strain, tension = traj.fields["edge_strain"][-1], traj.fields["edge_tension"][-1]
    np.testing.assert_array_equal(tension, model.edge_EA * strain)
    stretch = 0.5 * np.sum(model.edge_EA * strain**2 * model.rest_length)
    assert stretch == pytest.approx(result.log["energy_stretching"].iloc[-1], rel=1e-9)
    assert np.max(np.abs(strain)) > 0


def test_contact_force_per_node_matches_the_logged_total(tmp_path):
    example = Path(__file__).resolve().parents[2] / "examples" / "crossing_rods.toml"
    spec = RunSpec.load(example)
    result = run(spec.with_changes(run={"duration": 0.15, "output_interval": 0.05}), tmp_path / "run",
                    progress=False)
    traj = read_trajectory(tmp_path / "run" / "trajectory.h5")
    assert traj.units["contact_force"] == "N"
    fc, ff = traj.fields["contact_force"], traj.fields["friction_force"]
    assert fc.shape == ff.shape == (traj.n_frames, traj.n_nodes)
    assert np.all(np.isnan(fc[0]))  # written before the first step
    log = result.log
    for k in range(1, traj.n_frames):
        row = log.iloc[int(np.argmin(np.abs(log["time"].to_numpy() - traj.time[k])))]
        assert 0.5 * fc[k].sum() == pytest.approx(row["contact_force_total"], rel=1e-12, abs=1e-300)
        assert 0.5 * ff[k].sum() == pytest.approx(row["friction_force_total"], rel=1e-12, abs=1e-300)
    assert row["contact_force_total"] > 0  # B is pressed onto A by the end
    # the loaded nodes are those near the crossing (the middles of A and B)
    mid_a, mid_b = 7, 16 + 7
    assert set(np.argsort(fc[-1])[-2:]) & {mid_a, mid_a + 1, mid_b, mid_b + 1}
