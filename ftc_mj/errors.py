"""Exceptions shared by every layer.

:class:`BadInput` is raised for anything a user wrote wrongly (config files, CLI arguments, model
files, study files, cluster addresses). The CLI turns it into one line on stderr and exit code 2.
"""

from __future__ import annotations


class BadInput(ValueError):
    """A user-supplied input is invalid; ``str()`` is the one-line message naming the field."""


class RunFailed(RuntimeError):
    """A simulation run failed for a reason that is recorded (CLI exit code 1)."""
