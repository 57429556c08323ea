"""What the graph records and how: topic table and an MCAP (rosbag2) writer over rosbags.

ROS-free: the recorder node hands it serialized CDR bytes. The output is a rosbag2 folder with an
``.mcap`` file, readable by ``rosbags``, ``mcap-ros2-support``, Foxglove and ``ros2 bag play``.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable

from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

# topic -> (type, QoS kind). "latched": depth 1 reliable transient-local; "sensor": best effort.
GRAPH_TOPICS: dict[str, tuple[str, str]] = {
    "/cage/map": ("cage_planner_msgs/msg/CageMap", "latched"),
    "/cage/obstacles": ("visualization_msgs/msg/MarkerArray", "latched"),
    "/cage/plan": ("nav_msgs/msg/Path", "latched"),
    "/cage/track": ("nav_msgs/msg/Path", "latched"),
    "/cage/planner_status": ("cage_planner_msgs/msg/PlannerStatus", "latched"),
    "/cage/scan": ("sensor_msgs/msg/LaserScan", "sensor"),
    "/cage/odom": ("nav_msgs/msg/Odometry", "reliable"),
    "/tf": ("tf2_msgs/msg/TFMessage", "reliable"),
    "/cage/heading_setpoint": ("cage_planner_msgs/msg/HeadingSetpoint", "reliable"),
    "/cage/mission_event": ("cage_planner_msgs/msg/MissionEvent", "reliable"),
    "/goal_pose": ("geometry_msgs/msg/PoseStamped", "reliable"),
}


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

    def __init__(self, path: str | Path, topics: dict[str, str], msg_dirs: Iterable[Path]):
        self.path = Path(path)
        if self.path.exists():
            raise ValueError(f"output {self.path} exists already; rosbag2 folders are not overwritten")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.store = typestore_with(msg_dirs)
        self.writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self.writer.open()
        self.connections = {t: self.writer.add_connection(t, ty, typestore=self.store) for t, ty in topics.items()}
        self.count = 0

    def write(self, topic: str, timestamp_ns: int, data: bytes) -> None:
        self.writer.write(self.connections[topic], timestamp_ns, bytes(data))
        self.count += 1

    def close(self) -> None:
        self.writer.close()
