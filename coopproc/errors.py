"""The one error root of coopproc and its few subclasses.

Every error a user can cause is a :class:`CoopprocError`. The CLI prints its message on
one line and exits non-zero; ``--debug`` shows the traceback. Messages name the file,
line or column, what was found and what was expected.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["ConfigError", "CoopprocError", "InputError", "OutputError", "StageError"]


class CoopprocError(Exception):
    """Root of every error coopproc raises on purpose."""


class InputError(CoopprocError):
    """A file (or a record in it) that cannot be read or does not validate.

    ``InputError(path, "problem", line=12)`` renders as ``path:12: problem``; ``record``
    (e.g. an MCAP message index or a channel) may be given instead of a line.
    """

    def __init__(
        self,
        path: str | Path | None,
        message: str,
        *,
        line: int | None = None,
        record: str | None = None,
    ) -> None:
        self.path = None if path is None else str(path)
        self.line = line
        self.record = record
        self.problem = message
        where = self.path or "<input>"
        if line is not None:
            where = f"{where}:{line}"
        elif record is not None:
            where = f"{where} ({record})"
        super().__init__(f"{where}: {message}")


class ConfigError(CoopprocError):
    """A configuration (session.toml or a run config) with a wrong key or value."""


class StageError(CoopprocError):
    """A processing stage that cannot run on the data it was given."""


class OutputError(CoopprocError):
    """An output that cannot be written (existing directory without --force, ...)."""
