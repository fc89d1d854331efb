"""Fast decoding of a JSON MCAP channel whose messages are flat objects with one key order.

Recorders write every message of a channel with the same keys in the same order. Then
the channel is a CSV table in disguise: each ``"key":`` is replaced by a marker byte, the
markers are checked to appear exactly once per message and in order (vectorized), and
the remaining values are parsed by pandas' C CSV parser (pandas >= 3 parses floats
exactly, the same floats ``json.loads`` gives; a test checks it). Anything else (nested
values, escapes, differing keys, newlines inside messages) returns None and the caller
decodes message by message.
"""

from __future__ import annotations

import io
import json

import numpy as np
import pandas as pd

from coopproc.io.mcap_scan import Channel

__all__ = ["fast_json_frame"]

_FIRST_MARKER = 14  # control bytes 14..31 never occur raw in valid JSON
_MAX_KEYS = 32 - _FIRST_MARKER


def fast_json_frame(ch: Channel) -> pd.DataFrame | None:
    """The channel's messages as a DataFrame (one column per key), or None if not flat."""
    n = len(ch)
    if n < 2:
        return None
    try:
        row0 = json.loads(ch.buffer[int(ch.starts[0]) : int(ch.ends[0])])
    except (ValueError, UnicodeError, RecursionError):
        return None
    if not isinstance(row0, dict) or not 0 < len(row0) <= _MAX_KEYS:
        return None
    if any(isinstance(v, dict | list) for v in row0.values()):
        return None
    blob = ch.joined(b"\n")
    counts = np.bincount(np.frombuffer(blob, np.uint8), minlength=256)
    if counts[ord("\n")] != n - 1 or counts[ord("\\")] or counts[_FIRST_MARKER:32].any():
        return None
    if counts[ord("{")] != n or counts[ord("}")] != n:
        return None
    keys = list(row0)
    for j, key in enumerate(keys):
        blob = blob.replace(json.dumps(key).encode() + b":", bytes([_FIRST_MARKER + j]))
    view = np.frombuffer(blob, np.uint8)
    markers = view[(view >= _FIRST_MARKER) & (view < _FIRST_MARKER + len(keys))]
    expected = np.tile(np.arange(_FIRST_MARKER, _FIRST_MARKER + len(keys), dtype=np.uint8), n)
    if markers.size != expected.size or not np.array_equal(markers, expected):
        return None
    strip = bytes(range(_FIRST_MARKER, _FIRST_MARKER + len(keys))) + b"{}"
    text = blob.translate(None, strip)
    dtypes = {k: str for k, v in row0.items() if isinstance(v, str)}
    try:
        frame = pd.read_csv(
            io.BytesIO(text),
            header=None,
            names=keys,
            dtype=dtypes,  # type: ignore[arg-type]
            skipinitialspace=True,
            keep_default_na=False,
            na_values=["null", "NaN"],
            true_values=["true"],
            false_values=["false"],
            engine="c",
        )
    except (ValueError, pd.errors.ParserError, UnicodeError):
        return None
    if len(frame) != n:
        return None
    return frame
