"""Read a rosbag2 MCAP bag back (for replay): its topics and its serialized messages in time order. No ROS here.

A bag is a directory with ``metadata.yaml`` (as BagWriter and ``ros2 bag record -s mcap`` leave it) or a single
``.mcap`` file.

    for topic in bag_topics("demo_out/bag"):
        print(topic.name, topic.type_name, topic.count)
    for topic, log_time_ns, data in bag_messages("demo_out/bag"):
        ...
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import yaml
from mcap.reader import make_reader

from latent_planner_ros.recording.bag_writer import TopicQos


@dataclass(frozen=True)
class BagTopic:
    """A topic of a bag: name, type (``package/msg/Type``), offered QoS and message count."""

    name: str
    type_name: str
    qos: TopicQos
    count: int


def bag_files(path: str | Path) -> list[Path]:
    """The MCAP files of a bag directory (``metadata.yaml``'s, else every ``*.mcap`` in it) or of a ``.mcap`` path.
    FileNotFoundError when there are none."""
    path = Path(path)
    if path.is_file():
        return [path]
    meta = path / "metadata.yaml"
    if meta.is_file():
        info = yaml.safe_load(meta.read_text())["rosbag2_bagfile_information"]
        files = [path / Path(p).name for p in info["relative_file_paths"]]
    else:
        files = sorted(path.glob("*.mcap"))
    if not files or not all(f.is_file() for f in files):
        raise FileNotFoundError(f"{path}: no rosbag2 MCAP bag (a directory with metadata.yaml, or a .mcap file)")
    return files


def _qos(metadata: dict) -> TopicQos:
    try:
        profile = (yaml.safe_load(metadata.get("offered_qos_profiles", "")) or [{}])[0]
    except yaml.YAMLError:
        profile = {}
    return TopicQos(
        reliable=str(profile.get("reliability", "reliable")) != "best_effort",
        transient_local=str(profile.get("durability", "volatile")) == "transient_local",
        depth=int(profile.get("depth", 10) or 10),
    )


def bag_topics(path: str | Path) -> list[BagTopic]:
    """The topics of a bag, in the order of their channels."""
    topics: dict[str, BagTopic] = {}
    for file in bag_files(path):
        with open(file, "rb") as stream:
            summary = make_reader(stream).get_summary()
        if summary is None:
            raise ValueError(f"{file}: the MCAP file has no summary (was the recording cut short?)")
        counts = summary.statistics.channel_message_counts if summary.statistics else {}
        for cid, channel in summary.channels.items():
            schema = summary.schemas[channel.schema_id]
            before = topics.get(channel.topic)
            count = counts.get(cid, 0) + (before.count if before else 0)
            topics[channel.topic] = BagTopic(channel.topic, schema.name, _qos(channel.metadata), count)
    return list(topics.values())


def bag_messages(path: str | Path, topics: Iterable[str] | None = None) -> Iterator[tuple[str, int, bytes]]:
    """(topic, log time [ns since the epoch], CDR bytes) of every message (of `topics` if given), in log-time order
    within each file."""
    wanted = None if topics is None else set(topics)
    for file in bag_files(path):
        with open(file, "rb") as stream:
            for _, channel, message in make_reader(stream).iter_messages(topics=wanted, log_time_order=True):
                yield channel.topic, message.log_time, message.data


def paced(
    messages: Iterable[tuple[str, int, bytes]],
    rate: float = 1.0,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> Iterator[tuple[str, int, bytes]]:
    """The messages, each yielded when as much time [s] has passed since the first as between their log times
    (divided by `rate`: 2 plays twice as fast)."""
    if rate <= 0:
        raise ValueError(f"rate must be positive, got {rate}")
    first, start = None, clock()
    for item in messages:
        if first is None:
            first = item[1]
        wait = start + (item[1] - first) * 1e-9 / rate - clock()
        if wait > 0:
            sleep(wait)
        yield item
