"""Lazy `<pkg>.msg` modules: `from sensor_msgs.msg import LaserScan` builds the class on first access.

Why lazy module attributes (PEP 562) instead of generated source: the type store is the single source of
truth (rosbags' Jazzy definitions and the project's `.msg` files), so nothing generated can go stale.  The
thin package directories that call this live next to `rclpy/` in this distribution; being ordinary
packages on sys.path, a real ROS 2 install earlier on sys.path (its PYTHONPATH entries) always wins.
"""

from __future__ import annotations

from typing import Any, Callable

from cage_ros_runtime.messages import message_class
from cage_ros_runtime.typestore import typestore


def names(package: str) -> list[str]:
    """Message names of `package` in the type store."""
    prefix = f'{package}/msg/'
    return sorted(n[len(prefix):] for n in typestore().fielddefs if n.startswith(prefix))


def module_hooks(package: str) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """`(__getattr__, __dir__)` for the `msg` module of `package`."""

    def __getattr__(attr: str) -> Any:
        if attr.startswith('__'):
            raise AttributeError(attr)
        ros_type = f'{package}/msg/{attr}'
        if ros_type not in typestore().fielddefs:
            raise AttributeError(f"module '{package}.msg' has no message {attr!r}")
        return message_class(ros_type)

    def __dir__() -> list[str]:
        return names(package)

    return __getattr__, __dir__
