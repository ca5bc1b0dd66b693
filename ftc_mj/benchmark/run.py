"""``ftc-mj bench``: methods × draws on the study machinery (Dask, one row per run persisted at once,
resumable; :mod:`ftc_mj.study.runner`), each run scored in its worker by
:func:`~ftc_mj.benchmark.score.score_run`, then the outputs (:mod:`.report`).

The runs of a bench form a :class:`~ftc_mj.study.plan.StudyPlan` built here instead of from a study file:
one run per (method, draw), keyed by its resolved config and the method's code (:func:`bench_run_key`), labelled
``method``, ``draw`` and ``fault_class``. The plan's identity is the benchmark version, the split, the
draw indices and the ``healthy`` flag — not the methods: a run's key already hashes its method's resolved
settings, so a rerun of the same command into the same folder computes only the missing runs, a method added
to a folder computes only that method's runs (the others' rows are reused), and a bench of other draws is
refused there.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import BadInput
from ..identity import canonical_hash
from ..io import atomic_path, write_json, writer_lock
from ..study.plan import PlannedRun, StudyPlan, run_key
from ..study.spec import AnalysisSpec, StudySpec
from ..study.store import StudyStore
from .definition import CURRENT_VERSION, PRIVATE, RUN_SPLITS, JudgeRule, load_definition
from .draws import MAX_INDEX, Draw, draw
from .methods import Method
from .private import private_key_id
from .score import score_run

KEPT_METRICS = ("run_id", "status", "error", "outcome", "wall_time_s", "realtime_factor")
"""The run metrics a bench row keeps beside the scores."""
MAX_DRAWS = 2000
"""Largest ``--draws`` (the plan of a study is at most 10 000 runs; at ~6 s a run 2000 draws are hours)."""


def bench_run(cfg: Any, out_root: Path | None, rrd: bool, rule: JudgeRule | None = None) -> Any:
    """Run one (method, draw) and score it (the worker's ``run_fn``, with the version's success ``rule`` bound): the
    run's outcome whose metrics are :data:`KEPT_METRICS` and the scores (:func:`~ftc_mj.benchmark.score.score_run`)."""
    from ..sim.run import execute

    outcome = execute(cfg, out_root, rrd=rrd)
    scores = score_run(cfg, outcome.result.trace, outcome.result.events, status=str(outcome.metrics.get("status")),
                       record=outcome.result.record, rule=rule)
    scores.pop("status", None)
    outcome.metrics = {**{k: outcome.metrics.get(k) for k in KEPT_METRICS}, **scores}
    return outcome


@dataclass
class BenchPlan:
    """The runs of a bench and what they come from."""

    plan: StudyPlan
    draws: list[Draw]
    methods: list[Method]
    split: str
    version: str
    healthy: bool
    meta: dict[str, Any] = field(default_factory=dict)
    rule: JudgeRule = field(default_factory=JudgeRule)
    """The version's success rule (``[judge]``)."""
    classes: tuple[str, ...] = ()
    """The drawn fault classes in the definition's order (the report's rows)."""
    replay: dict[str, str] = field(default_factory=dict)
    """How a replay command names the definition: ``definition_file`` (absolute) for a definition file."""


def check_request(split: str, n_draws: int, start: int) -> None:
    """The split and draw range (:class:`BadInput` naming the option)."""
    if split not in RUN_SPLITS:
        raise BadInput(f"--split: expected {', '.join(RUN_SPLITS)}, got {split!r}")
    if not 1 <= n_draws <= MAX_DRAWS:
        raise BadInput(f"--draws: must be in [1, {MAX_DRAWS}], got {n_draws}")
    if start < 0:
        raise BadInput(f"--start: must be >= 0, got {start}")
    if start + n_draws > MAX_INDEX:
        raise BadInput(f"--start: the draws {start}..{start + n_draws - 1} go beyond the last draw index "
                       f"{MAX_INDEX - 1}")


def bench_run_key(cfg: Any, method: Method) -> str:
    """The key of one (method, draw) run: its resolved config's (:func:`~ftc_mj.study.plan.run_key`) and the
    method's code (:attr:`Method.code`: the ftc-mj source and each plug-in module's contents), so a run of an
    edited method is a new run beside the old one in the same folder, never a silent reuse of its results."""
    return canonical_hash({"config": run_key(cfg), "code": method.code})[:16]


def plan_bench(methods: list[Method], split: str, n_draws: int, *, version: str = CURRENT_VERSION, start: int = 0,
               healthy: bool = False, private_key: bytes | None = None) -> BenchPlan:
    """Every (method, draw) run of draws ``start … start + n_draws - 1`` (validated; :class:`BadInput`); the
    private split's draws need its ``private_key`` (:mod:`.private`), of which the plan keeps only the id."""
    from .. import __version__

    check_request(split, n_draws, start)
    definition = load_definition(version)
    draws = [draw(split, i, version, private_key) for i in range(start, start + n_draws)]
    runs: list[PlannedRun] = []
    seen: dict[str, str] = {}
    for m in methods:
        for d in draws:
            cfg = m.apply(d.scenario(with_faults=not healthy))
            key = bench_run_key(cfg, m)
            if key in seen:
                raise BadInput(f"METHOD: {m.name} and {seen[key]} resolve to the same runs")
            seen[key] = m.name
            runs.append(PlannedRun(len(runs), key, {"method": m.name, "draw": d.index, "fault_class":
                                                    "none" if healthy else d.fault_class}, cfg.seed,
                                   cfg.model_dump(mode="json")))
    meta = {"benchmark": definition.version, "split": split, "draws": [start, start + n_draws], "healthy": healthy,
            "methods": {m.name: {"digest": m.digest, "source": m.source, "description": m.description,
                                 "settings": m.settings, "plugins": list(m.plugins), "code": m.code}
                        for m in methods},
            "package_version": __version__}
    if split == PRIVATE:
        meta.update(private_key_id(private_key))
    if definition.plugins:  # a definition with plug-in fault classes: its file and modules are part of the bench
        meta.update(definition_file=version, fault_plugins=list(definition.plugins))
    replay = {"definition_file": str(Path(version).resolve())} if version.endswith(".toml") else {}
    identity = {k: v for k, v in meta.items() if k not in ("package_version", "methods")}
    name = f"bench-{definition.version}-{split}" + ("-healthy" if healthy else "")
    spec = StudySpec(name=name, description=f"ftc-mj bench {definition.version} {split}", scenario="scenario1",
                     analysis=AnalysisSpec(figures=False))
    plan = StudyPlan(spec, Path("bench.json"), canonical_hash(identity), runs, ["method", "draw", "fault_class"], {},
                     json.loads(json.dumps(identity, default=str)))
    return BenchPlan(plan, draws, methods, split, definition.version, healthy, meta, definition.judge,
                     tuple(definition.fault.classes), replay)


def adopt_earlier_bench(bp: BenchPlan, out: Path) -> bool:
    """Let a folder written before a bench's identity left out the methods take this bench: when its
    ``plan.json`` identity is this bench's plus a ``methods`` table, its hash and identity are rewritten to
    this bench's (its rows stay: each is keyed by its run's config). Returns whether it did."""
    pj = out / "plan.json"
    try:
        old = json.loads(pj.read_text()) if pj.is_file() else {}
    except (OSError, json.JSONDecodeError):
        return False  # the store's check names the unreadable file
    ident = old.get("identity") if isinstance(old, dict) else None
    if not isinstance(ident, dict) or "methods" not in ident or old.get("study_hash") == bp.plan.study_hash:
        return False
    if {k: v for k, v in ident.items() if k != "methods"} != bp.plan.identity:
        return False
    write_json(pj, {**old, "study_hash": bp.plan.study_hash, "identity": bp.plan.identity})
    return True


def prepare_output(bp: BenchPlan, out: Path) -> None:
    """Refuse an output folder that cannot take this bench (another bench's results, unwritable: the study
    store's checks), then write ``OUT/bench.json`` (the bench's definition: version, split, draws, this
    invocation's methods with their settings and digests, package version)."""
    StudyStore(out).check(bp.plan)
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / "bench.json") as tmp:
        tmp.write_text(json.dumps(bp.meta, indent=2, sort_keys=True, default=str) + "\n")
    bp.plan.path = out / "bench.json"  # the study store keeps a copy of the plan's file (study.toml)


def run_bench(bp: BenchPlan, out: Path, *, workers: int = 2, address: str | None = None, progress: bool = False,
              compare: int = 1, echo: Any = None) -> tuple[Any, Path]:
    """Compute the bench's missing runs into ``out`` (the study runner: Dask, rows persisted one by one),
    then write the outputs (:func:`~ftc_mj.benchmark.report.write_outputs`); returns the study report and
    the report file. Nothing is written before the folder is checked and the scheduler at ``address``
    answered; the folder has one writer (:func:`~ftc_mj.io.writer_lock`: a second bench or study on it
    gets :class:`BadInput`). When a local cluster (no ``address``) computed runs, the comparisons' runs are
    simulated again ``workers`` at a time in processes of their own (:func:`record_apart`); otherwise in this
    process."""
    import contextlib

    from ..study.cluster import open_client
    from ..study.runner import plan_todo, run_study
    from .report import write_outputs

    adopt_earlier_bench(bp, out)
    store = StudyStore(out)
    store.check(bp.plan)
    local = address is None and bool(plan_todo(bp.plan, store)[0])
    cluster = open_client(workers, address) if address is not None or local else contextlib.nullcontext(None)
    with cluster as client, writer_lock(out):
        prepare_output(bp, out)
        run_fn = functools.partial(bench_run, rule=bp.rule)
        report = run_study(bp.plan, out, workers=workers, client=client, run_fn=run_fn, analyse=False,
                           progress=progress, echo=echo, client_workers=workers if local else None)
        assert report.results is not None
        record = functools.partial(record_apart, processes=workers) if local else None
        return report, write_outputs(bp, report.results, out, compare=compare, echo=echo, record=record)


def record_apart(jobs: list[tuple[Any, Path]], processes: int) -> list[Path]:
    """:func:`~ftc_mj.benchmark.report.record_runs` in up to ``processes`` fresh processes of their own (spawned,
    gone with the report), one run a task, not in the bench's workers: a recording starts the Rerun SDK, about
    50 MiB that a process keeps, on top of the run, and in the workers, after their draws, it lifted the largest
    to 669 and 751 MiB where the draws had kept them at 585 and 613 (the 200-draw leaderboard at 32a7645). The
    configs travel as plain data and are validated in the process, which imports their plug-ins from the
    ``sys.path`` it inherits."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=max(1, min(processes, len(jobs))),
                             mp_context=multiprocessing.get_context("spawn")) as pool:
        return [Path(p) for p in pool.map(_record_one, [cfg.model_dump(mode="json") for cfg, _ in jobs],
                                          [str(root) for _, root in jobs])]


def _record_one(config: dict[str, Any], root: str) -> str:
    from ..config import validate_config
    from .report import record_runs

    return str(record_runs([(validate_config(config), Path(root))])[0])
