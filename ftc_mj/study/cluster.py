"""The dask cluster of a study: a LocalCluster on 127.0.0.1 or a connection to a scheduler the user names.

The local cluster listens on 127.0.0.1 only (scheduler and dashboard, unless another dashboard
address is asked for); its worker processes ignore Ctrl-C, which the client alone handles (it
cancels the runs in flight and closes the cluster, one line instead of every worker's traceback).
``--address`` must name a scheduler the user trusts (it receives the run configs, its workers run
this package's code); a scheduler that does not complete dask's handshake within
:data:`HANDSHAKE_TIMEOUT_S` is a bad address.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import re
import signal
import sys
from collections.abc import Iterator
from typing import Any

from ..errors import BadInput

ADDRESS_RE = re.compile(r"^tcp://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9]([A-Za-z0-9.\-]*[A-Za-z0-9])?):(\d{1,5})$")
CONNECT_TIMEOUT_S = 5.0
HANDSHAKE_TIMEOUT_S = 6.0
"""Time (s) a scheduler at ``--address`` gets to accept the connection and answer dask's handshake."""
LOCAL_CLUSTER_CONFIG = {
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.worker.profile.enabled": False,
}
"""dask settings of a local cluster that differ from dask's defaults, each for a measured cost:

- glibc's malloc trim threshold is left to glibc (dask gives its workers ``MALLOC_TRIM_THRESHOLD_=65536``, so
  that freed memory goes back to the system at once): a run allocates and frees its small arrays every step, and
  each came back as fresh pages, about 290 000 minor page faults a run and a fifth of a worker's CPU in the kernel
  (the six built-in methods on ftc-v2 dev draws 0-19, 2 workers: 27 s of system time per worker against 1.9 s
  without it; the runs' wall time 260 s against 203 s). A value the user sets in the environment is inherited
  by the workers all the same; the per-process cache returns free pages itself (:mod:`ftc_mj.sim.cache`).
- The event loops' tick (20 ms), the scheduler's system monitor (0.5 s) and the memory monitor (0.1 s) run
  every 1, 2 and 1 s: an idle cluster of 2 workers spent 0.68 s of the client's CPU and 0.49 s of each worker's
  per 30 s with dask's intervals, 0.18 and 0.39 s with these (a 15-minute bench: about 20 s of CPU).
- dask's statistical profiler is off in the workers: it samples the running task's stack every 10 ms (holding the
  GIL while it walks it) and keeps a profile tree per second for the last ``distributed.admin.low-level-log-length``
  (1000) seconds, twice (whole and per task): on the 200-draw leaderboard the workers peaked at 564 and 561 MiB
  without it against 689 and 648 MiB with it (docs/performance.md)."""
DASHBOARD_RE = re.compile(r"^(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9]([A-Za-z0-9.\-]*[A-Za-z0-9])?)?:(\d{1,5})$")


def validate_address(address: str) -> str:
    """Check ``tcp://host:port`` (BadInput otherwise)."""
    m = ADDRESS_RE.match(address.strip())
    if not m or not (1 <= int(m.group(3)) <= 65535):
        raise BadInput(f"--address {address}: expected tcp://HOST:PORT (port 1-65535)")
    return address.strip()


def validate_dashboard(address: str) -> str:
    """``HOST:PORT`` of the dashboard; ``:PORT`` (no host) is ``127.0.0.1:PORT``, this machine only (dask
    would listen on every interface). BadInput for anything else."""
    m = DASHBOARD_RE.match(address.strip())
    if not m or int(m.group(3)) > 65535:
        raise BadInput(f"--dashboard {address}: expected HOST:PORT, e.g. 127.0.0.1:8787 (port 0 = any free port)")
    return address.strip() if m.group(1) else f"127.0.0.1:{m.group(3)}"


def probe_scheduler(address: str, timeout: float = HANDSHAKE_TIMEOUT_S) -> None:
    """Connect to a dask scheduler and complete the comm handshake within ``timeout`` s, else
    :class:`BadInput`. (``distributed.Client`` bounds only the TCP connect: a listener that accepts and
    never answers would hold it for ever.)"""
    from distributed.comm import connect

    async def handshake() -> None:
        comm = await connect(address, timeout=CONNECT_TIMEOUT_S)
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(handshake(), timeout))
    except TimeoutError:
        raise BadInput(f"--address {address}: no dask scheduler answered within {timeout:g} s (the connection "
                       "was accepted, dask's handshake never came)") from None
    except Exception as err:  # noqa: BLE001 - refused, unresolvable, not dask: all the user's address
        msg = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise BadInput(f"--address {address}: cannot reach a dask scheduler within {timeout:g} s "
                       f"({msg[:120]})") from None


@contextlib.contextmanager
def open_client(workers: int, address: str | None, dashboard: str = "127.0.0.1:0") -> Iterator[Any]:
    """A dask Client: connected to ``address`` (handshake within :data:`HANDSHAKE_TIMEOUT_S`) or to a
    fresh LocalCluster of ``workers`` single-threaded worker processes on 127.0.0.1, its dashboard at
    ``dashboard``. BadInput if the scheduler cannot be reached."""
    import dask
    from distributed import Client, LocalCluster

    os.environ.setdefault("OMP_NUM_THREADS", "1")  # inherited by local workers: IPOPT must not spin
    if address is not None:
        address = validate_address(address)
        probe_scheduler(address)
        try:
            client = Client(address, timeout=CONNECT_TIMEOUT_S)
        except Exception as err:  # noqa: BLE001 - any failure to connect is the user's address
            msg = str(err).splitlines()[0] if str(err) else type(err).__name__
            raise BadInput(f"--address {address}: cannot reach a dask scheduler within "
                           f"{CONNECT_TIMEOUT_S:g} s ({msg[:120]})") from None
        try:
            with _sync_cancel_race_dropped():
                yield client
        finally:
            client.close()
        return
    if workers < 1:
        raise BadInput("--workers: must be >= 1")
    _quiet_resource_tracker()
    with _sigint_ignored_by_children(), dask.config.set(LOCAL_CLUSTER_CONFIG):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=validate_dashboard(dashboard), silence_logs=logging.ERROR)
    client = Client(cluster)
    try:
        with _sync_cancel_race_dropped():
            yield client
    finally:
        with _quiet_distributed():
            with contextlib.suppress(Exception):  # a worker that cannot answer is closed below all the same
                client.run(_quiet_worker_logs, on_error="ignore")
            client.close()
            cluster.close()


class SyncCancelRace(logging.Filter):
    """Drops tornado's log record of one race in ``distributed.utils.sync`` (distributed 2026.8): a Ctrl-C that
    arrives before ``sync`` has started its coroutine schedules ``cancel()``, which reads the coroutine's
    ``future`` before it was assigned and raises ``NameError``; tornado logs it, with its traceback, as an
    "Exception in callback". The coroutine had not started, so there was nothing yet to cancel (it runs later
    and ends with the client, which the interrupted study closes), and the interrupted call raises
    ``KeyboardInterrupt`` all the same, which the study handles with its one line. Only that record is dropped:
    a ``NameError`` whose innermost frame is ``cancel`` in ``distributed/utils.py``."""

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info
        if not exc or not isinstance(exc[1], NameError) or exc[2] is None:
            return True
        tb = exc[2]
        while tb.tb_next is not None:
            tb = tb.tb_next
        code = tb.tb_frame.f_code
        return not (code.co_name == "cancel" and code.co_filename.replace("\\", "/").endswith("distributed/utils.py"))


class ForgottenGather(logging.Filter):
    """Drops the scheduler's "Couldn't gather keys" record when every key it names is ``forgotten``: a Ctrl-C that
    lands while the client waits for a run's result leaves that gather in flight, the interrupted study then cancels
    its runs, and the scheduler, which runs in this process for a local cluster, logs the gather of the keys it was
    just told to forget (seen once in the suite: a second line after the one-line interrupt message). A gather that
    fails for any key the scheduler still knows (a lost worker, a missing result) is kept."""

    def filter(self, record: logging.LogRecord) -> bool:
        if record.msg != "Couldn't gather keys: %s":
            return True
        states = record.args  # logging unwraps a lone non-empty mapping argument into ``args`` itself
        return not (isinstance(states, dict) and states and all(v == "forgotten" for v in states.values()))


@contextlib.contextmanager
def _sync_cancel_race_dropped() -> Iterator[None]:
    """:class:`SyncCancelRace` on tornado's callback-error logger and :class:`ForgottenGather` on the scheduler's
    logger while the client is open."""
    pairs = [(logging.getLogger("tornado.application"), SyncCancelRace()),
             (logging.getLogger("distributed.scheduler"), ForgottenGather())]
    for logger, dropped in pairs:
        logger.addFilter(dropped)
    try:
        yield
    finally:
        for logger, dropped in pairs:
            logger.removeFilter(dropped)


TRACKER_WARNING = "ignore:resource_tracker:UserWarning:multiprocessing.resource_tracker"
"""The ``-W`` filter of the warning multiprocessing's resource tracker prints when the study process was
killed (SIGKILL) before it could release its semaphores: "There appear to be N leaked semaphore objects"."""


def _quiet_resource_tracker() -> None:
    """Start multiprocessing's resource tracker with :data:`TRACKER_WARNING`: after a killed study it still
    removes the semaphores dask's processes left, without a warning that reads like a bug of the user's
    (the tracker inherits this interpreter's ``-W`` options; one started earlier keeps its own)."""
    from multiprocessing import resource_tracker

    if TRACKER_WARNING not in sys.warnoptions:
        sys.warnoptions.append(TRACKER_WARNING)
    resource_tracker.ensure_running()


@contextlib.contextmanager
def _sigint_ignored_by_children() -> Iterator[None]:
    """Ignore SIGINT while worker processes are started: they inherit the disposition (Python keeps an
    inherited SIG_IGN), so a Ctrl-C in the terminal reaches only this process."""
    try:
        old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread: nothing to change
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


QUIET_LOGGERS = ("distributed", "tornado", "asyncio")
"""The loggers silenced while a local cluster is torn down."""


def _quiet_worker_logs() -> None:
    """Run on each local worker before the cluster closes: a worker still computing a cancelled run (after a
    Ctrl-C) outlives the scheduler by that run's length, and its heartbeat's "Failed to communicate with
    scheduler" traceback is the expected end, not news for the user (seen: 31 lines after the one-line
    interrupt message)."""
    names = [n for n in list(logging.root.manager.loggerDict) if n.split(".")[0] in QUIET_LOGGERS]
    for name in {*QUIET_LOGGERS, *names}:  # children with a level of their own (dask sets tornado.application's)
        logging.getLogger(name).setLevel(logging.CRITICAL)


@contextlib.contextmanager
def _quiet_distributed() -> Iterator[None]:
    """Silence distributed's and tornado's log lines while the cluster is torn down (closing comms of
    cancelled runs are expected)."""
    loggers = [logging.getLogger(n) for n in QUIET_LOGGERS]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for lg, lv in zip(loggers, levels, strict=True):
            lg.setLevel(lv)
