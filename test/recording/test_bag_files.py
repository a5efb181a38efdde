"""BagWriter and the reader used by replay, without a ROS graph: written bags read back by our reader and rosbags."""

from __future__ import annotations

import pytest
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from std_msgs.msg import Bool, String

from latent_planner_ros.recording.bag_reader import bag_messages, bag_topics, paced
from latent_planner_ros.recording.bag_writer import BagWriter, TopicQos


def _write(path) -> BagWriter:
    with BagWriter(path) as bag:
        bag.add_topic("/flag", "std_msgs/msg/Bool", TopicQos(reliable=False))
        bag.add_topic("/latched", "std_msgs/msg/String", TopicQos(transient_local=True, depth=1))
        for i in range(5):
            bag.write("/flag", 1_000_000_000 + i * 10_000_000, serialize_message(Bool(data=i % 2 == 1)))
        bag.write("/latched", 1_005_000_000, serialize_message(String(data="owner")))
    return bag


def test_a_written_bag_reads_back_with_its_topics_qos_and_order(tmp_path):
    _write(tmp_path / "bag")
    topics = {t.name: t for t in bag_topics(tmp_path / "bag")}
    assert topics["/flag"].count == 5 and topics["/flag"].type_name == "std_msgs/msg/Bool"
    assert not topics["/flag"].qos.reliable
    assert topics["/latched"].qos.transient_local and topics["/latched"].qos.depth == 1
    messages = list(bag_messages(tmp_path / "bag"))
    assert [t for _, t, _ in messages] == sorted(t for _, t, _ in messages)
    assert [topic for topic, _, _ in messages].count("/flag") == 5
    with AnyReader([tmp_path / "bag"], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        decoded = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()]
    assert [m.data for m in decoded if hasattr(m, "data") and isinstance(m.data, bool)] == [
        False,
        True,
        False,
        True,
        False,
    ]
    assert "owner" in [m.data for m in decoded]
    assert list(bag_messages(tmp_path / "bag" / "bag_0.mcap"))  # a lone .mcap file reads too


def test_an_existing_bag_is_not_overwritten_unless_asked(tmp_path):
    _write(tmp_path / "bag")
    with pytest.raises(FileExistsError):
        BagWriter(tmp_path / "bag")
    BagWriter(tmp_path / "bag", overwrite=True).close()
    assert bag_topics(tmp_path / "bag") == []


def test_paced_waits_the_recorded_gaps_scaled_by_the_rate():
    now = [0.0]
    waits = []

    def sleep(s):
        waits.append(round(s, 6))
        now[0] += s

    items = [("a", 0, b""), ("a", 500_000_000, b""), ("a", 2_000_000_000, b"")]
    assert list(paced(items, rate=2.0, clock=lambda: now[0], sleep=sleep)) == items
    assert waits == [0.25, 0.75]
    with pytest.raises(ValueError):
        list(paced(items, rate=0.0))
