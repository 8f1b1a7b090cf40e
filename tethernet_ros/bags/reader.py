"""Damage-tolerant reading of bags (folder with metadata.yaml, or a bare .mcap file).

:func:`read_bag` reads the MCAP file record by record with ``mcap`` and decodes messages
with ``mcap-ros2-support`` from the definitions embedded in the file (no ROS needed).  It
never raises on damaged content: it returns every message readable up to the first damage
(truncation, CRC mismatch, undecodable record) and describes the damage in ``problems``.
A bag marked INCOMPLETE (naming.py) is read the same way and reported as incomplete.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from .naming import MARKER, BagError


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
    skipped: dict[str, int] = field(default_factory=dict)        # topic -> messages passed
                                                                  # over (topics / types filter)
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
        """Messages read per topic (every topic of the file, 0 where none was read)."""
        out: dict[str, int] = {t: 0 for t in self.topics}
        for m in self.messages:
            out[m.topic] = out.get(m.topic, 0) + 1
        return out

    @property
    def n_skipped(self) -> int:
        """Messages in the part of the file read that the filter passed over."""
        return sum(self.skipped.values())


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
    damage, decoded with mcap-ros2-support if ``decode``; the messages the filter passed
    over are counted per topic in ``skipped``.  A truncated or corrupted file ends the
    reading at the damage, which ``problems`` describes.  Raises BagError only if
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
                    sch = schemas.get(ch.schema_id)
                    if (topics is not None and ch.topic not in topics) or \
                            (types is not None and (sch is None or sch.name not in types)):
                        out.skipped[ch.topic] = out.skipped.get(ch.topic, 0) + 1
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
        held = len(out.messages) + out.n_skipped
        if expected is not None and expected != held:
            problems.append(f"metadata.yaml lists {expected} messages, the file holds {held}")
    return out


def describe(contents: BagContents) -> str:
    state = "complete" if contents.complete else "INCOMPLETE or damaged"
    return f"{contents.path}: {len(contents.messages)} messages on {len(contents.topics)} topics, {state}"
