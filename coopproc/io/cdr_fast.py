"""Vectorized reading of ROS 2 (CDR) messages whose byte layout is the same in every message.

A channel's messages usually differ only in their numbers: the strings (frame ids) have
the same length in every message, and there are no variable-length sequences. Then every
field sits at the same byte offset in every message, and a field of all messages is one
numpy gather. :func:`plan` parses the ``ros2msg`` schema, lays out the first message
(CDR alignment rules: each primitive aligned to its size, counted after the 4-byte
encapsulation header) and returns None when the layout is not fixed (sequences, wstring,
big-endian data, messages of different lengths); the caller then decodes message by
message with mcap_ros2. Each string's length word is verified in every message.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from coopproc.io.mcap_scan import Channel

__all__ = ["CdrPlan", "plan"]

_PRIMITIVES: dict[str, str] = {
    "bool": "u1",
    "byte": "u1",
    "char": "u1",
    "uint8": "u1",
    "int8": "i1",
    "uint16": "<u2",
    "int16": "<i2",
    "uint32": "<u4",
    "int32": "<i4",
    "uint64": "<u8",
    "int64": "<i8",
    "float32": "<f4",
    "float64": "<f8",
}
_FIELD = re.compile(
    r"^\s*([A-Za-z0-9_/]+(?:<=\d+)?)(\[(\d*)(?:<=\d+)?\])?\s+([A-Za-z0-9_]+)\s*(.*)$"
)


class _NotFixed(Exception):
    """The message layout is not the same in every message (or not parsed)."""


def _definitions(text: str, name: str) -> dict[str, list[tuple[str, int | None, str]]]:
    """Message name -> fields (type, fixed array length or None, field name)."""
    sections = re.split(r"^=+\s*$", text, flags=re.M)
    out: dict[str, list[tuple[str, int | None, str]]] = {}
    for i, section in enumerate(sections):
        lines = section.strip().splitlines()
        msg = name
        if i:
            if not lines or not lines[0].startswith("MSG:"):
                raise _NotFixed
            msg, lines = lines[0][4:].strip(), lines[1:]
        fields = []
        for line in lines:
            line = line.split("#", 1)[0]
            if not line.strip():
                continue
            m = _FIELD.match(line)
            if not m:
                raise _NotFixed
            typ, bracket, size, fname, rest = m.groups()
            if rest.startswith("="):  # a constant, not a field
                continue
            if bracket is not None and not size:
                raise _NotFixed  # sequence
            fields.append((typ, int(size) if size else None, fname))
        out[msg.replace("/msg/", "/")] = fields
    return out


@dataclass
class CdrPlan:
    """Byte offsets of every primitive (and string) field of a fixed-layout message."""

    length: int
    #: path -> (offset, dtype, count) of primitives; strings have dtype "S<n>".
    fields: dict[str, tuple[int, str, int]] = field(default_factory=dict)
    #: (offset, value) of every string length word, checked in every message.
    checks: list[tuple[int, int]] = field(default_factory=list)

    def has(self, path: str) -> bool:
        return path in self.fields

    def read(self, ch: Channel, path: str) -> NDArray[np.generic]:
        """Field ``path`` of every message: (n,) or (n, count); strings decoded to str."""
        offset, dtype, count = self.fields[path]
        view = np.frombuffer(ch.buffer, np.uint8)
        if dtype.startswith("S"):
            width = int(dtype[1:])
            idx = ch.starts[:, None] + offset + np.arange(width)
            raw = np.ascontiguousarray(view[idx]).view(f"S{width}").ravel()
            return np.char.decode(raw, "utf-8", "replace").astype(object)  # type: ignore[no-any-return]
        size = np.dtype(dtype).itemsize * count
        idx = ch.starts[:, None] + offset + np.arange(size)
        values = np.ascontiguousarray(view[idx]).view(dtype)
        return values.reshape(-1) if count == 1 else values.reshape(-1, count)

    def valid_for(self, ch: Channel) -> bool:
        """Every message has this plan's length, encapsulation and string lengths."""
        if not np.all(ch.ends - ch.starts == self.length):
            return False
        view = np.frombuffer(ch.buffer, np.uint8)
        if not (np.all(view[ch.starts] == 0) and np.all(view[ch.starts + 1] == 1)):
            return False
        for offset, value in self.checks:
            idx = ch.starts[:, None] + offset + np.arange(4)
            if not np.all(np.ascontiguousarray(view[idx]).view("<u4").ravel() == value):
                return False
        return True


def plan(ch: Channel) -> CdrPlan | None:
    """A fixed-layout plan for a ROS 2 channel's messages, or None."""
    if not len(ch) or ch.schema_encoding != "ros2msg" or ch.message_encoding != "cdr":
        return None
    try:
        text = ch.schema_data.decode("utf-8")
        defs = _definitions(text, ch.schema_name.replace("/msg/", "/"))
        first = ch.buffer[int(ch.starts[0]) : int(ch.ends[0])]
        if first[:2] != b"\x00\x01":
            return None
        out = CdrPlan(length=len(first))
        end = _layout(defs, ch.schema_name.replace("/msg/", "/"), first, 4, "", out)
        # The layout must cover the message exactly (up to 3 zero padding bytes).
        if end > len(first) or len(first) - end >= 4 or any(first[end:]):
            return None
    except (_NotFixed, struct.error, KeyError, IndexError, ValueError, UnicodeError):
        return None
    return out if out.valid_for(ch) else None


def _align(offset: int, size: int) -> int:
    rel = offset - 4
    return offset + (-rel) % size


def _layout(
    defs: dict[str, list[tuple[str, int | None, str]]],
    msg: str,
    data: bytes,
    offset: int,
    prefix: str,
    out: CdrPlan,
) -> int:
    package = msg.split("/")[0]
    for typ, count, name in defs[msg]:
        path = f"{prefix}{name}"
        base = typ.split("<=")[0]
        if base in _PRIMITIVES:
            dtype = _PRIMITIVES[base]
            size = np.dtype(dtype).itemsize
            offset = _align(offset, size)
            out.fields[path] = (offset, dtype, count or 1)
            offset += size * (count or 1)
        elif base == "string":
            for k in range(count or 1):
                offset = _align(offset, 4)
                (n,) = struct.unpack_from("<I", data, offset)
                if n == 0:
                    raise _NotFixed  # CDR strings count their NUL: never 0
                out.checks.append((offset, n))
                key = path if count is None else f"{path}[{k}]"
                out.fields[key] = (offset + 4, f"S{max(n - 1, 0)}", 1)
                offset += 4 + n
        else:
            nested = base.replace("/msg/", "/")
            if "/" not in nested:
                nested = "std_msgs/Header" if nested == "Header" else f"{package}/{nested}"
            if nested not in defs:
                raise _NotFixed
            for k in range(count or 1):
                sub = f"{path}." if count is None else f"{path}[{k}]."
                offset = _layout(defs, nested, data, offset, sub, out)
    return offset
