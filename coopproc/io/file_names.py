"""Which files of a session directory are its files: letter case, copies, backups.

People keep copies beside a recording (``nav_A_backup.csv``, ``nav_A (copy).csv``,
``nav_A.csv.bak``, ``ref_B_old.pos``). Read as files of their own they would make phantom
platforms, so discovery (:func:`coopproc.io.registry.find_files`) ignores them, each with a
note:

- a name that starts like a session file (``nav_``, ``ref_``, ``ranges``, any case) but is
  not one (an id that is no platform id, another suffix) is ignored, naming the session
  file it looks like a copy of;
- an id that ends in a copy word (``A_backup``, ``A-old``, ``A_copy2``: :data:`COPY_WORDS`
  after ``_``, ``-``, ``.`` or a space, digits allowed after it) is ignored unless
  session.toml declares ``[platforms.<that id>]``;
- when session.toml declares platforms, an undeclared id that starts with a declared id
  and a separator (``A_2`` beside a declared ``A``) is ignored too, naming that id.

A file named by session.toml ``[files]`` is always read. Suffixes and the ``nav_`` /
``ref_`` / ``ranges`` prefixes are recognised in any letter case (``NAV_A.CSV`` is the
navigation of platform ``A``: ids keep their case).
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable, Sequence
from pathlib import Path

from coopproc.errors import InputError

__all__ = [
    "COPY_WORDS",
    "copy_id_note",
    "default_ranges",
    "find_sensor_files",
    "sensor_file_name",
    "sensor_platform",
    "unrecognised_note",
]

#: Words that mark a copy when an id ends in them (after a separator, digits may follow).
COPY_WORDS = ("backup", "bak", "old", "copy", "orig", "tmp", "temp", "save", "saved", "prev")
_COPY_ID = re.compile(rf"\A(?P<base>.+?)[_\-. ](?P<word>{'|'.join(COPY_WORDS)})\d*\Z", re.I)
_PREFIXES = ("nav_", "ref_", "ranges")
_RANGES = ("ranges.csv", "ranges.csv.gz")


def unrecognised_note(path: Path, recognised: Iterable[str]) -> str | None:
    """The note for a file that starts like a session file but is not one, else None."""
    name = path.name.lower()
    if not name.startswith(_PREFIXES):
        return None
    like = difflib.get_close_matches(path.name, sorted(recognised), n=1, cutoff=0.5)
    copy = f"a copy of {like[0]}?" if like else "not nav_<ID>.<ext>, ref_<ID>.<ext> or ranges.csv"
    return (
        f"{path}: ignored: not a session file name ({copy}); rename it, or name it in "
        "session.toml [files], to read it"
    )


def copy_id_note(path: Path, pid: str, declared: Sequence[str]) -> str | None:
    """The note for a nav/ref file whose id marks a copy (module doc), else None."""
    if pid in declared:
        return None
    m = _COPY_ID.match(pid)
    longest_first = sorted(declared, key=len, reverse=True)
    base = next((d for d in longest_first if re.match(rf"{re.escape(d)}[_\-. ]", pid)), None)
    if m is None and base is None:
        return None
    if base is None and m is not None:
        base = m["base"]
    why = f"'{pid}' looks like a copy of {base}'s file"
    if declared:
        close = difflib.get_close_matches(pid, sorted(declared), n=1, cutoff=0.0)
        nearest = base if base in declared else (close[0] if close else "")
        why = f"platform '{pid}' is not declared in session.toml [platforms]" + (
            f" (a copy of {nearest}'s file?)" if nearest else ""
        )
    return f"{path}: ignored: {why}; declare [platforms.{pid}] in session.toml to read it"


def default_ranges(root: Path) -> tuple[Path | None, InputError | None]:
    """``ranges.csv`` (else ``ranges.csv.gz``) in any letter case; two case variants: error."""
    for name in _RANGES:
        if (root / name).is_file():
            return root / name, None
    found = sorted(p for p in root.iterdir() if p.name.lower() in _RANGES and p.is_file())
    if len(found) > 1:
        names = ", ".join(p.name for p in found)
        return None, InputError(root, f"several ranges files ({names}); expected one")
    return (found[0] if found else None), None


def sensor_file_name(prefix: str) -> re.Pattern[str]:
    """The names of a raw-sensor file kind: ``<prefix>_<ID>.csv`` or ``.csv.gz``."""
    return re.compile(rf"^{re.escape(prefix)}_(?P<id>[A-Za-z0-9_-]+?)\.csv(\.gz)?$")


def sensor_platform(path: Path, name: re.Pattern[str]) -> str:
    """The platform of a raw-sensor file named by ``name``; the file's stem otherwise."""
    m = name.match(path.name)
    return m["id"] if m else path.name.split(".")[0]


def find_sensor_files(session_dir: Path, name: re.Pattern[str]) -> dict[str, Path]:
    """The files of a session directory named by ``name``, by platform id (sorted)."""
    found: dict[str, Path] = {}
    for path in sorted(Path(session_dir).iterdir()):
        m = name.match(path.name)
        if m and path.is_file():
            found.setdefault(m["id"], path)
    return found
