"""A rosbag2 bag of one MCAP file, written from serialized messages. No ROS here.

The bag is a directory holding ``<name>_0.mcap`` and ``metadata.yaml`` (rosbag2 format version 9, storage
``mcap``), the layout ``ros2 bag record -s mcap`` leaves: ``ros2 bag info/play DIR`` and rosbags read it. The MCAP
file follows rosbag2's conventions: profile ``ros2``, one schema per type (encoding ``ros2msg``, the text of
recording/msgdef.py), one channel per topic (message encoding ``cdr``, metadata ``offered_qos_profiles``),
zstd-compressed chunks. Messages are the CDR bytes a subscription delivers (with their 4-byte encapsulation
header), stamped with their receipt time [ns since the epoch].

    with BagWriter("runs/bag") as bag:
        ch = bag.add_topic("/joint_states", "sensor_msgs/msg/JointState", TopicQos())
        bag.write(ch, time.time_ns(), data)
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import yaml
from mcap.writer import CompressionType, Writer

from latent_planner_ros.recording.msgdef import message_definition

METADATA_VERSION = 9
"""rosbag2 metadata version (Jazzy's)."""
_FOREVER = {"sec": 9223372036, "nsec": 854775807}


@dataclass(frozen=True)
class TopicQos:
    """The QoS a topic was offered with, as ``ros2 bag play`` re-offers it.

    Attributes:
        reliable: reliable (else best effort).
        transient_local: late joiners get the last messages (else volatile).
        depth: history depth.
    """

    reliable: bool = True
    transient_local: bool = False
    depth: int = 10

    def yaml(self) -> str:
        """The ``offered_qos_profiles`` text of rosbag2 (a YAML list of one profile)."""
        profile = {
            "history": "keep_last",
            "depth": int(self.depth),
            "reliability": "reliable" if self.reliable else "best_effort",
            "durability": "transient_local" if self.transient_local else "volatile",
            "deadline": dict(_FOREVER),
            "lifespan": dict(_FOREVER),
            "liveliness": "automatic",
            "liveliness_lease_duration": dict(_FOREVER),
            "avoid_ros_namespace_conventions": False,
        }
        return yaml.safe_dump([profile], sort_keys=False)


@dataclass
class _Topic:
    name: str
    type_name: str
    qos: TopicQos
    channel: int
    count: int = 0


class BagWriter:
    """Writes one bag directory (see the module docstring).

    Args:
        path: the bag directory; created. An existing one is refused (FileExistsError) unless `overwrite`.
        chunk_size: [bytes] uncompressed MCAP chunk size.
    """

    def __init__(self, path: str | Path, overwrite: bool = False, chunk_size: int = 4 * 1024 * 1024):
        self.path = Path(path)
        if self.path.exists():
            if not overwrite and (not self.path.is_dir() or any(self.path.iterdir())):
                raise FileExistsError(f"{self.path} exists (a bag is written into a new directory)")
            shutil.rmtree(self.path) if self.path.is_dir() else self.path.unlink()
        self.path.mkdir(parents=True)
        self.file = self.path / f"{self.path.name}_0.mcap"
        self._stream = open(self.file, "wb")  # noqa: SIM115 (closed in close())
        self._mcap = Writer(self._stream, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self._mcap.start(profile="ros2", library="latent_planner_ros")
        self._schemas: dict[str, int] = {}
        self.topics: dict[str, _Topic] = {}
        self.start_ns: int | None = None
        self.end_ns: int | None = None
        self.closed = False

    def add_topic(self, topic: str, type_name: str, qos: TopicQos | None = None) -> int:
        """Register a topic (once; its first type wins) and return its channel id. MessageDefinitionError when the
        type's ``.msg`` file is not installed."""
        if topic in self.topics:
            return self.topics[topic].channel
        if type_name not in self._schemas:
            text = message_definition(type_name)
            self._schemas[type_name] = self._mcap.register_schema(type_name, "ros2msg", text.encode())
        qos = qos or TopicQos()
        channel = self._mcap.register_channel(
            topic, "cdr", self._schemas[type_name], metadata={"offered_qos_profiles": qos.yaml()}
        )
        self.topics[topic] = _Topic(topic, type_name, qos, channel)
        return channel

    def write(self, topic: str, log_time_ns: int, data: bytes) -> None:
        """Append one serialized message of a registered topic, received at `log_time_ns` [ns since the epoch]."""
        entry = self.topics[topic]
        entry.count += 1
        self._mcap.add_message(entry.channel, log_time_ns, bytes(data), log_time_ns, sequence=entry.count)
        self.start_ns = log_time_ns if self.start_ns is None else min(self.start_ns, log_time_ns)
        self.end_ns = log_time_ns if self.end_ns is None else max(self.end_ns, log_time_ns)

    @property
    def message_count(self) -> int:
        return sum(t.count for t in self.topics.values())

    def metadata(self) -> dict:
        """The content of ``metadata.yaml``."""
        start = self.start_ns or 0
        duration = (self.end_ns - start) if self.end_ns is not None else 0
        count = self.message_count
        return {
            "rosbag2_bagfile_information": {
                "version": METADATA_VERSION,
                "storage_identifier": "mcap",
                "relative_file_paths": [self.file.name],
                "duration": {"nanoseconds": duration},
                "starting_time": {"nanoseconds_since_epoch": start},
                "message_count": count,
                "topics_with_message_count": [
                    {
                        "topic_metadata": {
                            "name": t.name,
                            "type": t.type_name,
                            "serialization_format": "cdr",
                            "offered_qos_profiles": t.qos.yaml(),
                            "type_description_hash": "",
                        },
                        "message_count": t.count,
                    }
                    for t in self.topics.values()
                ],
                "compression_format": "",
                "compression_mode": "",
                "files": [
                    {
                        "path": self.file.name,
                        "starting_time": {"nanoseconds_since_epoch": start},
                        "duration": {"nanoseconds": duration},
                        "message_count": count,
                    }
                ],
                "custom_data": None,
                "ros_distro": "jazzy",
            }
        }

    def close(self) -> None:
        """Finish the MCAP file (summary and index) and write ``metadata.yaml``; idempotent."""
        if self.closed:
            return
        self.closed = True
        self._mcap.finish()
        self._stream.close()
        info = self.metadata()
        (self.path / "metadata.yaml").write_text(yaml.safe_dump(info, sort_keys=False))

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
