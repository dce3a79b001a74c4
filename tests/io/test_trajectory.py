"""Trajectory HDF5 writer/reader: round trip, frame selection, killed runs, clear errors."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap

import h5py
import numpy as np
import pytest

from knotsim.errors import ConfigError
from knotsim.io.trajectory import TrajectoryWriter, read_trajectory

# two rods: an open one with 5 nodes (4 edges) and a ring with 4 nodes (4 edges)
LAYOUT = dict(
    rod_node_start=[0, 5, 9],
    rod_edge_start=[0, 4, 8],
    rod_closed=[False, True],
    rod_radius=[0.01, 0.02],
    rod_names=["rope", "ring"],
)


def _frames(n, seed=0):
    rng = np.random.default_rng(seed)
    return 0.05 * np.arange(n), rng.normal(size=(n, 9, 3)), rng.normal(size=(n, 8))


def _write(path, n, chunk_frames=4):
    times, pos, ang = _frames(n)
    with TrajectoryWriter(path, **LAYOUT, chunk_frames=chunk_frames) as w:
        for k in range(n):
            assert w.append(times[k], pos[k], ang[k]) == k
        assert w.n_frames == n
    return times, pos, ang


def test_round_trip(tmp_path):
    path = tmp_path / "trajectory.h5"
    times, pos, ang = _write(path, 10)
    tr = read_trajectory(path)
    assert tr.n_frames == 10 and tr.n_rods == 2 and tr.n_nodes == 9 and tr.n_edges == 8
    np.testing.assert_array_equal(tr.time, times)
    np.testing.assert_array_equal(tr.positions, pos)
    np.testing.assert_array_equal(tr.edge_angles, ang)
    np.testing.assert_array_equal(tr.rod_closed, [False, True])
    np.testing.assert_array_equal(tr.rod_radius, [0.01, 0.02])
    assert tr.rod_names == ["rope", "ring"]
    assert tr.attrs["knotsim_version"] and tr.attrs["created"]
    np.testing.assert_array_equal(tr.rod_positions(3, "ring"), pos[3, 5:9])
    np.testing.assert_array_equal(tr.rod_positions(-1, 0), pos[9, 0:5])
    np.testing.assert_array_equal(tr.rod_edge_angles(2, 1), ang[2, 4:8])
    assert [c.shape for c in tr.centerlines(0)] == [(5, 3), (4, 3)]
    # nearest frame, clamped at both ends, ties to the earlier frame
    assert tr.frame_at_time(0.14) == 3
    assert tr.frame_at_time(0.125) == 2
    assert tr.frame_at_time(-1.0) == 0
    assert tr.frame_at_time(99.0) == 9
    with h5py.File(path) as f:  # layout of docs/architecture.md
        assert f["positions"].chunks[0] == 4
        assert f["rod_node_start"].dtype == np.int64 and f["rod_closed"].dtype == bool


def test_frame_selection_and_lazy(tmp_path):
    path = tmp_path / "trajectory.h5"
    times, pos, ang = _write(path, 10)
    tr = read_trajectory(path, frames=[7, 2, -1])
    np.testing.assert_array_equal(tr.frame_indices, [7, 2, 9])
    np.testing.assert_array_equal(tr.positions, pos[[7, 2, 9]])
    np.testing.assert_array_equal(tr.time, times[[7, 2, 9]])
    tr = read_trajectory(path, frames=slice(1, None, 3))
    np.testing.assert_array_equal(tr.frame_indices, [1, 4, 7])
    np.testing.assert_array_equal(tr.edge_angles, ang[[1, 4, 7]])
    assert read_trajectory(path, frames=-1).n_frames == 1
    with read_trajectory(path, frames=slice(None, None, 2), lazy=True) as lz:
        assert lz.n_frames == 5 and lz.positions.shape == (5, 9, 3)
        np.testing.assert_array_equal(lz.positions[1], pos[2])
        np.testing.assert_array_equal(lz.positions[[3, 0]], pos[[6, 0]])
        np.testing.assert_array_equal(lz.edge_angles[-1, 4:], ang[8, 4:])
        np.testing.assert_array_equal(np.asarray(lz.positions), pos[::2])
        np.testing.assert_array_equal(lz.rod_positions(2, "rope"), pos[4, :5])
    with pytest.raises(ConfigError):
        read_trajectory(path, frames=[10])
    with pytest.raises(ConfigError):
        read_trajectory(path, frames="last")


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs POSIX signals")
def test_killed_run_is_readable(tmp_path):
    """A writer killed without close() leaves every flushed frame readable."""
    path = tmp_path / "trajectory.h5"
    code = textwrap.dedent(
        f"""
        import os, signal
        import numpy as np
        from knotsim.io.trajectory import TrajectoryWriter
        w = TrajectoryWriter({str(path)!r}, [0, 5, 9], [0, 4, 8], [False, True], [0.01, 0.02],
                             ["rope", "ring"], chunk_frames=4)
        for k in range(7):
            w.append(0.1 * k, np.full((9, 3), float(k)), np.full(8, -float(k)))
        os.kill(os.getpid(), signal.SIGKILL)
        """
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    assert proc.returncode == -signal.SIGKILL, proc.stderr.decode()
    tr = read_trajectory(path)
    assert tr.n_frames == 7
    np.testing.assert_allclose(tr.time, 0.1 * np.arange(7))
    np.testing.assert_array_equal(tr.positions[:, 0, 0], np.arange(7.0))
    np.testing.assert_array_equal(tr.edge_angles[:, -1], -np.arange(7.0))


def test_incomplete_last_frame_is_dropped(tmp_path):
    path = tmp_path / "trajectory.h5"
    _write(path, 3)
    with h5py.File(path, "a") as f:  # as if killed after positions grew but before time was written
        f["positions"].resize(4, axis=0)
        f["edge_angles"].resize(4, axis=0)
        f["time"].resize(4, axis=0)
    assert read_trajectory(path).n_frames == 3


def test_writer_validation(tmp_path):
    path = tmp_path / "t.h5"
    bad = dict(LAYOUT, rod_edge_start=[0, 5, 9])  # open rod with 5 nodes has 4 edges
    with pytest.raises(ConfigError, match="rod_edge_start"):
        TrajectoryWriter(path, **bad)
    with pytest.raises(ConfigError, match="rod_radius"):
        TrajectoryWriter(path, **dict(LAYOUT, rod_radius=[0.01, -1.0]))
    with pytest.raises(ConfigError, match="rod_names"):
        TrajectoryWriter(path, **dict(LAYOUT, rod_names=["a"]))
    with TrajectoryWriter(path, **LAYOUT) as w:
        with pytest.raises(ConfigError, match="positions"):
            w.append(0.0, np.zeros((8, 3)), np.zeros(8))
        with pytest.raises(ConfigError, match="edge_angles"):
            w.append(0.0, np.zeros((9, 3)), np.zeros(9))
        w.append(1.0, np.zeros((9, 3)), np.zeros(8))
        with pytest.raises(ConfigError, match="time"):
            w.append(0.5, np.zeros((9, 3)), np.zeros(8))
    assert w.closed
    with pytest.raises(ConfigError):
        w.append(2.0, np.zeros((9, 3)), np.zeros(8))
    assert read_trajectory(path).n_frames == 1


def test_reader_errors(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_trajectory(tmp_path / "missing.h5")
    junk = tmp_path / "junk.h5"
    junk.write_text("not hdf5")
    with pytest.raises(ConfigError, match="HDF5"):
        read_trajectory(junk)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["positions"] = np.zeros((1, 2, 3))
    with pytest.raises(ConfigError, match="not a knotsim trajectory"):
        read_trajectory(other)


def test_empty_trajectory(tmp_path):
    path = tmp_path / "trajectory.h5"
    TrajectoryWriter(path, **LAYOUT).close()
    tr = read_trajectory(path)
    assert tr.n_frames == 0 and tr.positions.shape == (0, 9, 3)
    with pytest.raises(ConfigError):
        tr.frame_at_time(0.0)


def test_every_dataset_has_units_and_derived_fields_round_trip(tmp_path):
    from knotsim.io.trajectory import DATASETS

    path = tmp_path / "trajectory.h5"
    times, pos, ang = _frames(3)
    rng = np.random.default_rng(1)
    extra = [{"velocities": rng.normal(size=(9, 3)), "reference_directors": rng.normal(size=(8, 3)),
              "reference_twist": rng.normal(size=3), "edge_strain": rng.normal(size=8),
              "edge_tension": rng.normal(size=8), "contact_force": rng.random(9),
              "friction_force": rng.random(9), "slip_speed": rng.random(9), "rolling_speed": rng.random(9)}
             for _ in range(3)]
    # 3 bending stencils: the open rope has 3 interior nodes (the ring's 4 are left out here)
    with TrajectoryWriter(path, **LAYOUT, n_bend=3, rest_edge_length=np.full(8, 0.1),
                          fields=["edge_strain", "edge_tension", "contact_force", "friction_force", "slip_speed",
                                  "rolling_speed"]) as w:
        for k in range(3):
            w.append(times[k], pos[k], ang[k], extra[k])
    with h5py.File(path, "r") as f:
        names = set(f)
        assert names == set(DATASETS)  # every known dataset is written here, and none other
        for key in f:
            assert f[key].attrs["units"] == DATASETS[key][0] and f[key].attrs["description"]
    assert DATASETS["positions"][0] == "m" and DATASETS["velocities"][0] == "m/s"
    for lazy in (False, True):
        with read_trajectory(path, frames=[0, 2], lazy=lazy) as tr:
            assert tr.units["edge_tension"] == "N" and tr.units["time"] == "s"
            np.testing.assert_array_equal(tr.fields["edge_tension"][1], extra[2]["edge_tension"])
            np.testing.assert_array_equal(tr.fields["contact_force"][0], extra[0]["contact_force"])
            np.testing.assert_array_equal(tr.state["reference_twist"][1], extra[2]["reference_twist"])
            np.testing.assert_array_equal(tr.state["rest_edge_length"], np.full(8, 0.1))
            assert np.asarray(tr.fields["edge_strain"]).shape == (2, 8)
    with pytest.raises(ConfigError, match="edge_stress"):
        TrajectoryWriter(tmp_path / "x.h5", **LAYOUT, fields=["edge_stress"])
    with pytest.raises(ConfigError, match="rest_edge_length"):
        TrajectoryWriter(tmp_path / "y.h5", **LAYOUT, rest_edge_length=np.ones(5))
    with TrajectoryWriter(tmp_path / "z.h5", **LAYOUT, fields=["edge_strain"]) as w, \
            pytest.raises(ConfigError, match="edge_strain"):
        w.append(0.0, pos[0], ang[0])
