"""What the graph records and how: topic table and an MCAP (rosbag2) writer over rosbags.

ROS-free: the recorder node hands it serialized CDR bytes. The output is a rosbag2 folder with an
``.mcap`` file, readable by ``rosbags``, ``mcap-ros2-support``, Foxglove and ``ros2 bag play``.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

# topic (relative to the graph's namespace, except /tf and /goal_pose) -> (type, QoS kind the publisher
# offers). "latched": depth 1 reliable transient-local; "sensor": best effort; "reliable": depth 10.
GRAPH_TOPICS: dict[str, tuple[str, str]] = {
    "map": ("cage_planner_msgs/msg/CageMap", "latched"),
    "obstacles": ("visualization_msgs/msg/MarkerArray", "latched"),
    "plan": ("nav_msgs/msg/Path", "latched"),
    "track": ("nav_msgs/msg/Path", "latched"),
    "planner_status": ("cage_planner_msgs/msg/PlannerStatus", "latched"),
    "mission": ("cage_planner_msgs/msg/Mission", "latched"),
    "scan": ("sensor_msgs/msg/LaserScan", "sensor"),
    "odom": ("nav_msgs/msg/Odometry", "reliable"),
    "/tf": ("tf2_msgs/msg/TFMessage", "reliable"),
    "heading_setpoint": ("cage_planner_msgs/msg/HeadingSetpoint", "reliable"),
    "mission_event": ("cage_planner_msgs/msg/MissionEvent", "reliable"),
    "plan_request": ("geometry_msgs/msg/PoseStamped", "reliable"),
    "/goal_pose": ("geometry_msgs/msg/PoseStamped", "reliable"),
}

_INFINITE = QosTime(sec=2147483647, nsec=4294967295)   # how rosbag2 (Jazzy) writes an infinite duration


def offered_qos(kind: str) -> Qos:
    """The QoS the graph's publishers offer for a kind of topic, as rosbag2 records it in
    metadata.yaml (offered_qos_profiles), so ``ros2 bag play`` replays latched topics latched."""
    reliability = QosReliability.BEST_EFFORT if kind == "sensor" else QosReliability.RELIABLE
    durability = QosDurability.TRANSIENT_LOCAL if kind == "latched" else QosDurability.VOLATILE
    depth = {"latched": 1, "sensor": 5}.get(kind, 10)
    return Qos(QosHistory.KEEP_LAST, depth, reliability, durability, _INFINITE, _INFINITE,
               QosLiveliness.AUTOMATIC, _INFINITE, False)


def typestore_with(msg_dirs: Iterable[Path]):
    """Jazzy's standard types plus the project's own ``.msg`` files (found in ``msg_dirs``)."""
    store = get_typestore(Stores.ROS2_JAZZY)
    add = {}
    for d in msg_dirs:
        pkg = d.parent.name
        for f in sorted(Path(d).glob("*.msg")):
            add.update(get_types_from_msg(f.read_text(), f"{pkg}/msg/{f.stem}"))
    store.register(add)
    return store


class McapRecorder:
    """Writes serialized messages of known topics to a rosbag2 folder with MCAP storage."""

    def __init__(self, path: str | Path, topics: dict[str, tuple[str, str]], msg_dirs: Iterable[Path]):
        """``topics``: fully qualified name -> (type, QoS kind of GRAPH_TOPICS)."""
        self.path = Path(path)
        if self.path.exists():
            raise ValueError(f"output {self.path} exists already; rosbag2 folders are not overwritten")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.store = typestore_with(msg_dirs)
        self.writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self.writer.open()
        self.connections = {t: self.writer.add_connection(t, ty, typestore=self.store,
                                                          offered_qos_profiles=[offered_qos(kind)])
                            for t, (ty, kind) in topics.items()}
        self.count = 0

    def write(self, topic: str, timestamp_ns: int, data: bytes) -> None:
        self.writer.write(self.connections[topic], timestamp_ns, bytes(data))
        self.count += 1

    def close(self) -> None:
        self.writer.close()
