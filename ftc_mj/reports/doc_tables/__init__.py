"""The published tables of ``docs/`` computed from the output folders of the built-in studies:
``ftc-mj study NAME`` makes the runs, ``ftc-mj study NAME --report`` prints the tables (and writes them
to ``OUT/doc_tables.md``). One module per published table:

- :mod:`.physical_plant`, :mod:`.rate_bound`, :mod:`.reconfiguration`, :mod:`.pathfollow`,
  :mod:`.robust_ftc` — docs/findings.md; :mod:`.pathfollow_figure` draws its figure
  (``OUT/figures/pathfollow.png``, published as docs/figures/pathfollow.png);
- :mod:`.fdi`, :mod:`.pcrb` — the summary and bound tables of docs/fdi.md;
- :mod:`.findings` — the generated findings of docs/studies.md;
- :mod:`.tuning` — the data-tuned parameters of docs/studies.md (``tune_dwell``, ``tune_growth``).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path

from ...errors import BadInput


def _reports() -> dict[str, list[Callable[[Path], str]]]:
    from . import (
        fdi,
        findings,
        pathfollow,
        pathfollow_figure,
        pcrb,
        physical_plant,
        rate_bound,
        reconfiguration,
        robust_ftc,
        tuning,
    )

    out: dict[str, list[Callable[[Path], str]]] = {name: [findings.report] for name in findings.STUDIES}
    out.setdefault("reconfiguration", []).insert(0, reconfiguration.report)
    out["physical_plant"].insert(0, physical_plant.report)
    out["rate_bound"] = [rate_bound.report]
    out["pathfollow"] = out["pathfollow_fresh"] = out["pathfollow_confirm"] = [pathfollow.report]
    out["pathfollow_figure"] = [pathfollow_figure.report]
    out["robust_ftc"] = out["robust_ftc_fixed"] = [robust_ftc.report]
    out["fdi"] = [fdi.report]
    out["pcrb"] = [pcrb.report]
    for name, tuned in tuning.tuned_by_study().items():
        out[name] = [partial(tuning.report, tuned=tuned)]
    return out


def doc_table_studies() -> list[str]:
    """The built-in studies with a published table."""
    return sorted(_reports())


def doc_tables(study: str, out: Path) -> str:
    """Every published table of ``study`` from its output folder ``out`` (Markdown, as in ``docs/``)."""
    reports = _reports().get(study)
    if reports is None:
        raise BadInput(f"--report: study {study!r} has no published table (studies with one: "
                       f"{', '.join(doc_table_studies())})")
    if not Path(out).is_dir():
        raise BadInput(f"--report: {out} is not a study output folder (run `ftc-mj study {study}` first)")
    return "\n".join(r(Path(out)) for r in reports)
