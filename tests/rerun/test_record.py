"""Tests of :mod:`ftc_mj.rerun.record` (and :mod:`ftc_mj.rerun.read`): a synthetic 40 s run is written and read
back with RrdReader."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
import rerun as rr
from rerun.chunk import RrdReader

from ftc_mj.rerun.blueprint import _motion_tabs
from ftc_mj.rerun.read import read_scalar_series
from ftc_mj.rerun.record import REQUIRED_COLUMNS, write_rrd
from ftc_mj.telemetry import Event, RobotGeometry, Solve
from tests.support.synthetic import scalar_series, synthetic_run

N_MODES = 3
DURATION = 40.0


@pytest.fixture(scope="module")
def run_data() -> tuple[dict[str, np.ndarray], list[Solve], list[Event], np.ndarray]:
    return synthetic_run(DURATION, n_modes=N_MODES, seed=1)


@pytest.fixture(scope="module")
def rrd(tmp_path_factory: pytest.TempPathFactory, run_data: tuple) -> Path:
    trace, solves, events, ref = run_data
    path = tmp_path_factory.mktemp("rec") / "run.rrd"
    was_strict = rr.strict_mode()
    rr.set_strict_mode(True)   # any bad log call raises instead of warning
    try:
        write_rrd(path, trace, run_id="test-run-1", solves=solves, events=events, reference_path=ref,
                  geometry=RobotGeometry(), omega_max=17.4533, n_modes=N_MODES)
    finally:
        rr.set_strict_mode(was_strict)
    return path


@pytest.fixture(scope="module")
def chunks(rrd: Path) -> list:
    return RrdReader(str(rrd)).stream().to_chunks()


def _batches(chunks: list, entity: str) -> list[pa.RecordBatch]:
    return [c.to_record_batch() for c in chunks if str(c.entity_path) == entity and not c.is_static]


def _column(chunks: list, entity: str, column: str) -> tuple[np.ndarray, list]:
    """(sim_time ns, values as python lists) of one component over all non-static chunks, time-sorted."""
    ts, vs = [], []
    for rb in _batches(chunks, entity):
        ts.append(rb.column("sim_time").cast(pa.int64()).to_numpy(zero_copy_only=False))
        vs.extend(rb.column(column).to_pylist())
    assert ts, f"no data for {entity}"
    t = np.concatenate(ts)
    order = np.argsort(t, kind="stable")
    return t[order], [vs[i] for i in order]


SCALAR_ENTITIES = [
    "/radius/right/truth", "/radius/right/estimate", "/radius/right/upper", "/radius/right/lower",
    "/radius/left/truth", "/radius/left/estimate", "/radius/left/upper", "/radius/left/lower",
    "/innovation/value", "/innovation/upper", "/innovation/lower",
    "/wheel_rate/right/measured", "/wheel_rate/right/command",
    "/wheel_rate/left/measured", "/wheel_rate/left/command",
    "/tracking/cross_track_error", "/speed/truth", "/speed/measured",
]
OTHER_ENTITIES = [
    "/world/reference", "/world/path", "/world/robot", "/world/robot/chassis",
    "/world/robot/wheel_right", "/world/robot/wheel_left", "/world/prediction",
    "/wheel_rate/limits", "/solver/solve_time_ms", "/solver/iterations", "/solver/status", "/events",
]


def _expected(trace: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    e = scalar_series(trace)
    e.update({"/reconfiguration/state": trace["reconfig_state"], "/radius/right/model": trace["R_R_model"],
              "/radius/left/model": trace["R_L_model"]})
    assert [k for k in e if k.startswith("/imm/")] == [f"/imm/mode_prob_{k}" for k in range(1, N_MODES + 1)]
    return e


def test_all_entities_present(chunks: list) -> None:
    present = {str(c.entity_path) for c in chunks}
    wanted = SCALAR_ENTITIES + OTHER_ENTITIES + [f"/imm/mode_prob_{k}" for k in range(1, N_MODES + 1)]
    missing = [e for e in wanted if e not in present]
    assert not missing, missing


def test_recording_identity_and_blueprint(rrd: Path) -> None:
    rd = RrdReader(str(rrd))
    recs = rd.recordings()
    assert len(recs) == 1
    assert recs[0].application_id == "ftc-mj" and recs[0].recording_id == "test-run-1"
    assert len(rd.blueprints()) >= 1


def test_scalar_series_round_trip(rrd: Path, run_data: tuple) -> None:
    trace = run_data[0]
    for entity, want in _expected(trace).items():
        t, v = read_scalar_series(rrd, entity)
        assert len(t) == len(trace["t"]), entity
        np.testing.assert_allclose(t, trace["t"], rtol=0, atol=1e-9, err_msg=entity)
        np.testing.assert_allclose(v, want, rtol=0, atol=1e-12, err_msg=entity)


def test_time_columns_are_integer_ns_and_steps(chunks: list, run_data: tuple) -> None:
    trace = run_data[0]
    rb = _batches(chunks, "/radius/right/estimate")[0]
    assert rb.schema.field("sim_time").type == pa.duration("ns")
    t_ns = rb.column("sim_time").cast(pa.int64()).to_numpy()
    np.testing.assert_array_equal(t_ns, np.round(trace["t"] * 1e9).astype(np.int64))
    np.testing.assert_array_equal(rb.column("step").to_numpy(), np.arange(len(trace["t"])))


def test_robot_transform(chunks: list, run_data: tuple) -> None:
    trace = run_data[0]
    t, tr = _column(chunks, "/world/robot", "Transform3D:translation")
    assert len(t) == len(trace["t"])
    p = np.array([row[0] for row in tr])
    np.testing.assert_allclose(p[:, 0], trace["x"], atol=1e-4)
    np.testing.assert_allclose(p[:, 1], trace["y"], atol=1e-4)
    np.testing.assert_allclose(p[:, 2], trace["z"], atol=1e-5)
    _, q = _column(chunks, "/world/robot", "Transform3D:quaternion")
    q = np.array([row[0] for row in q])
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-6)
    # yaw from the quaternion (xyzw), ZYX convention
    yaw = np.arctan2(2 * (q[:, 3] * q[:, 2] + q[:, 0] * q[:, 1]), 1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2))
    dpsi = np.angle(np.exp(1j * (yaw - trace["psi"])))
    assert np.max(np.abs(dpsi)) < 1e-5


@pytest.mark.parametrize(("side", "col"), [("right", "R_R"), ("left", "R_L")])
def test_wheel_cylinders_follow_true_radii(chunks: list, run_data: tuple, side: str, col: str) -> None:
    trace = run_data[0]
    t_ns, radii = _column(chunks, f"/world/robot/wheel_{side}", "Cylinders3D:radii")
    r = np.array([row[0] for row in radii])
    rows = np.searchsorted(np.round(trace["t"] * 1e9).astype(np.int64), t_ns)
    # logged values are the true radius at the logged rows (float32 component)
    np.testing.assert_allclose(r, trace[col][rows], rtol=1e-6)
    assert t_ns[0] == 0 and rows[-1] == len(trace["t"]) - 1
    assert len(r) <= len(trace["t"]) // 10 + 2          # reduced rate
    # latest-at value stays within the 0.1 s rate limit + 0.1 mm of the truth at every trace row
    at = np.searchsorted(t_ns, np.round(trace["t"] * 1e9).astype(np.int64), side="right") - 1
    dr_max = np.max(np.abs(np.diff(trace[col]))) * 10 + 1e-4 + 1e-6
    assert np.max(np.abs(r[at] - trace[col])) <= dr_max


def test_deflating_wheel_is_drawn_smaller(chunks: list) -> None:
    _, radii = _column(chunks, "/world/robot/wheel_right", "Cylinders3D:radii")
    assert radii[0][0] == pytest.approx(2.0) and radii[-1][0] == pytest.approx(1.0)
    _, radii_l = _column(chunks, "/world/robot/wheel_left", "Cylinders3D:radii")
    assert len(radii_l) == 2     # constant radius: first and last row only


def test_solver_series_only_at_solves(rrd: Path, run_data: tuple) -> None:
    solves = run_data[1]
    t, v = read_scalar_series(rrd, "/solver/solve_time_ms")
    np.testing.assert_allclose(t, [s.t for s in solves], atol=1e-9)
    np.testing.assert_allclose(v, [s.solve_time_ms for s in solves], atol=1e-12)
    _, it = read_scalar_series(rrd, "/solver/iterations")
    np.testing.assert_array_equal(it, [s.iterations for s in solves])
    _, st = read_scalar_series(rrd, "/solver/status")
    assert set(np.unique(st)) <= {0.0, 0.5, 1.0}
    assert np.sum(st < 1) == sum(not s.ok for s in solves) >= 1


def test_prediction_strips(chunks: list, run_data: tuple) -> None:
    solves = run_data[1]
    t_ns, strips = _column(chunks, "/world/prediction", "LineStrips3D:strips")
    assert len(strips) == len(solves)
    first = np.array(strips[0][0])
    np.testing.assert_allclose(first[:, :2], solves[0].predicted[:, :2], atol=1e-4)
    np.testing.assert_array_equal(t_ns, np.round(np.array([s.t for s in solves]) * 1e9).astype(np.int64))


def test_path_and_limits(chunks: list, run_data: tuple, rrd: Path) -> None:
    trace = run_data[0]
    _, strips = _column(chunks, "/world/path", "LineStrips3D:strips")
    assert 70 <= len(strips) <= 90                       # 2 Hz over 40 s
    last = np.array(strips[-1][0])
    assert last[-1, 0] == pytest.approx(trace["x"][-1], abs=1e-4)
    assert last[-1, 1] == pytest.approx(trace["y"][-1], abs=1e-4)
    _, lim = read_scalar_series(rrd, "/wheel_rate/limits")
    np.testing.assert_allclose(lim, [[17.4533, -17.4533]] * 2)
    ref = [c for c in chunks if str(c.entity_path) == "/world/reference"]
    assert ref and all(c.is_static for c in ref)


def test_events_text(chunks: list, run_data: tuple) -> None:
    events = run_data[2]
    _, texts = _column(chunks, "/events", "TextLog:text")
    _, levels = _column(chunks, "/events", "TextLog:level")
    texts = [x[0] for x in texts]
    for e in events:
        assert e.text in texts
    assert any("NMPC solve failed" in x for x in texts)      # added from the failed solve
    assert "WARN" in [x[0] for x in levels] and "INFO" in [x[0] for x in levels]


def test_atomic_write_leaves_no_tmp(rrd: Path) -> None:
    assert rrd.exists()
    assert not [p for p in rrd.parent.iterdir() if p.name.endswith(".tmp")]


def test_failing_write_leaves_no_file(tmp_path: Path, run_data: tuple, monkeypatch: pytest.MonkeyPatch) -> None:
    trace, solves, events, ref = run_data
    target = tmp_path / "run.rrd"
    calls = {"n": 0}
    real = rr.RecordingStream.send_columns

    def failing(self: rr.RecordingStream, *a: object, **k: object) -> None:
        calls["n"] += 1
        if calls["n"] == 5:
            raise RuntimeError("disk on fire")
        real(self, *a, **k)

    monkeypatch.setattr(rr.RecordingStream, "send_columns", failing)
    with pytest.raises(RuntimeError, match="disk on fire"):
        write_rrd(target, trace, run_id="fail", solves=solves, events=events, reference_path=ref)
    assert calls["n"] == 5
    assert list(tmp_path.iterdir()) == []
    # an existing final file is left untouched by a failed rewrite
    target.write_bytes(b"old")
    calls["n"] = 0
    with pytest.raises(RuntimeError):
        write_rrd(target, trace, run_id="fail", solves=solves, events=events, reference_path=ref)
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["run.rrd"]


def test_bad_trace_raises_and_writes_nothing(tmp_path: Path, run_data: tuple) -> None:
    trace = dict(run_data[0])
    del trace["R_R_hat"]
    with pytest.raises(ValueError, match="R_R_hat"):
        write_rrd(tmp_path / "a.rrd", trace, run_id="bad")
    trace = dict(run_data[0])
    trace["v"] = trace["v"][:-1]
    with pytest.raises(ValueError, match="unequal"):
        write_rrd(tmp_path / "b.rrd", trace, run_id="bad")
    assert list(tmp_path.iterdir()) == []


def test_solver_from_trace_columns_minimal_run(tmp_path: Path) -> None:
    """No solves list, no optional columns, no IMM: solver series come from the trace's solve rows."""
    trace, _, _, _ = synthetic_run(5.0, n_modes=0)
    keep = set(REQUIRED_COLUMNS) | {"solve_time_ms", "solver_iterations", "solver_ok"}
    trace = {k: v for k, v in trace.items() if k in keep}
    path = tmp_path / "min.rrd"
    write_rrd(path, trace, run_id="min")
    rows = np.flatnonzero(np.isfinite(trace["solve_time_ms"]))
    t, v = read_scalar_series(path, "/solver/solve_time_ms")
    np.testing.assert_allclose(t, trace["t"][rows], atol=1e-9)
    np.testing.assert_allclose(v, trace["solve_time_ms"][rows], atol=1e-12)
    present = {str(c.entity_path) for c in RrdReader(str(path)).stream().to_chunks()}
    assert not any(p.startswith("/imm") for p in present)
    assert "/world/reference" not in present and "/world/prediction" not in present
    with pytest.raises(KeyError):
        read_scalar_series(path, "/imm/mode_prob_1")


def test_parallel_writes_do_not_mix(tmp_path: Path) -> None:
    runs = [synthetic_run(3.0, n_modes=0, seed=s) for s in range(3)]

    def job(i: int) -> Path:
        trace, solves, events, ref = runs[i]
        p = tmp_path / f"r{i}" / "run.rrd"
        write_rrd(p, trace, run_id=f"run-{i}", solves=solves, events=events, reference_path=ref)
        return p

    with ThreadPoolExecutor(3) as ex:
        paths = list(ex.map(job, range(3)))
    for i, p in enumerate(paths):
        recs = RrdReader(str(p)).recordings()
        assert [r.recording_id for r in recs] == [f"run-{i}"]
        _, v = read_scalar_series(p, "/speed/measured")
        np.testing.assert_allclose(v, runs[i][0]["v_meas"], atol=1e-12)


def test_file_size_bound(rrd: Path) -> None:
    """A 40 s run's recording stays below the 10 MB budget (speed is measured in benchmarks/)."""
    assert rrd.stat().st_size < 10e6


def test_injected_faults_are_recorded_when_the_run_has_them(tmp_path: Path) -> None:
    """A trace with servo and sensor fault truth columns: each is the series ``/injected/<name>`` (every row,
    the values as given) and the blueprint gets their view; a trace without them has no ``/injected``."""
    trace, _, _, _ = synthetic_run(2.0, n_modes=0)
    t = trace["t"]
    trace = {**trace, "fault_lock_L": (t >= 1.0).astype(float), "fault_effectiveness_L": np.ones_like(t),
             "fault_speed_offset": np.where(t >= 0.5, 0.3, 0.0)}
    path = tmp_path / "faults.rrd"
    write_rrd(path, trace, run_id="faults")
    for name in ("lock_L", "effectiveness_L", "speed_offset"):
        tt, v = read_scalar_series(path, f"/injected/{name}")
        np.testing.assert_allclose(tt, t, atol=1e-9)
        np.testing.assert_array_equal(v, trace[f"fault_{name}"])
    assert "/injected" in [v.origin for v in _motion_tabs(trace).contents]
    plain = {k: v for k, v in trace.items() if not k.startswith("fault_")}
    assert "/injected" not in [v.origin for v in _motion_tabs(plain).contents]
