"""recorder_node: records the graph's topics to MCAP (a rosbag2 folder), for Foxglove or ros2 bag play.

Subscribes to each topic raw (serialized CDR, as ``ros2 bag record`` does) with the QoS its
publisher offers, and writes every message with its receive time under its fully qualified name
(the names are relative: run it in the graph's namespace). metadata.yaml records the offered QoS, so
latched topics replay latched. On ROS 2 proper,
``ros2 bag record -s mcap`` does the same job; this node works in both worlds.
"""
from __future__ import annotations

import importlib
import time
from pathlib import Path

from ament_index_python.packages import get_package_share_directory
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

from .node_common import declare
from .node_runner import run_node
from ..recording import GRAPH_TOPICS, McapRecorder

QOS = {
    "latched": QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL),
    "sensor": qos_profile_sensor_data,
    "reliable": QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE),
}


def message_class(msgtype: str):
    """``pkg/msg/Name`` -> the message class, imported as node code imports it in either world."""
    pkg, _, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{pkg}.msg"), name)


class RecorderNode(Node):
    def __init__(self) -> None:
        super().__init__("recorder_node")
        p = declare(self, output="out/mission_bag", topics=list(GRAPH_TOPICS))
        unknown = [t for t in p["topics"] if t not in GRAPH_TOPICS]
        if unknown:
            raise ValueError(f"topics: cannot record {unknown}; known: {sorted(GRAPH_TOPICS)}")
        msg_dir = Path(get_package_share_directory("cage_planner_msgs")) / "msg"
        names = {t: self.resolve_topic_name(t) for t in p["topics"]}
        self.rec = McapRecorder(p["output"], {names[t]: GRAPH_TOPICS[t] for t in p["topics"]}, [msg_dir])
        for topic in p["topics"]:
            msgtype, kind = GRAPH_TOPICS[topic]
            self.create_subscription(message_class(msgtype), topic, self.writer_for(names[topic]), QOS[kind], raw=True)
        self.get_logger().info(f"recording {len(p['topics'])} topics to {p['output']}")

    def writer_for(self, topic: str):
        def write(data: bytes) -> None:
            self.rec.write(topic, time.time_ns(), data)
        return write

    def destroy_node(self) -> None:
        self.rec.close()
        self.get_logger().info(f"recorded {self.rec.count} messages to {self.rec.path}")
        super().destroy_node()


def main(args=None) -> None:
    run_node(RecorderNode, args)


if __name__ == "__main__":
    main()
