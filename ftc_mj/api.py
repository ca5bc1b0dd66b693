"""The Python API: configure, run, load back; the ``ftc-mj`` command is a thin layer over it.

::

    import ftc_mj

    cfg = ftc_mj.load_config("scenario2", {"sensors.yaw_rate_sigma": 0.01, "duration": 20.0})
    run = ftc_mj.run(cfg)                      # in memory; ftc_mj.run(cfg, "runs/out") also writes it
    run.trace.select("t", "R_L", "R_L_hat")    # a polars DataFrame, one row per estimator step
    run.metrics["detection_delay"], run.events[:3], run.path

- :func:`load_config`: a built-in scenario or a TOML file plus overrides with the dotted keys of
  ``--set`` (same validation, same one-line :class:`~ftc_mj.errors.BadInput` messages);
- :func:`run`: one closed-loop simulation, in memory or into ``OUT/<run-id>/``; :class:`Run` holds
  the trace (polars), the metrics, the events and the path written;
- :func:`load_run`, :func:`load_study`: a finished run directory, a finished study folder;
- :func:`plan_study`, :func:`run_study`: a study file (or built-in study) on Dask or serially.

Components are plugged in through :mod:`ftc_mj.registry` (``ftc_mj.register_estimator`` …).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .config import RunConfig, config_to_toml_dict, validate_config
from .config import load_config as _load_config
from .errors import BadInput
from .metrics.schema import upgrade_names
from .telemetry import Event

if TYPE_CHECKING:  # polars is imported where a DataFrame is made (the command line's run needs none)
    import polars as pl


@dataclass
class Run:
    """One finished run: what :func:`run` returns and :func:`load_run` reads back."""

    config: RunConfig
    """The fully resolved configuration."""
    run_id: str
    metrics: dict[str, Any]
    """The metrics of ``metrics.json`` (keys documented in :mod:`ftc_mj.metrics`)."""
    trace: pl.DataFrame
    """One row per estimator step (columns in :mod:`ftc_mj.telemetry.columns`; SI units, radians)."""
    events: list[Event] = field(default_factory=list)
    """Fault onsets, declarations, hand-overs, solver fallbacks, …, in time order."""
    path: Path | None = None
    """The run directory written (``None`` for a run kept in memory)."""
    outcome: Any = None
    """The simulation's in-memory result (:class:`~ftc_mj.sim.run.RunOutcome`; ``None`` when loaded)."""

    @property
    def status(self) -> str:
        """``ok``, ``failed`` (``metrics["error"]`` says why) or ``unstable``."""
        return str(self.metrics.get("status"))


def load_config(scenario: str | Path = "scenario2", overrides: Mapping[str, Any] | None = None, *,
                plugins: Iterable[str] = ()) -> RunConfig:
    """The run configuration of a built-in scenario (``scenario1`` … ``scenario4``) or a TOML file, with
    ``overrides`` (dotted keys as ``--set``: ``{"sensors.yaw_rate_sigma": 0.01}``) and the plug-in
    modules ``plugins`` added to the config's ``plugins`` (imported before validation).
    :class:`~ftc_mj.errors.BadInput` with a one-line message naming the field."""
    return _load_config(scenario, overrides, plugins=plugins)


def _config(config: RunConfig | str | Path | Mapping[str, Any], overrides: Mapping[str, Any] | None) -> RunConfig:
    if isinstance(config, RunConfig):
        if not overrides:
            return config
        data = config_to_toml_dict(config)
        from .config import set_dotted

        for k, v in overrides.items():
            set_dotted(data, k, v)
        return validate_config(data)
    if isinstance(config, Mapping):
        return validate_config({**config})
    return load_config(config, overrides)


def run(config: RunConfig | str | Path | Mapping[str, Any] = "scenario2", out: str | Path | None = None, *,
        overrides: Mapping[str, Any] | None = None, rrd: bool | None = None,
        progress: bool | Callable[[float], None] = False, strict: bool | None = None) -> Run:
    """Simulate one run and return it; with ``out``, also write ``out/<run-id>/`` (``config.toml``,
    ``trace.parquet``, ``metrics.json``, ``events.json``, ``run.rrd``).

    Parameters
    ----------
    config
        A :class:`RunConfig`, a scenario name or TOML path, or a plain table (validated).
    out
        Output folder (checked before simulating: :class:`~ftc_mj.errors.BadInput`), or ``None``.
    overrides
        Dotted keys applied on top of ``config``.
    rrd
        Write the Rerun recording (default: ``output.rrd``); only then is rerun-sdk imported.
    progress
        ``True``: a progress bar on the terminal; a callable: called with the fraction done.
    strict
        Re-raise a component's exception instead of recording a failed run (default: the
        ``FTC_MJ_STRICT`` environment variable).
    """
    import polars as pl

    cfg = _config(config, overrides)
    outcome = simulate_run(cfg, Path(out) if out is not None else None, rrd=rrd, progress=progress, strict=strict)
    return Run(cfg, outcome.run_id, outcome.metrics, pl.DataFrame(outcome.result.trace), list(outcome.result.events),
               outcome.run_dir, outcome)


def simulate_run(cfg: RunConfig, out_root: Path | None, *, rrd: bool | None = None,
                 progress: bool | Callable[[float], None] = False, strict: bool | None = None) -> Any:
    """:func:`run`'s simulation of a resolved config without the trace as a DataFrame: the
    :class:`~ftc_mj.sim.run.RunOutcome` (the command line's run, which needs no polars)."""
    if progress is True:
        from .sim.progress import run_with_progress

        return run_with_progress(cfg, out_root, rrd=cfg.output.rrd if rrd is None else rrd, show=True)
    from .sim.run import execute

    return execute(cfg, out_root, rrd=rrd, progress=progress or None, strict=strict)


def load_run(path: str | Path) -> Run:
    """A finished run directory (``OUT/<run-id>/``) read back by :func:`ftc_mj.rundir.read_run`;
    :class:`~ftc_mj.errors.BadInput` if it is not one. Events come from ``events.json`` (runs written
    before it existed: from the trace)."""
    from .rundir import read_run

    d = Path(path)
    cfg, metrics, trace, events = read_run(d)
    return Run(cfg, str(metrics.get("run_id", d.name)), metrics, trace, events, d)


@dataclass
class Study:
    """A study's results: what :func:`run_study` returns and :func:`load_study` reads back."""

    path: Path
    results: pl.DataFrame
    """``results.parquet``: one row per run (run key, axis labels, seed, flattened metrics, compact
    time series ``ts_*``)."""
    plan: dict[str, Any] = field(default_factory=dict)
    """``plan.json``: the study's name, hash, axes and runs."""
    report: Any = None
    """What the invocation did (:class:`~ftc_mj.study.runner.StudyReport`; ``None`` when loaded)."""


def plan_study(study: str | Path, *, overrides: Mapping[str, Any] | None = None, seeds: int | None = None,
               plugins: Iterable[str] = ()) -> Any:
    """A study file or built-in study name (``observability``, …) read, validated and expanded into its
    plan of runs (:class:`~ftc_mj.study.plan.StudyPlan`); ``overrides`` and ``plugins`` are added to its
    base (and to its identity), ``seeds`` replaces its seed count."""
    from .study.plan import plan_study as _plan

    extra = dict(overrides or {})
    if plugins:
        extra["plugins"] = list(dict.fromkeys([*extra.get("plugins", []), *plugins]))
    return _plan(study, extra_overrides=extra, seeds=seeds)


def run_study(study: str | Path | Any, out: str | Path | None = None, *, workers: int = 2, client: Any = None,
              address: str | None = None, serial: bool = False, overrides: Mapping[str, Any] | None = None,
              seeds: int | None = None, plugins: Iterable[str] = (), **kwargs: Any) -> Study:
    """Compute a study's missing runs into ``out`` (default ``runs/out/studies/<name>``) and collect
    them: serially (``serial``), on ``client`` (a ``distributed.Client``, left open), on the scheduler
    at ``address``, or on a new LocalCluster of ``workers`` processes. ``study`` is a study file,
    a built-in study name or a plan from :func:`plan_study`; ``kwargs`` go to
    :func:`ftc_mj.study.runner.run_study` (``rrd``, ``limit``, ``retry_failed``, ``progress``, …)."""
    from .study.plan import StudyPlan
    from .study.runner import run_study as _run

    plan = study if isinstance(study, StudyPlan) else plan_study(study, overrides=overrides, seeds=seeds,
                                                                  plugins=plugins)
    out_dir = Path(out) if out is not None else Path("runs/out/studies") / plan.spec.name
    report = _run(plan, out_dir, workers=workers, client=client, address=address, serial=serial, **kwargs)
    import polars as pl

    results = report.results if report.results is not None else pl.DataFrame()
    return Study(out_dir, results, plan.to_json(), report)


def load_study(path: str | Path) -> Study:
    """A finished study folder read back (``results.parquet``, ``plan.json``);
    :class:`~ftc_mj.errors.BadInput` if it has no results."""
    import polars as pl

    d = Path(path)
    res = d / "results.parquet"
    if not res.is_file():
        raise BadInput(f"STUDY_DIR: {d} has no results.parquet (not a finished study)")
    plan = json.loads((d / "plan.json").read_text()) if (d / "plan.json").is_file() else {}
    return Study(d, upgrade_names(pl.read_parquet(res)), plan)
