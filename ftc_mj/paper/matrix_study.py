"""The matrix over seeds, run by the study machinery (:mod:`ftc_mj.study`: Dask, one persisted row
per run, resumable).

The quick look is the same study with the one seed 0.

The matrix entries become one preset axis ``run`` of a generated study file (labels = matrix
labels; each value sets the entry's scenario — name, description, duration, both fault schedules —
and its overrides), crossed with the seeds. Each worker runs
:func:`run_with_report_metrics`: the run plus the report's trace-derived metrics
(:func:`~ftc_mj.paper.derived.report_metrics`), so the persisted rows carry everything the claims
read. The runs of one seed (``keep_seed``) also keep their run directory (config, metrics, events and
the trace) for the figures: without a recording the trace keeps only :func:`kept_columns` (what the
figures, the claims' comparison recordings and a recording of the run read), a third of the columns —
the quick look's 69 runs of 40 s then write 27 MB of traces instead of about 110 MB; with a recording
(quick look, ``--rrd runs|compare``) the whole trace.

The study folder is ``OUT/study/<study hash>``: the same invocation resumes there and computes only
the runs without a row; another selection, seed list or duration is another study.
"""

from __future__ import annotations

import dataclasses
import functools
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..config import read_toml, scenario_path
from ..io import write_toml
from .matrix import MatrixEntry

if TYPE_CHECKING:
    from ..config import RunConfig
    from ..study.plan import StudyPlan

AXIS = "run"
"""Name of the study axis holding the matrix labels."""
BASE_SCENARIO = "scenario1"


def entry_preset(entry: MatrixEntry, duration: float | None = None) -> dict[str, Any]:
    """Dotted overrides that turn the base scenario into ``entry``'s configuration (seed aside), run
    for ``duration`` (s) instead of the scenario's when given."""
    from ..study.spec import flatten_dotted

    data = read_toml(scenario_path(entry.scenario), "scenario")
    data.setdefault("name", scenario_path(entry.scenario).stem)
    preset = {"faults.left": [], "faults.right": []}
    preset.update(flatten_dotted(data))
    preset.update(entry.overrides)
    if duration is not None:
        preset["duration"] = float(duration)
    return preset


def study_data(entries: Sequence[MatrixEntry], seeds: Sequence[int], duration: float | None = None,
               name: str = "paper-matrix") -> dict[str, Any]:
    """The study file (as TOML data) of ``entries`` × ``seeds``, each run ``duration`` s long (default:
    its scenario's)."""
    return {
        "name": name,
        "description": "ftc-mj paper: the matrix over seeds (generated from ftc_mj.paper.matrix)",
        "scenario": BASE_SCENARIO,
        "seeds": [int(s) for s in seeds],
        "axes": [{"name": AXIS, "labels": [e.label for e in entries],
                  "values": [entry_preset(e, duration) for e in entries]}],
    }


def load_matrix_study(entries: Sequence[MatrixEntry], seeds: Sequence[int], duration: float | None,
                      out: Path, *, write: bool = True) -> StudyPlan:
    """Validate the generated study and return its plan, whose study file is
    ``out/study/<hash>/matrix.toml`` (written when ``write``; nothing is written when validation
    fails with BadInput)."""
    from ..study.plan import plan_study

    data = study_data(entries, seeds, duration)
    with tempfile.TemporaryDirectory() as tmp:
        probe = Path(tmp) / "matrix.toml"
        write_toml(probe, data)
        plan = plan_study(probe)
    final = Path(out) / "study" / plan.study_hash / "matrix.toml"
    if write:
        write_toml(final, data)
    return dataclasses.replace(plan, path=final)


EXTRA_KEPT_COLUMNS: tuple[str, ...] = ("R_R_model", "R_L_model", "reconfig_state", "plant_flags")
"""Trace columns kept beside :data:`ftc_mj.rerun.record.REQUIRED_COLUMNS` and ``mode_prob_<k>`` in a
run directory without a recording (:func:`kept_columns`)."""


def kept_columns(columns: Sequence[str]) -> list[str]:
    """Of a trace's ``columns``, those a run directory kept for the figures keeps: what
    :mod:`ftc_mj.paper.figures` draws, the claims' comparison recordings (:mod:`ftc_mj.rerun.overlay`)
    show and :func:`~ftc_mj.rerun.record.write_rrd` needs (so ``ftc-mj view`` still opens the run)."""
    from ..rerun.record import REQUIRED_COLUMNS

    keep = {*REQUIRED_COLUMNS, *EXTRA_KEPT_COLUMNS}
    return [c for c in columns if c in keep or c.startswith("mode_prob_")]


def run_with_report_metrics(cfg: RunConfig, out_root: Path | None, rrd: bool, *, keep_seed: int | None = None,
                            runs_dir: str | None = None, record: bool = False) -> Any:
    """A study ``run_fn``: :func:`~ftc_mj.sim.run.execute`, then the report metrics added to the
    outcome's metrics. Runs of ``keep_seed`` are written under ``runs_dir``: with a recording and the whole
    trace when ``record``, else with the trace's :func:`kept_columns` (the study's own ``out_root`` and
    ``rrd`` are not used)."""
    from ..sim.output import check_output_root, output_bytes
    from ..sim.run import execute, run_id_for, write_outcome
    from .derived import report_metrics

    keep = Path(runs_dir) if runs_dir is not None and cfg.seed == keep_seed else None
    if keep is None or record:
        outcome = execute(cfg, keep, rrd=record and keep is not None)
    else:
        check_output_root(keep, run_id_for(cfg), output_bytes(cfg, False))
        outcome = execute(cfg, None, rrd=False)
        res = outcome.result
        compact = dataclasses.replace(res, trace={c: res.trace[c] for c in kept_columns(list(res.trace))})
        written = write_outcome(dataclasses.replace(outcome, result=compact), cfg, keep, False)
        outcome = dataclasses.replace(written, result=res)
    outcome.metrics.update(report_metrics(cfg, outcome.result.trace))
    return outcome


@dataclass
class MatrixResult:
    """The rows of one invocation, by seed and label."""

    plan: StudyPlan
    folder: Path
    rows: list[dict[str, Any]]
    computed: int
    wall_time_s: float

    def by_seed(self) -> dict[int, dict[str, dict[str, Any]]]:
        """``{seed: {label: row}}``."""
        out: dict[int, dict[str, dict[str, Any]]] = {}
        for r in self.rows:
            out.setdefault(int(r["seed"]), {})[str(r[AXIS])] = r
        return out


def run_matrix_study(plan: StudyPlan, *, workers: int, keep_seed: int | None, report_only: bool = False,
                     progress: bool = False, on_row: Callable[[dict[str, Any]], None] | None = None,
                     runs_dir: Path | None = None, record: bool = False, retry_failed: bool = False,
                     echo: Callable[[str], None] | None = None) -> MatrixResult:
    """Compute the plan's missing runs (none with ``report_only``) and collect all its rows; one
    worker runs them in this process (no Dask cluster). The runs of ``keep_seed`` keep their
    directory in ``runs_dir`` (default: the study's ``runs/``), with a recording when ``record``;
    ``retry_failed`` recomputes the runs whose row says failed; ``echo`` receives the study's one-line notes
    (what it starts computing, before the first run finishes)."""
    from ..study.runner import run_study
    from ..study.store import StudyStore

    folder = plan.path.parent
    store = StudyStore(folder)
    store.check(plan)
    if report_only:
        df = store.collect(plan)
        return MatrixResult(plan, folder, df.to_dicts() if df.height else [], 0, 0.0)
    fn = functools.partial(run_with_report_metrics, keep_seed=keep_seed, record=record,
                           runs_dir=str(runs_dir if runs_dir is not None else store.runs_dir))
    rep = run_study(plan, folder, workers=workers, serial=workers == 1, run_fn=fn, analyse=False, progress=progress,
                    on_row=on_row, retry_failed=retry_failed, echo=echo)
    df = rep.results
    rows = df.to_dicts() if df is not None and df.height else []
    return MatrixResult(plan, folder, rows, len(rep.computed), rep.wall_time_s)
