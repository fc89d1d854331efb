"""A fast, strict MCAP record scanner: channels, their message bytes, and attachments.

MCAP (https://mcap.dev/spec) is a sequence of ``opcode u8, length u64, body`` records
between two magic strings; messages sit in (compressed) chunks. The record walk is a
compiled loop (numba) over each buffer; message headers (channel id, log time) are then
read for all messages at once with numpy, so no Python code runs per message. Message
bytes stay in one buffer (the file and the decompressed chunks, concatenated) and are
sliced or joined per channel only when asked. A truncated or corrupt file is one
InputError naming the byte offset. Messages are not decoded here (``mcap_read`` does).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray

from coopproc.errors import InputError
from coopproc.io._common import PARSE_ERRORS, one_line

__all__ = ["MAGIC", "Channel", "RawMcap", "scan_mcap"]

MAGIC = b"\x89MCAP0\r\n"
_OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 2, 3, 4, 5, 6
_OP_ATTACHMENT = 9
_MSG_HEADER = 22  # channel u16, sequence u32, log_time u64, publish_time u64

U8 = NDArray[np.uint8]
I64 = NDArray[np.int64]


@numba.njit(cache=True)
def _walk(buf: Any, start: int, end: int) -> tuple[Any, Any, Any, int, int]:  # pragma: no cover
    """(opcodes, body offsets, body lengths, count, status) of the records in buf[start:end].

    status: 0 walked to ``end``; 1 stopped at a footer; -k a bad record at byte k - 1.
    """
    cap = (end - start) // 9 + 1
    ops = np.empty(cap, np.uint8)
    offs = np.empty(cap, np.int64)
    lens = np.empty(cap, np.int64)
    n = 0
    off = start
    while off < end:
        if off + 9 > end:
            return ops, offs, lens, n, -(off + 1)
        length = np.uint64(0)
        for k in range(8):
            length |= np.uint64(buf[off + 1 + k]) << np.uint64(8 * k)
        if length > np.uint64(end - off - 9):
            return ops, offs, lens, n, -(off + 1)
        ops[n] = buf[off]
        offs[n] = off + 9
        lens[n] = np.int64(length)
        n += 1
        if buf[off] == 2:  # footer
            return ops, offs, lens, n, 1
        off = off + 9 + lens[n - 1]
    return ops, offs, lens, n, 0


@numba.njit(cache=True)
def _gather(buf: Any, starts: Any, ends: Any, sep: int) -> Any:  # pragma: no cover
    """The byte ranges buf[starts[i]:ends[i]] joined by ``sep`` (one byte)."""
    total = 0
    for i in range(starts.size):
        total += ends[i] - starts[i]
    total += max(starts.size - 1, 0)
    out = np.empty(total, np.uint8)
    pos = 0
    for i in range(starts.size):
        if i:
            out[pos] = sep
            pos += 1
        for j in range(starts[i], ends[i]):
            out[pos] = buf[j]
            pos += 1
    return out


@dataclass(eq=False)
class Channel:
    """One MCAP channel and its raw messages in file order."""

    topic: str
    message_encoding: str
    schema_name: str = ""
    schema_encoding: str = ""
    #: The schema's text (``ros2msg`` definitions for ROS 2 channels).
    schema_data: bytes = b""
    decoder: Callable[[bytes], Any] | None = None
    #: Message bytes are buffer[starts[i]:ends[i]].
    buffer: bytes = b""
    starts: I64 = field(default_factory=lambda: np.empty(0, np.int64))
    ends: I64 = field(default_factory=lambda: np.empty(0, np.int64))
    log_time_ns: NDArray[np.uint64] = field(default_factory=lambda: np.empty(0, np.uint64))

    def __len__(self) -> int:
        return int(self.starts.size)

    @property
    def data(self) -> list[bytes]:
        """Each message's bytes."""
        buf = self.buffer
        return [buf[s:e] for s, e in zip(self.starts.tolist(), self.ends.tolist(), strict=True)]

    def joined(self, sep: bytes = b"\n") -> bytes:
        """All messages' bytes joined by the one-byte ``sep``."""
        view = np.frombuffer(self.buffer, np.uint8)
        return _gather(view, self.starts, self.ends, sep[0]).tobytes()  # type: ignore[no-any-return]


@dataclass
class RawMcap:
    """A scanned MCAP file."""

    path: str
    channels: dict[int, Channel] = field(default_factory=dict)
    attachments: dict[str, bytes] = field(default_factory=dict)
    n_messages: int = 0


class _Corrupt(Exception):
    def __init__(self, offset: int, what: str) -> None:
        super().__init__(what)
        self.offset = offset
        self.what = what


def _string(buf: bytes, off: int) -> tuple[str, int]:
    (n,) = struct.unpack_from("<I", buf, off)
    end = off + 4 + n
    if end > len(buf):
        raise _Corrupt(off, "string runs past its record")
    return buf[off + 4 : end].decode("utf-8"), end


def _decompress(kind: str, data: bytes, size: int) -> bytes:
    if kind == "":
        return data
    if kind == "zstd":
        import zstandard

        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    if kind == "lz4":
        import lz4.frame

        return bytes(lz4.frame.decompress(data))
    raise _Corrupt(0, f"chunk compression '{kind}' not supported; expected zstd, lz4 or none")


def _le(view: U8, offsets: I64, width: int) -> NDArray[np.uint64]:
    """Little-endian unsigned integers of ``width`` bytes at ``offsets`` (vectorized)."""
    out = np.zeros(offsets.size, np.uint64)
    for k in range(width):
        out |= view[offsets + k].astype(np.uint64) << np.uint64(8 * k)
    return out


class _Scanner:
    def __init__(self, path: str) -> None:
        self.out = RawMcap(path)
        self.schemas: dict[int, tuple[str, str, bytes]] = {}
        self.segments: list[bytes] = []
        self.base = 0  # offset of the current segment in the concatenated buffer
        self.msg_cid: list[NDArray[np.uint64]] = []
        self.msg_start: list[I64] = []
        self.msg_end: list[I64] = []
        self.msg_time: list[NDArray[np.uint64]] = []

    def segment(self, buf: bytes, start: int, file_base: int) -> bool:
        """Walk one buffer (the file or a chunk); True when the footer was reached."""
        view = np.frombuffer(buf, np.uint8)
        ops, offs, lens, n, status = _walk(view, start, len(buf))
        ops, offs, lens = ops[:n], offs[:n], lens[:n]
        base = self.base
        self.segments.append(buf)
        self.base += len(buf)
        is_msg = ops == _OP_MESSAGE
        if is_msg.any():
            m_off, m_len = offs[is_msg], lens[is_msg]
            short = m_len < _MSG_HEADER
            if short.any():
                raise _Corrupt(file_base + int(m_off[short][0]), "message record too short")
            self.msg_cid.append(_le(view, m_off, 2))
            self.msg_time.append(_le(view, m_off + 6, 8))
            self.msg_start.append(base + m_off + _MSG_HEADER)
            self.msg_end.append(base + m_off + m_len)
        for i in np.flatnonzero(~is_msg):
            self.record(int(ops[i]), buf, int(offs[i]), int(offs[i] + lens[i]), file_base)
        if status < 0 and buf is self.segments[0]:
            raise _Corrupt(
                -status - 1, "truncated MCAP: the record here runs past the end of the file"
            )
        if status < 0:
            raise _Corrupt(file_base - status - 1, "record runs past the end of its chunk")
        return status == 1

    def record(self, op: int, buf: bytes, body: int, stop: int, file_base: int) -> None:
        if op == _OP_CHUNK:
            _s, _e, size, _crc = struct.unpack_from("<QQQI", buf, body)
            kind, o = _string(buf, body + 28)
            (n,) = struct.unpack_from("<Q", buf, o)
            if o + 8 + n > stop:
                raise _Corrupt(file_base + body, "chunk data runs past its record")
            try:
                data = _decompress(kind, buf[o + 8 : o + 8 + n], size)
            except _Corrupt:
                raise
            except Exception as err:  # zstd/lz4 raise their own error types on bad data
                what = f"chunk does not decompress ({type(err).__name__})"
                raise _Corrupt(file_base + body, what) from err
            self.segment(data, 0, file_base + body)
        elif op == _OP_CHANNEL:
            cid, sid = struct.unpack_from("<HH", buf, body)
            topic, o = _string(buf, body + 4)
            enc, o = _string(buf, o)
            ch = Channel(topic=topic, message_encoding=enc)
            if sid in self.schemas:
                name, senc, sdata = self.schemas[sid]
                ch.schema_name, ch.schema_encoding, ch.schema_data = name, senc, sdata
                if enc == "cdr" and senc == "ros2msg":
                    ch.decoder = _ros2_decoder(sid, name, sdata)
            self.out.channels.setdefault(cid, ch)
        elif op == _OP_SCHEMA:
            (sid,) = struct.unpack_from("<H", buf, body)
            name, o = _string(buf, body + 2)
            enc, o = _string(buf, o)
            (n,) = struct.unpack_from("<I", buf, o)
            self.schemas.setdefault(sid, (name, enc, buf[o + 4 : o + 4 + n]))
        elif op == _OP_ATTACHMENT:
            name, o = _string(buf, body + 16)
            _media, o = _string(buf, o)
            (n,) = struct.unpack_from("<Q", buf, o)
            self.out.attachments[name] = buf[o + 8 : o + 8 + n]

    def finish(self) -> RawMcap:
        """Assign the messages to their channels."""
        if not self.msg_cid:
            return self.out
        big = b"".join(self.segments)
        cid = np.concatenate(self.msg_cid)
        start, end = np.concatenate(self.msg_start), np.concatenate(self.msg_end)
        log_time = np.concatenate(self.msg_time)
        unknown = ~np.isin(cid, np.array(list(self.out.channels), dtype=np.uint64))
        if unknown.any():
            raise _Corrupt(-1, f"message on unknown channel {int(cid[unknown][0])}")
        for key, ch in self.out.channels.items():
            mask = cid == key
            ch.buffer = big
            ch.starts, ch.ends, ch.log_time_ns = start[mask], end[mask], log_time[mask]
        self.out.n_messages = int(cid.size)
        return self.out


def _ros2_decoder(sid: int, name: str, data: bytes) -> Callable[[bytes], Any] | None:
    from mcap.records import Schema
    from mcap_ros2.decoder import DecoderFactory

    schema = Schema(id=sid, name=name, encoding="ros2msg", data=data)
    try:
        return DecoderFactory().decoder_for("cdr", schema)
    except Exception:  # a schema the ROS 2 parser rejects: reported when a message needs it
        return None


def scan_mcap(path: Path) -> RawMcap:
    """Scan ``path``; raises InputError for a file that is not, or not all, MCAP."""
    try:
        buf = path.read_bytes()
    except OSError as err:
        raise InputError(path, f"cannot read ({err.strerror})") from err
    if len(buf) == 0:
        raise InputError(path, "empty file; expected an MCAP recording")
    if not buf.startswith(MAGIC):
        raise InputError(path, "not an MCAP file (bad magic); expected an MCAP recording")
    scanner = _Scanner(str(path))
    try:
        footer = scanner.segment(buf, len(MAGIC), 0)
        if not footer or not buf.endswith(MAGIC):
            raise InputError(path, "truncated MCAP: no footer; expected a complete recording")
        return scanner.finish()
    except _Corrupt as err:
        where = f" at byte {err.offset}" if err.offset >= 0 else ""
        if err.what.startswith("truncated"):
            raise InputError(path, f"{err.what} (byte {err.offset})") from err
        raise InputError(path, f"corrupt MCAP{where}: {err.what}") from err
    except PARSE_ERRORS as err:
        raise InputError(path, f"corrupt MCAP ({type(err).__name__}: {one_line(err)})") from err
