"""Readers, writers and validation of session inputs (DATA.md; docs/formats.md).

Every format is one small module; trajectory readers sit in ``registry``; ``session``
reads a whole session into one :class:`~coopproc.model.Session`.
"""

from coopproc.io.csv_traj import read_traj_csv, write_traj_csv
from coopproc.io.mcap_write import write_mcap
from coopproc.io.ranges_csv import read_ranges_csv, write_ranges_csv
from coopproc.io.rtklib_pos import read_pos, write_pos
from coopproc.io.session import inspect_session, read_session, validate_session
from coopproc.io.session_toml import McapMapping, read_session_toml, write_session_toml
from coopproc.io.tum import read_tum, write_tum
from coopproc.io.writers import session_to_gpst, write_reference_pos, write_session

__all__ = [
    "McapMapping",
    "inspect_session",
    "read_pos",
    "read_ranges_csv",
    "read_session",
    "read_session_toml",
    "read_traj_csv",
    "read_tum",
    "session_to_gpst",
    "validate_session",
    "write_mcap",
    "write_pos",
    "write_ranges_csv",
    "write_reference_pos",
    "write_session",
    "write_session_toml",
    "write_traj_csv",
    "write_tum",
]
