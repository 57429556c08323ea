"""rclpy.subscription: a ROS subscription = one DDS reader whose samples the executor dispatches."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable

from cage_ros_runtime import messages
from cage_ros_runtime.dds import RawReader
from rclpy.exceptions import InvalidHandle
from rclpy.qos import QoSProfile

if TYPE_CHECKING:
    from rclpy.node import Node


class Subscription:
    """Created with `Node.create_subscription(msg_type, topic, callback, qos_profile)`."""

    def __init__(self, node: 'Node', msg_type: Any, topic: str, callback: Callable[[Any], None],
                 qos_profile: QoSProfile, reader: RawReader, raw: bool = False) -> None:
        self.msg_type = msg_type
        self._ros_type = messages.type_of(msg_type)
        self.topic = topic
        self.callback = callback
        self.qos_profile = qos_profile
        self.raw = raw
        self._reader: RawReader | None = reader
        self._node = node

    @property
    def topic_name(self) -> str:
        return self.topic

    @property
    def handle(self) -> RawReader:
        if self._reader is None:
            raise InvalidHandle('subscription was destroyed')
        return self._reader

    def get_publisher_count(self) -> int:
        return self.handle.matched_count()

    def _take(self) -> list[bytes]:
        reader = self._reader
        return reader.take() if reader is not None else []

    def _dispatch(self, data: bytes) -> None:
        """Decode (unless raw) and call the user callback; runs in the spinning thread."""
        if self._reader is None:
            return  # destroyed while samples were queued
        self.callback(data if self.raw else messages.deserialize(data, self._ros_type))

    def destroy(self) -> bool:
        return self._node.destroy_subscription(self)

    def _close(self) -> None:
        if self._reader is not None:
            self._reader.close()
            self._reader = None

    def __enter__(self) -> 'Subscription':
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy()
