"""VTK export: parse the written XML back and check counts, connectivity and point data."""

from __future__ import annotations

import base64
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from knotsim.errors import ConfigError
from knotsim.io.trajectory import TrajectoryWriter, read_trajectory
from knotsim.io.vtk import export_vtk, node_curvature, node_twist

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
