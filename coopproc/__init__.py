"""coopproc: post-processing of recorded cooperative-positioning logs.

Readers (``coopproc.io``) turn a session directory or MCAP file into a validated
:class:`coopproc.model.Session`; stages (``coopproc.stages``) clean the UWB ranges,
detect and estimate NLOS errors and fuse the platforms' positions; reporters
(``coopproc.report``) write the tables and figures of paper 000.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("coopproc")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
