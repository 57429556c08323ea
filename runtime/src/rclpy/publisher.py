"""rclpy.publisher: a ROS publisher = one DDS writer that sends CDR bytes."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Union

from cage_ros_runtime import messages
from cage_ros_runtime.dds import RawWriter
from rclpy.exceptions import InvalidHandle
from rclpy.qos import QoSProfile

if TYPE_CHECKING:
    from rclpy.node import Node


class Publisher:
    """Created with `Node.create_publisher(msg_type, topic, qos_profile)`."""

    def __init__(self, node: 'Node', msg_type: Any, topic: str, qos_profile: QoSProfile,
                 writer: RawWriter) -> None:
        self.msg_type = msg_type
        self._ros_type = messages.type_of(msg_type)
        self.topic = topic
        self.qos_profile = qos_profile
        self._writer: RawWriter | None = writer
        self._node = node

    @property
    def topic_name(self) -> str:
        return self.topic

    @property
    def handle(self) -> RawWriter:
        if self._writer is None:
            raise InvalidHandle('publisher was destroyed')
        return self._writer

    def publish(self, msg: Union[Any, bytes]) -> None:
        """Serialize and send `msg`; `bytes` are sent as an already serialized CDR message (rclpy too)."""
        writer = self.handle
        if isinstance(msg, (bytes, bytearray, memoryview)):
            writer.write(bytes(msg))
            return
        if not isinstance(msg, self.msg_type):
            raise TypeError(f'Expected {self.msg_type}, got {type(msg)}')
        writer.write(messages.serialize(msg))

    def get_subscription_count(self) -> int:
        return self.handle.matched_count()

    def assert_liveliness(self) -> None:
        """Liveliness is AUTOMATIC: nothing to assert."""

    def wait_for_all_acked(self, timeout: Any = None) -> bool:
        from cyclonedds.util import duration
        ns = duration(infinite=True) if timeout is None or timeout.nanoseconds < 0 else timeout.nanoseconds
        try:
            return bool(self.handle.writer.wait_for_acks(ns))
        except Exception:  # noqa: BLE001 - best-effort writers have nothing to ack
            return True

    def destroy(self) -> bool:
        return self._node.destroy_publisher(self)

    def _close(self) -> None:
        if self._writer is not None:
            self._writer.close()
            self._writer = None

    def __enter__(self) -> 'Publisher':
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy()
