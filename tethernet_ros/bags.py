"""rosbag2 bags (folder with metadata.yaml version 9 + ``<name>_0.mcap``) written with
``mcap`` from serialized CDR messages, and read back with ``mcap`` + ``mcap-ros2-support``.

No ROS import: message definitions (``ros2msg`` schemas with every nested type, as rosbag2
embeds them) are built from the ``.msg`` files installed under ``<prefix>/share/<pkg>/msg/``
(the venv, or $AMENT_PREFIX_PATH).

Writing is atomic at the folder level: a bag is written as ``<name>.partial/`` holding an
``INCOMPLETE`` marker, and renamed to ``<name>/`` (marker removed, metadata.yaml written)
only when it is complete.  A recording that is aborted (``BagWriter.abort``) or whose
writer dies keeps the ``.partial`` name and the marker, whose text says why.

Reading never raises on damaged content: :func:`read_bag` returns every message readable
up to the first damage (truncation, CRC mismatch, undecodable record) and describes the
damage in ``problems``.
"""
from __future__ import annotations

import json
import os
import re
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

MARKER = "INCOMPLETE"
PARTIAL_SUFFIX = ".partial"
SEPARATOR = "=" * 80
PRIMITIVES = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
              "int32", "uint32", "int64", "uint64", "string", "wstring"}
# rosbag2's "infinite" duration, as Jazzy writes it for default deadline/lifespan/lease
_INFINITE = {"sec": 9223372036, "nsec": 854775807}


class BagError(Exception):
    """A bag cannot be opened or written (one line)."""


# --- message definitions ------------------------------------------------------------------
def _prefixes() -> list[Path]:
    out = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    out.append(Path(sys.prefix))
    return out


def _interface_file(pkg: str, kind: str, name: str, ext: str) -> Path:
    for prefix in _prefixes():
        path = prefix / "share" / pkg / kind / f"{name}.{ext}"
        if path.is_file():
            return path
    raise BagError(f"message definition {pkg}/{kind}/{name}.{ext} not found under "
                   f"{[str(p) for p in _prefixes()]} (run scripts/setup.sh)")


def _split_type(msgtype: str) -> tuple[str, str]:
    parts = msgtype.split("/")
    if len(parts) == 3:
        return parts[0], parts[2]
    if len(parts) == 2:
        return parts[0], parts[1]
    raise BagError(f"message type {msgtype!r}: expected pkg/msg/Name")


def _field_types(text: str, pkg: str) -> list[str]:
    """Nested message types (pkg/Name) used by the fields of a .msg text."""
    out = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.split()
        if len(parts) < 2 or "=" in parts[1] or (len(parts) > 2 and parts[2].startswith("=")):
            continue  # a constant
        ftype = re.sub(r"\[.*\]$", "", parts[0])
        ftype = re.sub(r"<=\d+$", "", ftype)
        if ftype in PRIMITIVES:
            continue
        if "/" in ftype:
            dpkg, dname = _split_type(ftype)
        elif ftype == "Header":
            dpkg, dname = "std_msgs", "Header"
        else:
            dpkg, dname = pkg, ftype
        out.append(f"{dpkg}/{dname}")
    return out


_DEF_CACHE: dict[str, str] = {}


def message_definition(msgtype: str) -> str:
    """Concatenated ros2msg definition of ``msgtype`` (pkg/msg/Name) and of every nested
    type, each after a ``====`` separator and a ``MSG: pkg/Name`` line (rosbag2's format)."""
    if msgtype in _DEF_CACHE:
        return _DEF_CACHE[msgtype]
    pkg, name = _split_type(msgtype)
    top = _interface_file(pkg, "msg", name, "msg").read_text()
    seen: list[str] = []
    texts: dict[str, str] = {}

    def visit(p: str, text: str) -> None:
        for dep in _field_types(text, p):
            if dep in seen:
                continue
            seen.append(dep)
            dpkg, dname = dep.split("/")
            texts[dep] = _interface_file(dpkg, "msg", dname, "msg").read_text()
            visit(dpkg, texts[dep])

    visit(pkg, top)
    parts = [top.rstrip("\n")]
    for dep in seen:
        parts.append(f"{SEPARATOR}\nMSG: {dep}\n{texts[dep].rstrip(chr(10))}")
    _DEF_CACHE[msgtype] = "\n".join(parts) + "\n"
    return _DEF_CACHE[msgtype]


def type_hash(msgtype: str) -> str:
    """RIHS01 type-description hash of ``msgtype`` from its installed .json ('' if absent)."""
    pkg, name = _split_type(msgtype)
    try:
        data = json.loads(_interface_file(pkg, "msg", name, "json").read_text())
    except (BagError, ValueError):
        return ""
    full = f"{pkg}/msg/{name}"
    for entry in data.get("type_hashes", []):
        if entry.get("type_name") == full:
            return entry.get("hash_string", "")
    return ""


def qos_profile(depth: int = 10, reliable: bool = True, durability: str = "volatile") -> dict:
    """An offered QoS profile as rosbag2 (metadata version 9) writes it."""
    return {"history": "keep_last", "depth": int(depth),
            "reliability": "reliable" if reliable else "best_effort",
            "durability": durability, "deadline": dict(_INFINITE), "lifespan": dict(_INFINITE),
            "liveliness": "automatic", "liveliness_lease_duration": dict(_INFINITE),
            "avoid_ros_namespace_conventions": False}


# --- writing ------------------------------------------------------------------------------
class BagWriter:
    """Write one rosbag2 bag at ``path`` (a folder) from serialized CDR messages.

    Thread-safe.  ``add_topic`` before writing a topic; ``write(topic, data, log_time_ns)``;
    then ``close()`` (complete bag) or ``abort(reason)`` (marked incomplete).
    """

    def __init__(self, path: str | os.PathLike, compression: str = "zstd",
                 custom_data: dict | None = None, chunk_size: int = 256 * 1024):
        from mcap.writer import CompressionType, Writer

        self.final = Path(path)
        self.name = self.final.name
        if not self.name or self.name in (".", "..") or not re.fullmatch(r"[A-Za-z0-9_.\-]+", self.name):
            raise BagError(f"bag name {self.name!r}: use letters, digits, '_', '-' and '.'")
        self.dir = self.final.with_name(self.name + PARTIAL_SUFFIX)
        if self.final.exists():
            raise BagError(f"bag {str(self.final)!r} already exists")
        if self.dir.exists():
            raise BagError(f"an unfinished bag {str(self.dir)!r} is in the way; remove it")
        comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                "none": CompressionType.NONE, "": CompressionType.NONE}.get(compression)
        if comp is None:
            raise BagError(f"compression {compression!r}: must be zstd, lz4 or none")
        self.dir.mkdir(parents=True)
        (self.dir / MARKER).write_text(
            f"recording in progress (pid {os.getpid()}, started "
            f"{time.strftime('%Y-%m-%d %H:%M:%S')}); if this file remains, the recorder stopped "
            "before finishing the bag\n")
        self.mcap_name = f"{self.name}_0.mcap"
        self._file = open(self.dir / self.mcap_name, "wb")
        self._writer = Writer(self._file, chunk_size=chunk_size, compression=comp)
        from importlib.metadata import version

        self._writer.start(profile="ros2", library=f"tethernet_ros; mcap {version('mcap')}")
        self._lock = threading.Lock()
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._topics: dict[str, dict] = {}
        self._counts: dict[str, int] = {}
        self._seq: dict[str, int] = {}
        self.t_min: int | None = None
        self.t_max: int | None = None
        self.custom_data = {str(k): str(v) for k, v in (custom_data or {}).items()}
        self.closed = False

    def add_topic(self, topic: str, msgtype: str, qos: dict | None = None) -> None:
        import yaml

        with self._lock:
            if topic in self._channels:
                return
            if msgtype not in self._schemas:
                self._schemas[msgtype] = self._writer.register_schema(
                    name=msgtype, encoding="ros2msg", data=message_definition(msgtype).encode())
            qos = qos or qos_profile()
            digest = type_hash(msgtype)
            meta = {"offered_qos_profiles": yaml.safe_dump([qos], sort_keys=False)}
            if digest:
                meta["topic_type_hash"] = digest
            self._channels[topic] = self._writer.register_channel(
                topic=topic, message_encoding="cdr", schema_id=self._schemas[msgtype],
                metadata=meta)
            self._topics[topic] = {"type": msgtype, "qos": qos, "hash": digest}
            self._counts[topic] = 0
            self._seq[topic] = 0

    def write(self, topic: str, data: bytes, log_time_ns: int | None = None,
              publish_time_ns: int | None = None) -> None:
        t = time.time_ns() if log_time_ns is None else int(log_time_ns)
        with self._lock:
            if self.closed:
                return
            self._writer.add_message(channel_id=self._channels[topic], log_time=t,
                                     data=bytes(data), publish_time=publish_time_ns or t,
                                     sequence=self._seq[topic])
            self._seq[topic] += 1
            self._counts[topic] += 1
            self.t_min = t if self.t_min is None else min(self.t_min, t)
            self.t_max = t if self.t_max is None else max(self.t_max, t)

    @property
    def counts(self) -> dict[str, int]:
        return dict(self._counts)

    def _metadata(self) -> dict:
        start = self.t_min or 0
        duration = (self.t_max or 0) - start
        total = sum(self._counts.values())
        return {
            "version": 9,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": duration},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": total,
            "topics_with_message_count": [
                {"topic_metadata": {"name": topic, "type": info["type"],
                                    "serialization_format": "cdr",
                                    "offered_qos_profiles": [info["qos"]],
                                    "type_description_hash": info["hash"]},
                 "message_count": self._counts[topic]}
                for topic, info in self._topics.items()],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [self.mcap_name],
            "files": [{"path": self.mcap_name,
                       "starting_time": {"nanoseconds_since_epoch": start},
                       "duration": {"nanoseconds": duration}, "message_count": total}],
            "custom_data": self.custom_data or None,
            "ros_distro": "jazzy",
        }

    def _finish_mcap(self) -> dict:
        import yaml

        meta = self._metadata()
        # rosbag2's MCAP storage repeats metadata.yaml in a "rosbag2" metadata record
        self._writer.add_metadata("rosbag2", {"serialized_metadata": yaml.safe_dump(meta, sort_keys=False)})
        self._writer.finish()
        self._file.flush()
        os.fsync(self._file.fileno())
        self._file.close()
        return meta

    def close(self) -> Path:
        """Finish a complete bag: metadata.yaml written, marker removed, folder renamed."""
        import yaml

        with self._lock:
            if self.closed:
                return self.final
            self.closed = True
            meta = self._finish_mcap()
            tmp = self.dir / "metadata.yaml.tmp"
            tmp.write_text(yaml.safe_dump({"rosbag2_bagfile_information": meta}, sort_keys=False))
            tmp.rename(self.dir / "metadata.yaml")
            (self.dir / MARKER).unlink()
            self.dir.rename(self.final)
            return self.final

    def abort(self, reason: str) -> Path:
        """Finish the MCAP file (so that it is readable) but mark the bag incomplete: it
        keeps its ``.partial`` name, has no metadata.yaml, and ``INCOMPLETE`` says why."""
        with self._lock:
            if self.closed:
                return self.dir if self.dir.exists() else self.final
            self.closed = True
            try:
                self._finish_mcap()
            except Exception:  # noqa: BLE001 - the marker below is what matters
                pass
            (self.dir / MARKER).write_text(f"incomplete: {reason}\n")
            return self.dir


# --- reading ------------------------------------------------------------------------------
@dataclass
class BagMessage:
    topic: str
    msgtype: str
    log_time: int
    publish_time: int
    data: bytes
    msg: object = None


@dataclass
class BagContents:
    path: Path
    mcap_path: Path | None
    messages: list[BagMessage] = field(default_factory=list)
    topics: dict[str, str] = field(default_factory=dict)         # topic -> type
    metadata: dict | None = None                                  # metadata.yaml content
    marker: str | None = None                                     # INCOMPLETE text
    problems: list[str] = field(default_factory=list)
    bytes_read: int = 0
    file_size: int = 0
    reached_end: bool = False

    @property
    def complete(self) -> bool:
        """True for a finished bag read to its end without damage."""
        return (self.reached_end and not self.problems and self.marker is None
                and (self.metadata is not None or self.path.suffix == ".mcap"))

    def by_topic(self, topic: str) -> list[BagMessage]:
        return [m for m in self.messages if m.topic == topic]

    def counts(self) -> dict[str, int]:
        out: dict[str, int] = {t: 0 for t in self.topics}
        for m in self.messages:
            out[m.topic] = out.get(m.topic, 0) + 1
        return out


def _locate(path: Path) -> tuple[Path | None, dict | None, str | None, list[str]]:
    """(mcap file, metadata, marker text, problems) of a bag folder or .mcap file."""
    import yaml

    problems = []
    if path.is_file():
        return path, None, None, problems
    if not path.is_dir():
        raise BagError(f"bag {str(path)!r} does not exist")
    metadata = None
    marker = None
    if (path / MARKER).is_file():
        marker = (path / MARKER).read_text().strip()
        problems.append(f"bag is marked incomplete: {marker}")
    meta_path = path / "metadata.yaml"
    if meta_path.is_file():
        try:
            metadata = yaml.safe_load(meta_path.read_text())["rosbag2_bagfile_information"]
        except Exception as exc:  # noqa: BLE001
            problems.append(f"metadata.yaml unreadable: {str(exc).splitlines()[0]}")
    elif marker is None:
        problems.append("metadata.yaml missing (the recording did not finish)")
    files = []
    if metadata and metadata.get("relative_file_paths"):
        files = [path / f for f in metadata["relative_file_paths"]]
    if not files:
        files = sorted(path.glob("*.mcap"))
    if not files:
        raise BagError(f"bag {str(path)!r} holds no .mcap file")
    if len(files) > 1:
        problems.append(f"{len(files)} storage files; only {files[0].name} is read")
    if not files[0].is_file():
        raise BagError(f"bag {str(path)!r}: storage file {files[0].name} is missing")
    return files[0], metadata, marker, problems


def read_bag(path: str | os.PathLike, topics: set[str] | None = None,
             decode: bool = True, types: set[str] | None = None) -> BagContents:
    """Read a bag (folder or .mcap file) record by record.

    Returns every message (of ``topics`` and ``types``, if given) that can be read before the first
    damage, decoded with mcap-ros2-support if ``decode``; a truncated or corrupted file
    ends the reading at the damage, which ``problems`` describes.  Raises BagError only if
    there is no bag at ``path``.
    """
    from mcap.records import Channel, Footer, Message, Schema
    from mcap.stream_reader import StreamReader
    from mcap_ros2.decoder import DecoderFactory

    path = Path(path)
    mcap_path, metadata, marker, problems = _locate(path)
    out = BagContents(path=path, mcap_path=mcap_path, metadata=metadata, marker=marker,
                      problems=problems)
    out.file_size = mcap_path.stat().st_size
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    decoders: dict[int, object] = {}
    factory = DecoderFactory()
    undecodable: dict[str, str] = {}
    with open(mcap_path, "rb") as f:
        reader = StreamReader(f, validate_crcs=True, record_size_limit=max(out.file_size, 1))
        try:
            for rec in reader.records:
                out.bytes_read = f.tell()
                if isinstance(rec, Schema):
                    schemas[rec.id] = rec
                elif isinstance(rec, Channel):
                    channels[rec.id] = rec
                    sch = schemas.get(rec.schema_id)
                    out.topics[rec.topic] = sch.name if sch else ""
                elif isinstance(rec, Message):
                    ch = channels.get(rec.channel_id)
                    if ch is None:
                        raise ValueError(f"message on unknown channel {rec.channel_id}")
                    if topics is not None and ch.topic not in topics:
                        continue
                    sch = schemas.get(ch.schema_id)
                    if types is not None and (sch is None or sch.name not in types):
                        continue
                    bm = BagMessage(ch.topic, sch.name if sch else "", rec.log_time,
                                    rec.publish_time, bytes(rec.data))
                    if decode and ch.topic not in undecodable:
                        try:
                            if ch.id not in decoders:
                                decoders[ch.id] = factory.decoder_for(ch.message_encoding, sch)
                            dec = decoders[ch.id]
                            bm.msg = dec(rec.data) if dec is not None else None
                        except Exception as exc:  # noqa: BLE001
                            undecodable[ch.topic] = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
                            problems.append(f"{ch.topic}: message at log time {rec.log_time} not "
                                            f"decodable: {undecodable[ch.topic]}")
                    out.messages.append(bm)
                elif isinstance(rec, Footer):
                    out.reached_end = True
        except Exception as exc:  # noqa: BLE001 - damage: keep what was read
            what = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            at = out.bytes_read
            kind = type(exc).__name__
            if kind in ("EndOfFile", "RecordLengthLimitExceeded") or "end of file" in what.lower():
                problems.append(f"{mcap_path.name}: truncated: the file ends ({out.file_size} bytes) "
                                f"inside the record that starts after byte {at}; read "
                                f"{len(out.messages)} messages before it")
            else:
                problems.append(f"{mcap_path.name}: damaged after byte {at} of {out.file_size} "
                                f"({kind}: {what}); read {len(out.messages)} messages before "
                                "the damage")
    if out.reached_end and metadata is not None:
        expected = metadata.get("message_count")
        if topics is None and types is None and expected is not None and expected != len(out.messages):
            problems.append(f"metadata.yaml lists {expected} messages, the file holds "
                            f"{len(out.messages)}")
    return out


def describe(contents: BagContents) -> str:
    state = "complete" if contents.complete else "INCOMPLETE or damaged"
    return f"{contents.path}: {len(contents.messages)} messages on {len(contents.topics)} topics, {state}"


def copy_truncated(src: str | os.PathLike, dst: str | os.PathLike, fraction: float) -> Path:
    """Copy a bag folder with its .mcap cut to ``fraction`` of its size (for tests and
    demonstrations of damaged-bag handling)."""
    import shutil

    src, dst = Path(src), Path(dst)
    shutil.copytree(src, dst)
    for f in dst.glob("*.mcap"):
        data = f.read_bytes()
        f.write_bytes(data[: int(len(data) * fraction)])
    return dst


__all__ = ["BagError", "BagWriter", "BagContents", "BagMessage", "read_bag", "message_definition",
           "type_hash", "qos_profile", "copy_truncated", "MARKER", "PARTIAL_SUFFIX", "describe"]
