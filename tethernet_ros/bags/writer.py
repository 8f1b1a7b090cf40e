"""BagWriter: one rosbag2 bag (metadata version 9, MCAP storage) written with rosbags.

The bag is recorded as ``<name>.partial/`` with an ``INCOMPLETE`` marker (naming.py).
``close()`` lets rosbags finish the MCAP file and write metadata.yaml, then removes the
marker and renames the folder to ``<name>/``.  ``abort(reason)`` also finishes the MCAP
file (every message written so far is readable and indexed) but keeps the ``.partial``
name, removes metadata.yaml (a bag without it is not a finished recording) and writes the
reason into the marker.  A writer that dies leaves the ``.partial`` folder, the marker
("recording in progress") and an MCAP file without footer, readable up to its last whole
chunk (CHUNK_BYTES of messages before compression).  rosbags writes no CRCs (0: "not
computed", as MCAP allows); each chunk here carries the CRC-32 of its records (MCAP's
``uncompressed_crc``), so a reader that checks them (reader.py) finds a chunk whose bytes
changed, not only a file cut short.  The summary's records carry none.

Times are ns since the epoch.  Thread-safe: the recorder thread writes while another
thread may close or abort.
"""
from __future__ import annotations

import os
import struct
import threading
import time
import zlib
from pathlib import Path

from .naming import MARKER, PARTIAL_SUFFIX, BagError, check_name, partial_path, storage_file
from .typestore import message_definition, type_hash

COMPRESSION = ("zstd", "none")
#: bytes of messages per MCAP chunk (before compression): 17 states of the default design
CHUNK_BYTES = 256 * 1024
#: where a Chunk record's uncompressed_crc lies, from the record's start (MCAP: opcode
#: uint8, length uint64, message_start_time, message_end_time, uncompressed_size uint64)
CHUNK_CRC_OFFSET = 1 + 8 + 3 * 8
#: rosbag2's "infinite" duration (s, ns), as Jazzy writes it for default QoS durations
_INFINITE = (9223372036, 854775807)


def qos_profile(depth: int = 10, reliable: bool = True, latched: bool = False):
    """The QoS a topic is offered with (keep-last ``depth``; transient-local if
    ``latched``, else volatile), as rosbags' Qos (``ros2 bag play`` offers it again)."""
    from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness,
                                    QosReliability, QosTime)

    forever = QosTime(*_INFINITE)
    return Qos(history=QosHistory.KEEP_LAST, depth=int(depth),
               reliability=QosReliability.RELIABLE if reliable else QosReliability.BEST_EFFORT,
               durability=QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE,
               deadline=forever, lifespan=forever,
               liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=forever,
               avoid_ros_namespace_conventions=False)


def _rosbag2_writer(chunk_bytes: int):
    """rosbags' rosbag2 Writer whose MCAP storage (a) names its file ``<name>_0.mcap``
    after the final bag name (rosbags names it after the folder, which is
    ``<name>.partial`` meanwhile) and (b) closes a chunk once it holds ``chunk_bytes`` of
    messages (rosbags: 1 MiB), so that a recording cut short loses less."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.storage_mcap import McapWriter

    class McapStorage(McapWriter):
        def __init__(self, path: Path, compression) -> None:
            super().__init__(path, compression)
            named = path / storage_file(path.name.removesuffix(PARTIAL_SUFFIX))
            os.rename(self.path, named)        # the open file keeps being written
            self.path = named

        def write(self, connection, timestamp: int, data: bytes) -> None:
            super().write(connection, timestamp, data)
            if self.chunk.bio.tell() >= chunk_bytes:
                self.close_chunk()

        def close_chunk(self) -> None:
            # rosbags writes the chunk record first, at the file's end, with a CRC of 0:
            # put the CRC of the chunk's records in its place
            records = self.chunk.bio.getvalue()
            start = self.bio.tell()
            super().close_chunk()
            end = self.bio.tell()
            self.bio.seek(start + CHUNK_CRC_OFFSET)
            self.bio.write(struct.pack("<I", zlib.crc32(records)))
            self.bio.seek(end)

    class NamedWriter(Writer):
        STORAGE_PLUGINS = {**Writer.STORAGE_PLUGINS, StoragePlugin.MCAP: McapStorage}

    return NamedWriter, StoragePlugin


class BagWriter:
    """Write one bag at ``path`` (a folder) from serialized CDR messages.

    ``add_topic(topic, msgtype, qos)`` before writing a topic; ``write(topic, data,
    log_time_ns)``; then ``close()`` (complete bag) or ``abort(reason)`` (incomplete).
    As a context manager (``with BagWriter(path) as bag:``) it closes the bag when the
    block ends and aborts it, naming the exception, when the block raises.
    compression: ``zstd`` (MCAP chunks) or ``none``; chunk_bytes: messages per MCAP chunk
    (bytes before compression), the unit that a damaged file is read in.
    """

    def __init__(self, path: str | os.PathLike, compression: str = "zstd",
                 custom_data: dict | None = None, chunk_bytes: int = CHUNK_BYTES):
        from rosbags.rosbag2 import CompressionFormat, CompressionMode

        self.final = Path(path)
        self.name = check_name(self.final.name)
        self.dir = partial_path(self.final)
        if self.final.exists():
            raise BagError(f"bag {str(self.final)!r} already exists")
        if self.dir.exists():
            raise BagError(f"an unfinished bag {str(self.dir)!r} is in the way; remove it")
        if compression not in COMPRESSION and compression != "":
            raise BagError(f"compression {compression!r}: must be one of {list(COMPRESSION)}")
        self.dir.parent.mkdir(parents=True, exist_ok=True)
        writer_class, plugin = _rosbag2_writer(int(chunk_bytes))
        self._bag = writer_class(self.dir, version=9, storage_plugin=plugin.MCAP)
        if compression == "zstd":
            self._bag.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        for key, value in (custom_data or {}).items():
            self._bag.set_custom_data(str(key), str(value))
        try:
            self._bag.open()
        except Exception as exc:  # noqa: BLE001 - e.g. a race on the folder
            raise BagError(f"cannot create bag {str(self.dir)!r}: {exc}") from None
        (self.dir / MARKER).write_text(
            f"recording in progress (pid {os.getpid()}, started "
            f"{time.strftime('%Y-%m-%d %H:%M:%S')}); if this file remains, the recorder stopped "
            "before finishing the bag\n")
        self._lock = threading.Lock()
        self._connections: dict = {}
        self._counts: dict[str, int] = {}
        self.closed = False

    def add_topic(self, topic: str, msgtype: str, qos=None) -> None:
        """Declare ``topic`` of type ``msgtype`` (pkg/msg/Name); qos: :func:`qos_profile`."""
        with self._lock:
            if topic in self._connections:
                return
            self._connections[topic] = self._bag.add_connection(
                topic, msgtype, msgdef=message_definition(msgtype), rihs01=type_hash(msgtype),
                offered_qos_profiles=[qos or qos_profile()])
            self._counts[topic] = 0

    def write(self, topic: str, data: bytes, log_time_ns: int | None = None) -> None:
        """Append one serialized message; log time in ns since the epoch (default: now)."""
        t = time.time_ns() if log_time_ns is None else int(log_time_ns)
        with self._lock:
            if self.closed:
                return
            self._bag.write(self._connections[topic], t, bytes(data))
            self._counts[topic] += 1

    @property
    def counts(self) -> dict[str, int]:
        return dict(self._counts)

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, exc_type, exc, _tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort(f"{exc_type.__name__}: {exc}")

    def close(self) -> Path:
        """Finish a complete bag: metadata.yaml written, marker removed, folder renamed."""
        with self._lock:
            if self.closed:
                return self.final
            self.closed = True
            self._bag.close()
            (self.dir / MARKER).unlink()
            self.dir.rename(self.final)
            return self.final

    def abort(self, reason: str) -> Path:
        """Finish the MCAP file but leave the bag marked incomplete (see the module)."""
        with self._lock:
            if self.closed:
                return self.dir if self.dir.exists() else self.final
            self.closed = True
            try:
                self._bag.close()
                (self.dir / "metadata.yaml").unlink(missing_ok=True)
            except Exception:  # noqa: BLE001 - the marker below is what matters
                self._bag.abort()
            (self.dir / MARKER).write_text(f"incomplete: {reason}\n")
            return self.dir
