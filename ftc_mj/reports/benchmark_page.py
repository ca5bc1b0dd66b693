"""``ftc-mj bench … --publish DOCS``: ``DOCS/benchmark.md`` — what the benchmark is, its distributions
(generated from the definition), the seeds used for what, and the report of the invocation (the
leaderboard on the test split), with its figures copied to ``DOCS/figures/benchmark/``."""

from __future__ import annotations

import json
import shlex
import shutil
from pathlib import Path
from typing import Any

from ..benchmark.definition import BenchmarkDefinition, Range, load_definition
from ..benchmark.methods import BUILTIN, REFERENCE_ROWS
from ..errors import BadInput
from ..io import atomic_path
from ..markdown import table

FULL_RUN = ("ftc-mj bench paper safe pathfollow hybrid passive feedback-off --split test --draws 200 --workers 2 "
            "--publish docs")
"""The command that writes the leaderboard of the built-in methods into docs/benchmark.md: 1200 runs of 30 s, 3768 s
on 2 Dask workers of this project's 2-core machine (2026-12-03, the machine otherwise nearly idle); a run of the
path-following or the robust NMPC takes 3–4 times one of the nominal NMPC. Resumable: a killed run loses only the
runs in flight."""
PUBLISH_ROWS = ("paper", "safe", "pathfollow", "hybrid", "passive", "feedback-off", "oracle", "standstill")
"""The rows of a published leaderboard from ``ftc-v2`` on: every built-in method and the two reference rows."""


def full_run(d: BenchmarkDefinition) -> str:
    """The ONE command that writes version ``d``'s leaderboard into docs/benchmark.md: ``ftc-v1``'s as published
    (:data:`FULL_RUN`), later versions' with every built-in method plus ``oracle`` and ``standstill`` on the test
    split's fixed leaderboard draws."""
    if d.version == "ftc-v1":
        return FULL_RUN
    return (f"ftc-mj bench {' '.join(PUBLISH_ROWS)} --benchmark {d.version} --split test --draws "
            f"{d.leaderboard_draws or 200} --workers 2 --publish docs")


HEALTHY_CHECK = (
    "**Healthy-path check.** The ranges were chosen so that the healthy robot follows every drawn path: "
    "`ftc-mj bench feedback-off --healthy --draws 40 --workers 1` (the nominal NMPC with the actuation-rate "
    "term, every dev draw 0–39 without its faults, 2026-12-03) stayed within 0.19 m of the path from 5 s on in "
    "all 40 draws (largest in draw 24, a figure-eight of 50 m lobes at 8.2 m/s; bound 0.5 m, the success rule; "
    "mean of the 40 largest errors 0.096 m), with no lift-off and no tip-over. Paths: "
    "circles of 40–120 m, figure-eights of 50–80 m lobes and straight lines; lines with turns are not a "
    "built-in reference (a figure-eight reverses its curvature instead).")


def _r(r: Range, unit: str = "", digits: int = 3) -> str:
    return f"{r.low:.{digits}g}–{r.high:.{digits}g}{' ' + unit if unit else ''}"


def definition_tables(d: BenchmarkDefinition) -> list[str]:
    """The distributions of the definition as Markdown tables (units in the cells)."""
    f, p, pa, s = d.fault, d.plant, d.path, d.sensors
    lines = [f"Benchmark `{d.version}` (`ftc_mj/data/benchmarks/{d.version}.toml`), runs of {d.duration:g} s.", "",
             *table(["fault class", "probability"], ([c, f"{v:g}"] for c, v in f.classes.items())), ""]
    factors = [
        ("second fault", f"probability {f.double:g} given a first; another target, {_r(f.second_delay, 's')} later"),
        ("onset of the first fault", f"uniform {_r(f.onset, 's')}"),
        ("step puncture: remaining radius", f"uniform {_r(f.puncture_fraction)} of nominal"),
        ("ramp puncture: final radius, rate",
         f"uniform {_r(f.ramp_final_fraction)} of nominal; {_r(f.ramp_rate, 'm/s')}"),
        ("servo loss of effectiveness", f"remaining gain and torque uniform {_r(f.effectiveness)}"),
        ("speed bias / drift", f"± uniform {_r(f.speed_bias, 'm/s')} / ± {_r(f.speed_drift, 'm/s²')}"),
        ("gyro bias / drift", f"± uniform {_r(f.gyro_bias, 'rad/s')} / ± {_r(f.gyro_drift, 'rad/s²')}"),
        ("sensor dropout", f"uniform {_r(f.dropout_duration, 's')}"),
        ("tyre friction", f"uniform {_r(p.tyre_friction)}"),
        ("servo gain", f"uniform {_r(p.actuator_gain, 'N m s/rad', 5)}"),
        ("payload mass; centre (forward, left, up from the axle)", f"uniform {_r(p.payload_mass, 'kg')}; "
         f"{_r(p.payload_offset_x, 'm')}, {_r(p.payload_offset_y, 'm')}, {_r(p.payload_offset_z, 'm')}"),
        ("path", ", ".join(f"{k} {v:g}" for k, v in pa.kinds.items()) + "; circle radius one of "
         f"{', '.join(f'{r:g}' for r in pa.circle_radius)} m, figure-eight lobe one of "
         f"{', '.join(f'{r:g}' for r in pa.figure8_radius)} m; counter-clockwise {pa.direction_ccw:g}"),
        ("desired speed", f"uniform {_r(pa.speed, 'm/s')}, capped at √({pa.max_lateral_accel:g} m/s² × radius)"),
        ("speed sensor σ", f"uniform {_r(s.speed_sigma, 'm/s')}"),
        ("yaw-rate gyro", f"present with probability {s.gyro:g} (always with a gyro fault); σ log-uniform "
         f"{_r(s.gyro_sigma, 'rad/s')}"),
        ("pose noise σ (controller's pose)", f"uniform {_r(s.pose_sigma, 'm (and rad)')}")]
    return lines + table(["factor", "distribution"], factors + pose_sensor_rows(d))


def pose_sensor_rows(d: BenchmarkDefinition) -> list[tuple[str, str]]:
    """The pose sensor's and the pose faults' rows of a definition that has them (``ftc-v2`` on)."""
    s, ranges = d.sensors, d.fault.ranges
    if s.pose_fix_sigma is None or s.pose_fix_rate is None:
        return []
    rows = [("pose sensor (the controller's pose, through the filter; the pose noise above is then unused)",
             f"σ uniform {_r(s.pose_fix_sigma, 'm')} on x and y (heading: that per metre, rad), fixes at uniform "
             f"{_r(s.pose_fix_rate, 'Hz')}")]
    if "pose_bias" in ranges:
        rows.append(("pose bias", f"± uniform {_r(ranges['pose_bias'], 'm')} along the 45° diagonal, to the end"))
    if "pose_jump" in ranges:
        rows.append(("pose jump", f"± uniform {_r(ranges['pose_jump'], 'm')} along the 45° diagonal for uniform "
                                  f"{_r(ranges['pose_jump_duration'], 's')}"))
    return rows


INFORMATION_RULE = (
    "## Information rule", "",
    "A method sees what a real robot would: the **nominal robot** (the MJCF with the model's geometry — never the "
    "drawn tyre friction, payload or servo gain, nor which simulator runs), the **path**, and its **sensors** — the "
    "same measurements for estimator and controller. Enforced by construction: the path-following NMPC's lift-off "
    "bound, braking trade and yaw compliance come from the nominal robot (`ftc_mj.sim.cache.robot_limits`); the "
    "degraded mode's `auto` is armed by evidence on the measurements (the measured wheel rates leaving their "
    "commands: the tyres can be dragged), not by the simulator kind; the `truth` policy needs `oracle = true`. "
    "A test builds every built-in method on two draws that differ only in friction, payload, servo gain and plant "
    "kind and finds every number its components receive bitwise equal (`tests/benchmark/test_information_rule.py`).",
    "",
    "From `ftc-v2` on, every draw has a **pose sensor** (fixes of x, y and heading at a drawn σ and rate): they "
    "are the filter's measurements (x, y and the heading, its innovation wrapped to [-π, π)), and the "
    "controller's pose is the filter's pose estimate, which has taken in the fixes so far and carries them "
    "forward with the measured wheel rates between fixes and through a dropout (`sensors.pose_source = \"sensor\"`; "
    "without a filter, the last fix held). Pose faults — bias, jump, dropout — hit those fixes, hence estimator "
    "and controller alike. `ftc-v1` draws keep the controller's pose of the paper (the true pose + `pose_sigma` "
    "noise, untouched by sensor faults). Why the filter's pose: it is the one fusion of every measurement the "
    "method has, and it carries the pose between fixes and through a dropout; the price is that whatever the "
    "filter absorbs reaches the controller too, as on a real robot. Two defences: the fix's **heading** is fused "
    "(it holds the heading against a gyro bias), and a **χ² gate** rejects a fix whose x, y lie beyond the χ² "
    "quantile (2 dof) of false-rejection probability `estimator.pose_gate` (1e-4 per fix) of the filter's "
    "prediction; the heading is always fused (no pose fault moves it, and it keeps the dead reckoning straight "
    "while the position is gated). Rejected fixes are counted (trace column `pose_rejected`, metric "
    "`filter_pose_rejections`): the evidence of a pose fault. A streak of rejections is judged against the "
    "covariance of its first fix, not the prediction's, which grows while no fix is taken in (with the filters' "
    "default process noise, 0.25 m²/s on x and y, the gate would otherwise open by itself after about a second "
    "and let a 2 m jump through); and it cannot last: after `estimator.pose_gate_reacquire` (2 s) the next fix is "
    "fused whatever its distance, the covariance grown over the streak taking the filter most of the way to it — "
    "the filter cannot tell a lasting offset of its only pose source from its own drift, so it believes the "
    "sensor, and the streak and the re-acquisition are what a diagnoser sees of a pose bias (a controller on that "
    "pose then follows the biased fixes). A jump shorter than 2 s is rejected whole; a longer one costs 2 s of "
    "rejections at its start and again at its end. Measured in scenario 1 (the healthy 50 m circle at 10 m/s; "
    "pose fixes σ 0.03 m at 10 Hz, `pose_source = \"sensor\"`) with a 2 m jump of the fixes at 15 s: lasting 3 s, "
    "ungated the filter's pose followed it at once (2.1 m off) and the cross-track error reached 1.59 m, gated 40 "
    "fixes were rejected and it reached 1.06 m; lasting 1 s, ungated it followed it 2.0 m off and the cross-track "
    "error reached 1.46 m, gated its 10 fixes were rejected, the filter's pose stayed within 0.14 m of the truth "
    "and the cross-track error within 0.43 m. Measured on `ftc-v2` dev draws 0–9 (`ftc-mj bench safe pathfollow "
    "--benchmark ftc-v2 --split dev --draws 10`, 2026-12-06): `safe` and `pathfollow` succeed on 7 of 10 each (6 "
    "of 10 each without the heading and the gate): the gyro-bias draw 0 now ends within 0.20–0.23 m (was 1.3–1.5 "
    "m), draw 7 within 0.51–0.59 m (was 1.3–1.6 m; the filters have no gyro-bias state, and that draw's heading "
    "fixes, σ 0.05 rad, hold the heading to 0.05 rad on average); no fix was rejected on draws 3, 6 and 7.", "",
    "**The oracle** (`oracle = true`, a run-config flag set only by the benchmark's oracle row and by studies "
    "that compare against an oracle) is told the truth — the drawn plant's limits and the `truth` policy's true "
    "radii — so the rule does not bind it: it is a ceiling, not a method.")
"""The page's section on what a method may see (docs/benchmark.md)."""


HEALTHY_CHECK_V2 = (
    "**Healthy-path check of ftc-v2** (the same ranges as ftc-v1, new draws, the progress rule): "
    "`ftc-mj bench feedback-off --healthy --benchmark ftc-v2 --draws 20 --workers 1` (the nominal NMPC, dev draws "
    "0–19 without their faults, 2026-12-06) succeeded on all 20 under the progress rule: within 0.22 m of the path "
    "from 5 s on (largest in draw 0, a 40 m circle at 7.6 m/s; mean of the 20 largest errors 0.098 m), progress at "
    "least 99.99 % of the desired speed times the window, no lift-off, no tip-over.")


def healthy_check(d: BenchmarkDefinition) -> str:
    """The healthy-path check's paragraph: ftc-v1's, and ftc-v2's beside it from ftc-v2 on."""
    return HEALTHY_CHECK if d.version == "ftc-v1" else HEALTHY_CHECK + "\n\n" + HEALTHY_CHECK_V2


POWER_DISCORDANCES = (0.05, 0.1, 0.2, 0.3)
"""Shares of draws on which two methods disagree that the page's power table covers (ftc-v1's questions
showed 1–58 %)."""


def power_section(d: BenchmarkDefinition) -> list[str]:
    """The analysis that fixes a version's leaderboard draw count (``leaderboard_draws``): for a 5-point paired
    success difference at 80 % power after Holm over the page's verdicts, the draws needed at several
    discordances, and the power of the version's fixed count there (exact conditional binomial test,
    :func:`~ftc_mj.benchmark.stats.mcnemar_power`)."""
    from ..benchmark.report import QUESTIONS, VERDICT_SCORES
    from ..benchmark.stats import ALPHA, POWER_DIFFERENCE, POWER_TARGET, draws_for_power, mcnemar_power

    k = len(QUESTIONS) * len(VERDICT_SCORES)
    n = d.leaderboard_draws
    body = [[f"{100 * psi:g} %", draws_for_power(POWER_DIFFERENCE, psi, k),
             "—" if n is None else f"{100 * mcnemar_power(n, POWER_DIFFERENCE, psi, ALPHA, k):.0f} %"]
            for psi in POWER_DISCORDANCES]
    fixed = (f"`{d.version}` fixes `leaderboard_draws = {n}`" if n is not None
             else f"`{d.version}` fixes no leaderboard draw count")
    return [f"A version's leaderboard draw count is fixed in advance in its definition, never chosen from its "
            f"results. The analysis: the exact McNemar test at {ALPHA:g}/{k} (Holm's first step over the page's {k} "
            f"verdicts) should find a {100 * POWER_DIFFERENCE:g}-point paired success difference with "
            f"{100 * POWER_TARGET:g} % power; its exact power sums the conditional binomial test over the "
            "discordant count. " + fixed + (_why_count(d) if n is not None else "."), "",
            *table(["draws on which two methods disagree", f"draws for {100 * POWER_TARGET:g} % power",
                    f"power of {n} draws" if n is not None else "power of the fixed count"], body)]


def _why_count(d: BenchmarkDefinition) -> str:
    """Why the version's fixed count is what it is (``ftc-v1``: kept as published; later: the design discordance)."""
    if d.version == "ftc-v1":
        return (" (set before this rule and kept: it is published), which resolves only large differences; every "
                "question on the page prints its achieved power.")
    return (", chosen before any of its runs: 80 % power at a design discordance of 10 % (ftc-v1's questions showed "
            "1–58 %); at larger discordances it resolves only larger differences, and every question on the page "
            "prints its achieved power.")


def judge_section(d: BenchmarkDefinition) -> list[str]:
    """The success rule of version ``d`` (its ``[judge]`` table) as the page's text."""
    j = d.judge
    if j.rule != "progress":
        return ["## Success rule", "", f"`{d.version}` judges a run by the rule it was published with, "
                "`near-path`: the run completed, never tipped, and stayed within 0.5 m of the path from 5 s after "
                "the last fault onset. (It takes a robot that never starts as a success: `ftc-v2` asks for "
                "progress.)"]
    return ["## Success rule", "",
            f"`{d.version}` judges by the rule `progress` (`[judge]` of its definition; "
            "`ftc_mj.benchmark.judge`). Every draw is labelled **trackable** or **stop-only** from its truth alone — "
            "the drawn plant read from the MJCF (masses, payload, tyre loads, friction, servo torque limit), the "
            "drawn faults and the path; never from a run, the same on every CPU (`ftc_mj.benchmark.attainability`): "
            "each tyre's available force, the servo's torque (scaled by a loss; none when unresponsive) at the "
            "tyre's radius or its traction μ(N₀ − k a), must cover the couple that turns the robot on the path's "
            f"curvature, M a x_G / (2b), plus a control reserve of {0.1:g} m/s² of half the mass; a locked wheel adds "
            "its tyre's sliding friction μ N₀ to the other tyre's demand (the other motor drags it: 1500 N m / 2 m = "
            "750 N against μ N₀, 907–1789 N over ftc-v2's dev draws 0–99 by `drive_robot`: no lock is "
            "trackable). The largest speed that satisfies this "
            "on every curvature of the path and the wheel-rate limit with the damaged radii, capped at the desired "
            f"speed, is the *attainable speed*; a draw is trackable when it is at least "
            f"{100 * j.trackable_speed_fraction:g} % of the desired speed.", "",
            "**Trackable draws**: from 5 s after the last onset (fault-free: from 5 s) to the end, the run "
            "completed, never tipped, stayed within 0.5 m of the path, *and* its progress along the path — the arc "
            "length of the true position's projection, tracked locally from the previous projection so that it is "
            "unwrapped on closed paths and continuous through a figure-eight's crossing — is at least "
            f"{100 * j.progress_fraction:g} % of the attainable speed times the window. A robot that never starts, "
            "or crawls, fails.", "",
            "**Stop-only draws**: from 5 s to the *disabling onset* (the first onset after which the faults so far "
            "make the draw stop-only; 5 s after any earlier onset left out), within 0.5 m of the path and "
            f"progressing ({100 * j.progress_fraction:g} % of the speed attainable before it); then never tipped, "
            f"inside {j.corridor:g} m of the path, and at rest (|v| < {j.stop_speed:g} m/s) from "
            f"{j.stop_within:g} s after the onset to the end.", "",
            "**Reference rows** (not methods; the information rule does not bind them): `oracle`, the path-following "
            "NMPC told the truth (the truth policy's radii from each onset, the run flag `oracle = true`: the drawn "
            "plant's limits) — a ceiling whose failures on trackable draws are listed (there the physics rule or the "
            "oracle is wrong); `standstill`, zero command — a floor that fails every trackable draw and every "
            "stop-only draw whose fault comes after 5 s. Each method's success on trackable draws is also given as "
            "a fraction of the oracle's, with an interval joining two exact Clopper–Pearson intervals at 97.5 % "
            "(Bonferroni: coverage ≥ 95 % whatever the pairing, so never anti-conservative).", "",
            "**Every fault counts**: a draw's classes are all its faults (a draw with two faults counts in both "
            "per-class rows); the difficulty tiers (gyro or not; no, one or two faults; trackable or stop-only) "
            "are reported."]


METHOD_FILE = (
    "**Your own method** (`docs/tutorial-benchmark.md` of the source repository scores one step by step): a "
    "method file, e.g. `examples/blend_policy.toml`, is TOML with `name`, an optional `description`, optional "
    "`plugins` (modules registering plug-in components, found in the method file's folder or installed) and a "
    "`[settings]` table of run-config keys (dotted or nested) of the sections estimator, controller, "
    "reconfiguration and model only — the draw sets the faults, plant, sensors, path, duration and seed. "
    "`ftc-mj bench FILE feedback-off --out OUT` scores it beside a built-in; naming another method with the same "
    "`--out` later computes only that method's runs.",
)
"""The method-file paragraph of the page (also in ``ftc-mj bench --help``)."""


def builtin_settings(rows: dict[str, tuple[str, dict[str, Any]]] = BUILTIN, head: str = "built-in method"
                     ) -> list[str]:
    """The built-in methods' settings (the ``[settings]`` of an equivalent method file), one row each; with
    ``rows`` = :data:`~ftc_mj.benchmark.methods.REFERENCE_ROWS`, the reference rows' (``oracle`` only they set)."""
    return table([head, "settings"],
                 ([k, ", ".join(f"`{key} = {json.dumps(v)}`" for key, v in settings.items())]
                  for k, (_desc, settings) in rows.items()))


def publish(docs: Path, report: Path, out: Path, argv: list[str], version: str) -> Path:
    """Write ``docs/benchmark.md`` (module docstring) from the finished bench in ``out``; returns its path."""
    if not docs.is_dir():
        raise BadInput(f"--publish: {docs} is not an existing folder")
    d = load_definition(version)
    fig_dir = docs / "figures" / "benchmark"
    fig_dir.mkdir(parents=True, exist_ok=True)
    for png in sorted((out / "figures").glob("*.png")):
        shutil.copyfile(png, fig_dir / png.name)
    body = report.read_text().replace("](figures/", "](figures/benchmark/")
    body = "\n".join(("#" + ln) if ln.startswith("#") else ln for ln in body.splitlines())
    text = "\n".join([
        "# The ftc-mj benchmark", "",
        f"Generated by `{shlex.join(['ftc-mj', *argv])}`; do not edit by hand.", "",
        "A method — estimator, decision rule, reconfiguration policy and controller, built-in or a method file "
        "(`name`, `[settings]` of the sections estimator, controller, reconfiguration, model) — is scored on "
        "draws of faults and conditions. A draw is a pure function of (version, split, index): "
        f"`ftc_mj.benchmark.draws.draw(split, index, \"{d.version}\")`. Built-in methods: "
        + "; ".join(f"`{k}`: {v[0]}" for k, v in BUILTIN.items()) + ". Reference rows: "
        + "; ".join(f"`{k}`: {v[0]}" for k, v in REFERENCE_ROWS.items()) + ".", "",
        f"This page is regenerated by one command: `{full_run(d)}`.", "",
        *METHOD_FILE, "", *builtin_settings(), "", *builtin_settings(REFERENCE_ROWS, "reference row"), "",
        "## Seeds", "",
        f"The `dev` split's run seeds lie in {int(d.seeds.dev.low)}–{int(d.seeds.dev.high) - 1} and the `test` "
        f"split's from {int(d.seeds.test.low)} "
        "(different entropies in the definition: disjoint streams). Develop and tune on `dev`; a study flagged "
        "`tuning = true` (tune_dwell, tune_growth, robust_hybrid_dev) refuses seeds ≥ 1000, and the leaderboard "
        "shows test-split results only, each with its method's digest (its resolved settings and its code: the "
        "ftc-mj version and source revision, each plug-in module's content) and the package version.", "",
        "The `private` split's draws come from a key given at run time (`FTC_MJ_PRIVATE_KEY` or `--key-file`): "
        "each draw's stream is seeded by HMAC-SHA256 of the version and index under the key, so neither this "
        "repository nor a bench's outputs (which keep only the key's SHA-256 id) reproduce them; without a key "
        "`--split private` exits 2. A test or private leaderboard lists, per method identity, the date of its "
        "first run on the split and how many times it has been scored there (the output folder's log).", "",
        *INFORMATION_RULE, "",
        "## Draw count and power", "", *power_section(d), "",
        "## Distributions", "", *definition_tables(d), "", healthy_check(d), "",
        *judge_section(d), "",
        *([] if "--split test" in " ".join(argv) and "--healthy" not in argv else
          ["**Leaderboard.** Not generated yet: the leaderboard shows test-split results only; "
           f"`{full_run(d)}` writes it into this page.", ""]),
        body])
    path = docs / "benchmark.md"
    with atomic_path(path) as tmp:
        tmp.write_text(text + "\n")
    return path


def argv_of(**opts: Any) -> list[str]:
    """The command line of a bench invocation (for the generated page's header)."""
    args = list(opts.pop("methods"))
    for k, v in opts.items():
        if v is True:
            args.append(f"--{k}")
        elif v not in (None, False):
            args += [f"--{k}", str(v)]
    return ["bench", *args]
