"""Exceptions shared by every layer.

:class:`BadInput` is raised for anything a user wrote wrongly (config files, CLI arguments, model
files, study files, cluster addresses). The CLI turns it into one line on stderr and exit code 2.
The ``EXIT_*`` constants are the CLI's exit codes.
"""

from __future__ import annotations


class BadInput(ValueError):
    """A user-supplied input is invalid; ``str()`` is the one-line message naming the field."""


class RunFailed(RuntimeError):
    """A simulation run failed for a reason that is recorded (CLI exit code 1)."""


class OutputError(RunFailed):
    """The results could not be written (a full disk, a folder removed during the run); nothing of them
    was kept (CLI exit code 1, one line)."""


EXIT_OK = 0
"""The command did what was asked."""
EXIT_FAILED = 1
"""A run failed (its reason is in ``metrics.json``), or its output could not be written."""
EXIT_BAD_INPUT = 2
"""Bad input: one line on stderr naming the field or option; nothing written."""
EXIT_UNSTABLE = 3
"""The run's physics became unstable (status ``unstable``): its metrics are not results."""
EXIT_INTERRUPTED = 130
"""Interrupted (Ctrl-C); finished work is kept."""
