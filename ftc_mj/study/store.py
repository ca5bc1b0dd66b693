"""The study output folder: identity check, per-run rows, the run log and the collected table.

Layout of ``OUT/``::

    study.toml        copy of the study file (of the latest invocation; same identity)
    plan.json         the resolved plan (run keys, axis labels, seeds) and the study hash
    rows/<key>.parquet one metrics row per finished run, written atomically by the client
    rows/quarantine/  row files that could not be read (moved aside; their runs are recomputed)
    log.jsonl         one line per invocation start/end and per persisted run (who computed what)
    runs/<run-id>/    per-run recordings (``--rrd failures|all``)
    results.parquet   all rows of the plan, collected atomically at the end
    summary.md, figures/  the analysis

Nothing here ever deletes or rewrites a row of another run; a row is replaced only when its run is
explicitly recomputed (``--retry-failed``).
"""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path
from typing import Any

import polars as pl
import pyarrow as pa
import pyarrow.parquet as pq

from ..errors import BadInput, OutputError
from ..io import atomic_path, output_failure, remove_stale_temporaries, write_json
from ..metrics.schema import upgrade_names
from ..sim.output import check_output_root
from .plan import StudyPlan, identity_diff


class StudyStore:
    """Reads and writes one study output folder."""

    def __init__(self, root: Path) -> None:
        self.root = Path(root)
        self.rows_dir = self.root / "rows"
        self.runs_dir = self.root / "runs"
        self.log_path = self.root / "log.jsonl"

    # ------------------------------------------------------------------ identity
    def check(self, plan: StudyPlan) -> None:
        """Refuse (BadInput naming ``--out``) an output folder that cannot be written (below a regular
        file, in a folder without write permission, beyond the path limits: the checks of ``ftc-mj run``,
        :func:`~ftc_mj.sim.output.check_output_root`) or that holds another study's results. Writes
        nothing that stays."""
        longest = max((f"{r.key}.parquet" for r in plan.runs), key=len, default="rows")
        try:
            if self.root.exists() and not self.root.is_dir():
                raise BadInput(f"--out: {self.root} exists and is not a directory")
        except OSError as err:  # a name too long for the file system, a folder that may not be searched
            check_output_root(self.root, longest)  # names the limit when it is one
            raise BadInput(f"--out: cannot use {str(self.root)[:80]}: {err.strerror}") from None
        check_output_root(self.root, longest)
        pj = self.root / "plan.json"
        if pj.is_file():
            try:
                old = json.loads(pj.read_text())
            except (OSError, json.JSONDecodeError) as err:
                raise BadInput(f"--out: {pj} is unreadable ({err}); use another --out") from None
            if old.get("study_hash") != plan.study_hash:
                raise BadInput(f"--out: {self.root} holds results of a different study ({old.get('study')!r} from "
                               f"{old.get('study_file')}; {describe_difference(old, plan)}); use another --out")
        elif self.rows_dir.is_dir() and any(self.rows_dir.glob("*.parquet")):
            raise BadInput(f"--out: {self.root} holds rows but no plan.json; use another --out")

    def init(self, plan: StudyPlan) -> None:
        """Write the study file copy and (first invocation) the plan; remove the temporaries a killed
        invocation left (rows, recordings, figures)."""
        self.rows_dir.mkdir(parents=True, exist_ok=True)
        for d in (self.root, self.rows_dir, self.runs_dir, self.runs_dir / ".staging", self.root / "figures"):
            remove_stale_temporaries(d)
        # the copy follows the latest invocation (same identity; only [analysis] may have changed)
        with atomic_path(self.root / "study.toml") as tmp:
            shutil.copyfile(plan.path, tmp)
        if not (self.root / "plan.json").is_file():
            write_json(self.root / "plan.json", plan.to_json())

    # ------------------------------------------------------------------ rows
    def row_path(self, key: str) -> Path:
        return self.rows_dir / f"{key}.parquet"

    def quarantine_corrupt(self) -> list[Path]:
        """Move every row file that is not a readable one-row table with a ``status`` to
        ``rows/quarantine/`` (so its run counts as missing and is recomputed); returns the moved files."""
        if not self.rows_dir.is_dir():
            return []
        moved = []
        for p in sorted(self.rows_dir.glob("[!.]*.parquet")):
            try:
                ok = pq.read_table(p, columns=["status"]).num_rows == 1
            except Exception:  # noqa: BLE001 - pyarrow raises several types for a damaged file
                ok = False
            if ok:
                continue
            qdir = self.rows_dir / "quarantine"
            qdir.mkdir(exist_ok=True)
            dest = qdir / f"{p.stem}.{time.strftime('%Y%m%dT%H%M%S', time.gmtime())}.parquet"
            os.replace(p, dest)
            moved.append(dest)
        return moved

    def done_keys(self) -> set[str]:
        """Keys of runs whose row has been persisted."""
        if not self.rows_dir.is_dir():
            return set()
        return {p.stem for p in self.rows_dir.glob("*.parquet") if not p.name.startswith(".")}

    def failed_keys(self) -> set[str]:
        """Keys of persisted rows whose run failed."""
        out = set()
        for p in self.rows_dir.glob("*.parquet"):
            if p.name.startswith("."):
                continue
            t = pq.read_table(p, columns=["status"])
            if t.num_rows and t.column("status")[0].as_py() != "ok":
                out.add(p.stem)
        return out

    def write_row(self, key: str, row: dict[str, Any]) -> None:
        """Persist one run's row atomically (temporary file + rename)."""
        table = pa.Table.from_pylist([row])
        with atomic_path(self.row_path(key)) as tmp:
            pq.write_table(table, tmp)

    def read_rows(self, keys: list[str] | None = None) -> pl.DataFrame:
        """All persisted rows (or those of ``keys`` that exist), as one table."""
        paths = [self.row_path(k) for k in keys] if keys is not None else sorted(self.rows_dir.glob("[!.]*.parquet"))
        frames = [pl.read_parquet(p) for p in paths if p.is_file()]
        if not frames:
            return pl.DataFrame()
        return upgrade_names(pl.concat(frames, how="diagonal_relaxed"))  # rows written before a rename

    def collect(self, plan: StudyPlan) -> pl.DataFrame:
        """Write ``results.parquet`` (atomically) with the rows of the plan's runs, in plan order."""
        df = self.read_rows([r.key for r in plan.runs])
        if df.height:
            df = df.sort("run_index")
        try:
            with atomic_path(self.root / "results.parquet") as tmp:
                df.write_parquet(tmp)
        except Exception as err:  # noqa: BLE001 - polars reports a full disk as its own ComputeError
            why = output_failure(err, self.root)
            if why is None:
                raise
            raise OutputError(f"{self.root / 'results.parquet'}: {why}; the rows are kept in {self.rows_dir}, "
                              "re-run the same command once there is room") from None
        return df

    # ------------------------------------------------------------------ log
    def log(self, event: str, **data: Any) -> None:
        """Append one JSON line to ``log.jsonl`` (flushed and fsynced)."""
        self.root.mkdir(parents=True, exist_ok=True)
        line = json.dumps({"time": time.time(), "event": event, **data}, default=str)
        with open(self.log_path, "a") as fh:
            fh.write(line + "\n")
            fh.flush()
            os.fsync(fh.fileno())

    def reconcile_log(self) -> list[str]:
        """Log the persisted rows the log does not know of, from the rows themselves.

        A row is written (atomically) before its ``run`` line is appended, so a process killed
        between the two leaves a row without a log line. Each such row carries the invocation that
        computed it; it gets its ``run`` line now, marked ``recovered``, so the log again names
        exactly one computation per persisted run. Returns the keys it logged (plan order is not
        known here: sorted).
        """
        logged = {e.get("run_key") for e in self.read_log() if e.get("event") == "run"}
        missing = sorted(self.done_keys() - logged)
        for key in missing:
            t = pq.read_table(self.row_path(key), columns=["invocation", "run_index", "status", "worker"])
            row = t.to_pylist()[0] if t.num_rows else {}
            self.log("run", invocation=row.get("invocation"), run_key=key, run_index=row.get("run_index"),
                     status=row.get("status"), worker=row.get("worker"), recovered=True)
        return missing

    def read_log(self) -> list[dict[str, Any]]:
        """Parsed ``log.jsonl`` (a torn last line from a killed process is skipped)."""
        if not self.log_path.is_file():
            return []
        out = []
        for line in self.log_path.read_text().splitlines():
            try:
                out.append(json.loads(line))
            except json.JSONDecodeError:
                continue
        return out


def describe_difference(old_plan: dict[str, Any], plan: StudyPlan) -> str:
    """What differs between a stored ``plan.json`` and ``plan``: from the stored identity when there is
    one, else from its seeds and ``--set`` overrides."""
    if isinstance(old_plan.get("identity"), dict):
        diffs = identity_diff(old_plan["identity"], plan.identity)
    else:
        old_seeds = sorted({r.get("seed") for r in old_plan.get("runs", [])}, key=str)
        new_seeds = sorted({r.seed for r in plan.runs}, key=str)
        diffs = [f"seeds {old_seeds} → {new_seeds}"] if old_seeds != new_seeds else []
        if old_plan.get("extra_overrides", {}) != plan.extra_overrides:
            diffs.append(f"--set {old_plan.get('extra_overrides')} → {plan.extra_overrides}")
    if not diffs:
        return "the study file changed"
    more = f" and {len(diffs) - 4} more" if len(diffs) > 4 else ""
    return "differs in " + "; ".join(diffs[:4]) + more
