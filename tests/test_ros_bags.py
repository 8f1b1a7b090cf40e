"""Pieces of the ROS suite that need no node processes: bag writing/reading (atomic
naming, incomplete marking, damage handling), message definitions and type hashes, the state mirror that
the monitor and replay use, parameter defaults, launch file and console scripts.
"""
from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("rclpy", reason="ROS 2 wheels not installed: run scripts/setup.sh")

from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402
from tethernet_msgs.msg import ClosingCommand, EpisodeResult, NetState  # noqa: E402

from tethernet_ros.bags import (MARKER, BagError, BagWriter, message_definition,  # noqa: E402
                                qos_profile, read_bag, type_hash)
from tethernet_ros.core.config import SimConfig  # noqa: E402
from tethernet_ros.core.design import load_design  # noqa: E402
from tethernet_ros.core.episode import run_episode, run_simulation  # noqa: E402
from tethernet_ros.core.noise import NoiseModel  # noqa: E402
from tethernet_ros.core.scenario import actions_for, build_scenario, world_for  # noqa: E402
from tethernet_ros.monitoring import StateMirror  # noqa: E402
from tethernet_ros.ros import conversions as conv  # noqa: E402
from tethernet_ros.ros.names import STAMPED, TOPIC_TYPES  # noqa: E402
from tethernet_ros.ros.parameters import DEFAULTS  # noqa: E402
from tethernet_ros.ros.results import compare_results  # noqa: E402
from tethernet_ros.ros.state import state_arrays  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.timeout(120)]
ROOT = Path(__file__).resolve().parent.parent
STATE_T = "tethernet_msgs/msg/NetState"


def _states(n: int) -> list[bytes]:
    out = []
    for i in range(n):
        m = NetState()
        m.step = i
        m.sim_time = 0.1 * i
        m.positions = [float(i) + 1e-3 * k for k in range(3 * 303)]
        m.velocities = [0.5 * k for k in range(3 * 303)]
        m.locked = [k < i % 13 for k in range(12)]
        out.append(serialize_message(m))
    return out


def _write(path: Path, n: int = 40, chunk_bytes: int = 256 * 1024) -> BagWriter:
    w = BagWriter(path, custom_data={"k": "v"}, chunk_bytes=chunk_bytes)
    w.add_topic("/s", STATE_T, qos_profile(1000))
    w.add_topic("/c", "tethernet_msgs/msg/ClosingCommand")
    w.write("/c", serialize_message(ClosingCommand(closing_displacement=1.5)), 1)
    for i, data in enumerate(_states(n)):
        w.write("/s", data, 10 + i)
    return w


def test_complete_bag_round_trip(tmp_path):
    from rosbags.highlevel import AnyReader

    w = _write(tmp_path / "good")
    assert (tmp_path / "good.partial" / MARKER).is_file() and not (tmp_path / "good").exists()
    path = w.close()
    assert path == tmp_path / "good" and not (tmp_path / "good.partial").exists()
    assert sorted(p.name for p in path.iterdir()) == ["good_0.mcap", "metadata.yaml"]
    meta = yaml.safe_load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["version"] == 9 and meta["message_count"] == 41 and meta["custom_data"] == {"k": "v"}
    contents = read_bag(path)
    assert contents.complete and contents.problems == [] and contents.counts() == {"/s": 40, "/c": 1}
    expected = _states(40)
    # (CDR padding bytes are not initialised by the serializer: compare the messages)
    assert [deserialize_message(m.data, NetState) for m in contents.by_topic("/s")] == \
        [deserialize_message(b, NetState) for b in expected]
    assert contents.by_topic("/s")[7].msg.step == 7
    with AnyReader([path]) as reader:
        got = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()
               if c.topic == "/s"]
    assert [m.step for m in got] == list(range(40))
    want = np.frombuffer(deserialize_message(expected[3], NetState).positions, dtype=float)
    assert np.array_equal(got[3].positions, want)


def test_aborted_bag_is_marked_and_readable(tmp_path):
    w = _write(tmp_path / "cut")
    path = w.abort("the simulation stopped")
    assert path == tmp_path / "cut.partial"
    assert (path / MARKER).read_text().strip() == "incomplete: the simulation stopped"
    assert not (path / "metadata.yaml").exists() and not (tmp_path / "cut").exists()
    contents = read_bag(path)
    assert not contents.complete and contents.counts() == {"/s": 40, "/c": 1}
    assert any("the simulation stopped" in p for p in contents.problems)


def test_writer_as_a_context_manager_closes_or_aborts(tmp_path):
    """A block that ends closes the bag; one that raises aborts it, the marker naming the
    exception, and the messages written before it stay readable."""
    from rosbags.highlevel import AnyReader

    with BagWriter(tmp_path / "ok") as w:
        w.add_topic("/c", "tethernet_msgs/msg/ClosingCommand")
        w.write("/c", serialize_message(ClosingCommand(closing_displacement=1.5)), 1)
    assert (tmp_path / "ok" / "metadata.yaml").is_file() and not (tmp_path / "ok.partial").exists()
    with pytest.raises(RuntimeError, match="winch"):
        with BagWriter(tmp_path / "bad") as w:
            w.add_topic("/c", "tethernet_msgs/msg/ClosingCommand")
            w.write("/c", serialize_message(ClosingCommand(closing_displacement=2.5)), 1)
            raise RuntimeError("winch stalled")
    partial = tmp_path / "bad.partial"
    assert (partial / MARKER).read_text() == "incomplete: RuntimeError: winch stalled\n"
    assert not (tmp_path / "bad").exists() and not (partial / "metadata.yaml").exists()
    with AnyReader([tmp_path / "ok"]) as r:
        assert len(list(r.messages())) == 1


def test_writer_refuses_clobbering_and_bad_names(tmp_path):
    _write(tmp_path / "a").close()
    with pytest.raises(BagError, match="already exists"):
        BagWriter(tmp_path / "a")
    _write(tmp_path / "b")            # left unfinished (a writer that died)
    with pytest.raises(BagError, match="unfinished"):
        BagWriter(tmp_path / "b")
    with pytest.raises(BagError, match="bag name"):
        BagWriter(tmp_path / "x y")
    with pytest.raises(BagError, match="does not exist"):
        read_bag(tmp_path / "nothing")


def test_damaged_files_are_read_up_to_the_damage(tmp_path):
    """A truncated file is read up to the cut, whole chunks at a time; a corrupted one
    never raises and keeps every message of the chunks before the damage; a chunk whose
    bytes changed is found by its CRC (the writer stores each chunk's) and none of its
    messages is read."""
    import zlib

    import zstandard
    from mcap.reader import make_reader
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    from tethernet_ros.bags.writer import CHUNK_CRC_OFFSET

    # 60 states of 14.7 kB, a chunk closed at 64 kiB: 5 states a chunk, 12 chunks
    path = _write(tmp_path / "d", n=60, chunk_bytes=64 * 1024).close()
    mcap = path / "d_0.mcap"
    data = mcap.read_bytes()
    with open(mcap, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        chunks = reader.get_summary().chunk_indexes
        assert len(list(reader.iter_messages())) == 61          # every CRC checks out
    assert len(chunks) == 12
    for ch in chunks:                                           # each one's own, not 0
        crc = int.from_bytes(data[ch.chunk_start_offset + CHUNK_CRC_OFFSET:][:4], "little")
        assert crc != 0
    # the CRC is that of the chunk's records, as MCAP defines it
    with open(mcap, "rb") as f:
        first = next(r for r in StreamReader(f, emit_chunks=True).records if isinstance(r, Chunk))
    records = zstandard.ZstdDecompressor().decompress(first.data,
                                                      max_output_size=first.uncompressed_size)
    assert first.uncompressed_crc == zlib.crc32(records)
    previous = -1
    for frac in np.linspace(0.0, 0.98, 25):
        mcap.write_bytes(data[: int(len(data) * frac)])
        c = read_bag(path)                                   # never raises
        assert not c.complete and c.problems
        n = len(c.by_topic("/s"))
        assert n >= previous and [m.msg.step for m in c.by_topic("/s")] == list(range(n))
        previous = n
    assert previous >= 55                                    # the first 11 chunks
    rng = np.random.default_rng(0)
    for off in rng.integers(200, len(data) - 200, 15):
        bad = bytearray(data)
        bad[off:off + 64] = rng.integers(0, 256, 64, dtype=np.uint8).tobytes()
        mcap.write_bytes(bytes(bad))
        c = read_bag(path)                                   # never raises
        steps = [m.msg.step for m in c.by_topic("/s") if m.msg is not None]
        # the states of the chunks that end before the damage (log time 10 + step)
        intact = max([ch.message_end_time - 9 for ch in chunks
                      if ch.chunk_start_offset + ch.chunk_length <= off], default=0)
        assert steps[:intact] == list(range(intact))
        if any(ch.chunk_start_offset <= off < ch.chunk_start_offset + ch.chunk_length
               for ch in chunks):
            # inside a chunk: found, and nothing of that chunk or after it is read
            assert c.problems and steps == list(range(intact)), (off, c.problems, len(steps))
        else:
            # outside the chunks (their indexes, the summary): no message is changed
            assert steps == list(range(len(steps)))


def test_message_definitions_embed_every_nested_type():
    from mcap_ros2._dynamic import generate_dynamic
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    text = message_definition("visualization_msgs/msg/MarkerArray")
    for dep in ("visualization_msgs/Marker", "std_msgs/Header", "builtin_interfaces/Time",
                "geometry_msgs/Point", "sensor_msgs/CompressedImage", "visualization_msgs/MeshFile"):
        assert f"MSG: {dep}\n" in text
    store = get_typestore(Stores.EMPTY)
    for type_name in set(TOPIC_TYPES.values()):
        assert type_name in generate_dynamic(type_name, message_definition(type_name))
        parts = message_definition(type_name).split("=" * 80 + "\n")
        store.register(get_types_from_msg(parts[0], type_name))


def test_type_hashes_are_rosidls():
    """The RIHS01 hashes that bags carry (rosbags' type system) are those rosidl
    generated for the installed interfaces."""
    import json
    import sys

    for type_name in set(TOPIC_TYPES.values()):
        pkg, _, name = type_name.split("/")
        data = json.loads((Path(sys.prefix) / "share" / pkg / "msg" / f"{name}.json").read_text())
        (expected,) = [e["hash_string"] for e in data["type_hashes"] if e["type_name"] == type_name]
        assert type_hash(type_name) == expected, type_name


def _episode_states(design, sample, cfg, every):
    """States of an in-process episode as NetState messages through CDR, as the sim node
    publishes them (same PublishingSimulation), plus the episode's result."""
    from tethernet_ros.ros.publishing import PublishingSimulation

    scen = build_scenario(design, actions_for(design, sample), world_for(design, sample), cfg)
    msgs = []
    sim = PublishingSimulation(scen, every, lambda s: msgs.append(
        serialize_message(conv.net_state_msg(state_arrays(s)))), lambda: False)
    sim.publish()
    result = run_simulation(sim, record_trace=False)
    sim.publish()
    return [deserialize_message(b, NetState) for b in msgs], result, scen


@pytest.mark.parametrize("every", [1000, 4321])
def test_state_mirror_gives_the_library_verdict(every):
    """Publishing every k steps changes nothing, and the mirror's verdict from the
    transported states is the library's result (the monitor's and replay's path)."""
    design, noise, cfg = load_design("time-min"), NoiseModel(), SimConfig(settle_time=1.0)
    sample = noise.sample(4)
    ref = run_episode(design, sample, cfg, record_trace=False)
    states, result, _ = _episode_states(design, sample, cfg, every)
    assert compare_results(result, ref) == ""
    assert states[-1].sim_time == ref.completion_time
    mirror = StateMirror(design, actions_for(design, sample), world_for(design, sample), cfg)
    verdicts = []
    for m in states:
        mirror.load(conv.net_state_from_msg(m))
        v = mirror.verdict()
        if v is not None:
            verdicts.append((m.step, v))
    assert len(verdicts) == 1 and verdicts[0][0] == states[-1].step
    assert compare_results(verdicts[0][1], ref) == ""
    res_msg = deserialize_message(serialize_message(
        conv.episode_result_msg(ref, "e", False)), EpisodeResult)
    assert compare_results(conv.episode_result_from_msg(res_msg), ref) == ""


def test_mirror_never_triggered_and_divergence():
    design = load_design("baseline")
    cfg = SimConfig(horizon=1.0)                # closing cannot trigger in 1 s
    ref = run_episode(design, None, cfg, record_trace=False)
    assert not math.isfinite(ref.settled_cqi) and "never triggered" in ref.failure_reason
    states, _, _ = _episode_states(design, None, cfg, 2000)
    mirror = StateMirror(design, actions_for(design, None), world_for(design, None), cfg)
    mirror.load(conv.net_state_from_msg(states[-1]))
    assert compare_results(mirror.verdict(), ref) == ""
    # a non-finite state at a check step ends the episode as run_simulation would
    st = conv.net_state_from_msg(states[1])
    st.step = mirror.check_every
    st.positions[5, 0] = math.nan
    mirror.load(st)
    assert mirror.terms() is None                # no CQI of a non-finite state
    v = mirror.verdict()
    assert v is not None and not v.success and v.failure_reason.startswith("simulation diverged")


def test_request_validation_names_the_field():
    from tethernet_msgs.msg import NoiseSettings

    d = conv.design_msg(load_design("time-min"))
    d.thread_radius = -1.0
    with pytest.raises(conv.RequestError, match=r"^design\.thread_radius: \(r_n\)"):
        conv.design_from_msg(d)
    n = conv.noise_settings_msg(NoiseModel())
    n.closing_scale = 101.0
    with pytest.raises(conv.RequestError, match=r"^noise\.closing_scale"):
        conv.noise_model_from_msg(n)
    # settings left out (the message defaults) are the nominal spreads, not zero noise
    assert conv.noise_model_from_msg(NoiseSettings()) == NoiseModel()
    assert conv.noise_settings_msg(None) == NoiseSettings()


def test_parameter_file_matches_node_defaults():
    doc = yaml.safe_load((ROOT / "config" / "tethernet.yaml").read_text())

    def flat(d, prefix=""):
        out = {}
        for k, v in d.items():
            if isinstance(v, dict):
                out.update(flat(v, f"{prefix}{k}."))
            else:
                out[f"{prefix}{k}"] = v
        return out

    # every parameter under /**: a /<node>: entry would beat launch arguments and -p
    # (config/tethernet.yaml's header; tests/test_ros_launch.py)
    assert set(doc) == {"/**"}
    shared = flat(doc["/**"]["ros__parameters"])
    for node, defaults in DEFAULTS.items():
        merged = shared
        declared = {k: merged[k] for k in defaults}            # every default is in the file
        assert declared == defaults, node
        for k, v in defaults.items():                          # same types (rclpy is strict)
            assert type(merged[k]) is type(v), (node, k)


def test_launch_file_and_console_scripts():
    launch = (ROOT / "launch" / "tethernet.launch.py").read_text()
    tree = ast.parse(launch)
    assert any(isinstance(n, ast.FunctionDef) and n.name == "generate_launch_description"
               for n in tree.body)
    setup = (ROOT / "setup.py").read_text()
    # the launch file starts names.NODES, with the launch arguments' rule
    assert "from tethernet_ros.ros.names import NODES" in launch
    assert "from tethernet_ros.ros.launch_arguments import" in launch
    from tethernet_ros.ros.names import NODES

    assert set(NODES) == set(DEFAULTS)
    for node in DEFAULTS:
        assert f"{node} = tethernet_ros.ros.nodes.{node}:main" in setup


def test_cdr_stamp_reads_the_header_stamp_of_every_stamped_topic():
    """The capture node decides that a bag is complete from stamps read in place from the
    serialized messages; they must be the stamps rclpy serialized, for every type, and a
    MarkerArray without markers has none."""
    from tethernet_ros.ros.recording import cdr_stamp, msg_class

    sim_time = 23.697514995715512
    sec, nsec = conv.split_time(sim_time)
    assert nsec > 0
    for key in STAMPED:
        cls = msg_class(TOPIC_TYPES[key])
        m = cls()
        if key == "clock":
            conv.set_time(m.clock, sim_time)
        elif key == "markers":
            from visualization_msgs.msg import Marker

            for _ in range(2):
                mk = Marker()
                conv.set_time(mk.header.stamp, sim_time)
                mk.header.frame_id = "chaser"
                m.markers.append(mk)
        else:
            conv.set_time(m.header.stamp, sim_time)
            m.header.frame_id = "chaser"          # a string after the stamp: must not matter
        assert cdr_stamp(key, serialize_message(m)) == (sec, nsec), key
    empty = msg_class(TOPIC_TYPES["markers"])()
    assert cdr_stamp("markers", serialize_message(empty)) is None


def test_the_recording_keeps_one_of_each_repeated_setup_or_command():
    """The setup handshake sends a setup (and the actuator its commands) again until the
    episode runs: the recording writes a message equal byte for byte to one already
    recorded once, and counts states as they come."""
    from tethernet_ros.ros.recording import Episode

    class Writer:
        def __init__(self):
            self.written = []

        def write(self, topic, data, t):
            self.written.append((topic, data))

    w = Writer()
    ep = Episode(episode_id="e", writer=w, started=0.0)
    for key, data in [("setup", b"\x00\x01\x00\x00A"), ("setup", b"\x00\x01\x00\x00A"),
                      ("launch_command", b"L"), ("launch_command", b"L"),
                      ("setup", b"\x00\x01\x00\x00B")]:
        ep.record(key, "/" + key, data)
    assert w.written == [("/setup", b"\x00\x01\x00\x00A"), ("/launch_command", b"L"),
                         ("/setup", b"\x00\x01\x00\x00B")]
    assert not ep.seen_running()


def test_setups_heard_by_episode_and_stamp():
    from types import SimpleNamespace as NS

    from tethernet_ros.ros.state import SetupsHeard

    def setup(eid, sec, nsec=0):
        return NS(episode_id=eid, header=NS(stamp=NS(sec=sec, nanosec=nsec)))

    heard = SetupsHeard(keep=2)
    assert not heard.repeat(setup("a", 1)) and heard.repeat(setup("a", 1))
    assert heard.is_latest(setup("a", 1))
    assert not heard.repeat(setup("a", 1, 5))           # same id, a later request: new
    assert not heard.repeat(setup("b", 2)) and heard.repeat(setup("a", 1, 5))
    assert not heard.is_latest(setup("a", 1, 5)) and heard.is_latest(setup("b", 2))
    assert not heard.repeat(setup("a", 1))              # forgotten beyond `keep`
