"""A recording whose writer died (SIGKILL, power loss): read what reached the file, or rewrite it finished.

Such a file has the MCAP header and the records the writer had flushed (recording/writer.py flushes the chunk
in progress every FLUSH_SECONDS), then stops anywhere, possibly inside a record; it has no summary and no
footer, so the seeking reader cannot open it. `salvage` reads it with mcap's own StreamReader, record by record
in file order — the semantics of `mcap recover`: every whole record before the point where the file ends or
stops making sense is kept, a chunk that does not decompress or fails its CRC is dropped (and counted), and the
rest from the first broken record framing on is dropped (its bytes counted). `rewrite` writes the kept records
into a finished MCAP (summary, indexes, footer) in place of the damaged file.
"""

from __future__ import annotations

import os
import struct
import tempfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

from mcap.exceptions import McapError
from mcap.records import Attachment, Channel, Chunk, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import MCAP0_MAGIC, CompressionType, IndexType, Writer

# What a broken file can raise while its records are decoded (a truncated tail, garbage lengths, bad zstd)
BROKEN = (McapError, EOFError, struct.error, ValueError, KeyError, IndexError, OverflowError, MemoryError, zlib.error)


@dataclass
class Salvage:
    """The records of a file read in order up to where it breaks off."""

    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    messages: list[Message] = field(default_factory=list)
    metadata: list[Metadata] = field(default_factory=list)
    attachments: list[Attachment] = field(default_factory=list)
    chunks_kept: int = 0
    chunks_dropped: int = 0  # whole chunks that did not decompress or failed their CRC
    bytes_kept: int = 0  # the file's bytes up to the end of its last whole record
    bytes_total: int = 0
    finished: bool = False  # it has its footer: nothing was lost
    why: str = ""  # where and why reading stopped early

    @property
    def bytes_dropped(self) -> int:
        return self.bytes_total - self.bytes_kept

    # the reader's interface (recording/reader.py `_read`)
    def iter_metadata(self):
        return iter(self.metadata)

    def iter_attachments(self):
        return iter(self.attachments)

    def iter_messages(self):
        for m in self.messages:
            channel = self.channels.get(m.channel_id)
            if channel is not None:  # a message whose channel record was lost is unreadable
                yield self.schemas.get(channel.schema_id), channel, m

    def lines(self) -> str:
        return (
            f"chunks_kept={self.chunks_kept}\nchunks_dropped={self.chunks_dropped}\n"
            f"bytes_kept={self.bytes_kept}\nbytes_dropped={self.bytes_dropped}"
        )


def salvage(path: str | os.PathLike) -> Salvage:
    """Every whole record of the file at `path`, in order (module docstring). Raises McapError if it does not
    even start as an MCAP file."""
    with open(path, "rb") as fh:
        return salvage_stream(fh)


def salvage_stream(fh: BinaryIO) -> Salvage:
    """`salvage` of the open, seekable binary file `fh` (read from its start)."""
    size = fh.seek(0, os.SEEK_END)
    fh.seek(0)
    out = Salvage(bytes_total=size)
    reader = StreamReader(fh, emit_chunks=True, record_size_limit=out.bytes_total)
    records = reader.records
    try:
        first = True
        for record in records:
            first = False
            if isinstance(record, Chunk):
                try:
                    inner = breakup_chunk(record, validate_crc=True)
                except BROKEN:
                    out.chunks_dropped += 1
                    out.bytes_kept = reader._stream.count
                    continue
                out.chunks_kept += 1
                for r in inner:
                    _take(out, r)
            else:
                _take(out, record)
                if isinstance(record, Footer):
                    out.finished = True
            out.bytes_kept = reader._stream.count
    except BROKEN as exc:
        if first and out.bytes_kept == 0:
            raise McapError(f"not an MCAP file ({type(exc).__name__})") from None
        out.why = f"the file breaks off after byte {out.bytes_kept} ({type(exc).__name__})"
    return out


def _take(out: Salvage, record) -> None:
    if isinstance(record, Schema):
        out.schemas[record.id] = record
    elif isinstance(record, Channel):
        out.channels[record.id] = record
    elif isinstance(record, Message):
        out.messages.append(record)
    elif isinstance(record, Metadata):
        out.metadata.append(record)
    elif isinstance(record, Attachment):
        out.attachments.append(record)


def rewrite(path: str | os.PathLike, kept: Salvage) -> Path:
    """Write `kept` as a finished MCAP in place of `path` (a new file renamed over it, so a failure leaves
    the damaged one as it was); returns the path."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".recovering", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as stream:
            w = Writer(
                stream,
                compression=CompressionType.ZSTD,
                index_types=IndexType.ALL,
                use_chunking=True,
                use_statistics=True,
                use_summary_offsets=True,
            )
            w.start(profile="", library="fluidswarm replay --recover")
            schema_ids, channel_ids = {}, {}
            for m in kept.metadata:
                w.add_metadata(m.name, dict(m.metadata))
            for a in kept.attachments:
                w.add_attachment(
                    create_time=a.create_time, log_time=a.log_time, name=a.name, media_type=a.media_type, data=a.data
                )
            for schema, channel, m in kept.iter_messages():
                if channel.id not in channel_ids:
                    sid = 0
                    if schema is not None:
                        if schema.id not in schema_ids:
                            schema_ids[schema.id] = w.register_schema(schema.name, schema.encoding, schema.data)
                        sid = schema_ids[schema.id]
                    channel_ids[channel.id] = w.register_channel(
                        channel.topic, channel.message_encoding, sid, dict(channel.metadata)
                    )
                w.add_message(
                    channel_ids[channel.id],
                    log_time=m.log_time,
                    data=m.data,
                    publish_time=m.publish_time,
                    sequence=m.sequence,
                )
            w.finish()
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def ends_with_magic(fh: BinaryIO) -> bool:
    """The open, seekable file `fh` ends with MCAP's magic after at least its opening one: its writer wrote the
    footer (a look at 8 bytes; leaves `fh` at its start)."""
    size = fh.seek(0, os.SEEK_END)
    fh.seek(max(0, size - len(MCAP0_MAGIC)))
    tail = fh.read(len(MCAP0_MAGIC))
    fh.seek(0)
    return size >= 2 * len(MCAP0_MAGIC) and tail == MCAP0_MAGIC


def after_recorder(path: str | os.PathLike | None, code: int | None, how: str = "", words: str = "") -> str | None:
    """What a run says of its recording once its recorder has ended with exit `code` (`how`: that end in words,
    swarmhost.helpers.describe_exit; `words`: its last line on stderr); None when it ended well with its file
    finished. A recorder killed or crashed before its footer leaves a file only `salvage` can read: it is
    rewritten finished with every whole record (the record survives its writer; the scores written as it
    closes are lost) and the line says so, naming how the recorder ended."""
    if path is None or code is None or not Path(path).is_file():
        return None
    path = Path(path)
    said = f" ({words[:200]})" if words else ""
    how = how or f"exited with code {code}"
    try:
        with open(path, "rb") as fh:
            if code == 0 and ends_with_magic(fh):
                return None  # the usual end, told without reading the file through
        kept = salvage(path)
        if kept.finished:
            return None if code == 0 else f"the recorder {how}{said} after finishing {path}"
        rewrite(path, kept)
    except McapError as exc:
        return f"the recorder {how}{said}: {path} is not a recording ({exc})"
    except OSError as exc:
        return f"the recorder {how}{said} before finishing {path}, which could not be rewritten ({exc.strerror or exc})"
    return (
        f"the recorder {how}{said} before finishing {path}: rewritten finished with its {len(kept.messages)} whole "
        f"messages ({kept.bytes_dropped} bytes of a cut record dropped; its closing scores were never written)"
    )
