"""A fast, strict MCAP record scanner: channels, their message bytes, and attachments.

MCAP (https://mcap.dev/spec) is a sequence of ``opcode u8, length u64, body`` records
between two magic strings; messages sit in (compressed) chunks. This scanner walks the
data section once, keeps each message's bytes and log time per channel and stops at the
footer; it does not decode messages (``mcap_read`` does, batched per channel). It is a
few times faster than iterating ``mcap.reader`` records one by one, and it reports a
truncated or corrupt file as one InputError naming the byte offset.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from coopproc.errors import InputError
from coopproc.io._common import PARSE_ERRORS, one_line

__all__ = ["MAGIC", "Channel", "RawMcap", "scan_mcap"]

MAGIC = b"\x89MCAP0\r\n"
_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 1, 2, 3, 4, 5, 6
_OP_ATTACHMENT = 9
_REC = struct.Struct("<BQ")
_MSG = struct.Struct("<HIQQ")


@dataclass
class Channel:
    """One MCAP channel and its raw messages in file order."""

    topic: str
    message_encoding: str
    schema_name: str = ""
    schema_encoding: str = ""
    decoder: Callable[[bytes], Any] | None = None
    data: list[bytes] = field(default_factory=list)
    log_time_ns: list[int] = field(default_factory=list)


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


class _Scanner:
    def __init__(self, path: str) -> None:
        self.out = RawMcap(path)
        self.schemas: dict[int, tuple[str, str, bytes]] = {}

    def records(self, buf: bytes, start: int, end: int, base: int) -> bool:
        """Walk records in buf[start:end]; True when the footer was reached."""
        off = start
        rec_unpack, msg_unpack = _REC.unpack_from, _MSG.unpack_from
        channels = self.out.channels
        while off < end:
            if off + 9 > end:
                raise _Corrupt(base + off, "record header cut off")
            op, length = rec_unpack(buf, off)
            body = off + 9
            stop = body + length
            if stop > end:
                raise _Corrupt(base + off, f"record of {length} bytes runs past the end")
            if op == _OP_MESSAGE:
                cid, _seq, log_time, _pub = msg_unpack(buf, body)
                ch = channels.get(cid)
                if ch is None:
                    raise _Corrupt(base + off, f"message on unknown channel {cid}")
                ch.data.append(buf[body + 22 : stop])
                ch.log_time_ns.append(log_time)
            elif op == _OP_CHUNK:
                self.chunk(buf, body, stop, base)
            elif op == _OP_CHANNEL:
                self.channel(buf, body)
            elif op == _OP_SCHEMA:
                (sid,) = struct.unpack_from("<H", buf, body)
                name, o = _string(buf, body + 2)
                enc, o = _string(buf, o)
                (n,) = struct.unpack_from("<I", buf, o)
                self.schemas[sid] = (name, enc, buf[o + 4 : o + 4 + n])
            elif op == _OP_ATTACHMENT:
                name, o = _string(buf, body + 16)
                _media, o = _string(buf, o)
                (n,) = struct.unpack_from("<Q", buf, o)
                self.out.attachments[name] = buf[o + 8 : o + 8 + n]
            elif op == _OP_FOOTER:
                return True
            off = stop
        return False

    def chunk(self, buf: bytes, body: int, stop: int, base: int) -> None:
        _start, _end, size, _crc = struct.unpack_from("<QQQI", buf, body)
        kind, o = _string(buf, body + 28)
        (n,) = struct.unpack_from("<Q", buf, o)
        if o + 8 + n > stop:
            raise _Corrupt(base + body, "chunk data runs past its record")
        try:
            data = _decompress(kind, buf[o + 8 : o + 8 + n], size)
        except _Corrupt:
            raise
        except Exception as err:  # zstd/lz4 raise their own error types on bad data
            raise _Corrupt(
                base + body, f"chunk does not decompress ({type(err).__name__})"
            ) from err
        self.records(data, 0, len(data), base + body)

    def channel(self, buf: bytes, body: int) -> None:
        cid, sid = struct.unpack_from("<HH", buf, body)
        topic, o = _string(buf, body + 4)
        enc, o = _string(buf, o)
        ch = Channel(topic=topic, message_encoding=enc)
        if sid in self.schemas:
            name, senc, data = self.schemas[sid]
            ch.schema_name, ch.schema_encoding = name, senc
            if enc == "cdr" and senc == "ros2msg":
                ch.decoder = _ros2_decoder(sid, name, data)
        self.out.channels.setdefault(cid, ch)


def _ros2_decoder(sid: int, name: str, data: bytes) -> Callable[[bytes], Any] | None:
    from mcap.records import Schema
    from mcap_ros2.decoder import DecoderFactory

    try:
        return DecoderFactory().decoder_for(
            "cdr", Schema(id=sid, name=name, encoding="ros2msg", data=data)
        )
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
        footer = scanner.records(buf, len(MAGIC), len(buf), 0)
    except _Corrupt as err:
        raise InputError(path, f"corrupt MCAP at byte {err.offset}: {err.what}") from err
    except PARSE_ERRORS as err:
        raise InputError(path, f"corrupt MCAP ({type(err).__name__}: {one_line(err)})") from err
    if not footer or not buf.endswith(MAGIC):
        raise InputError(path, "truncated MCAP: no footer; expected a complete recording")
    scanner.out.n_messages = sum(len(c.data) for c in scanner.out.channels.values())
    return scanner.out
