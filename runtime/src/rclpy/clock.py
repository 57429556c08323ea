"""rclpy.clock: system, steady and ROS clocks.

ROS time follows the system clock unless a node sets `use_sim_time`, in which case the node's
:class:`ROSClock` is driven by `/clock` (rosgraph_msgs/Clock) as in rclpy's TimeSource.
"""

from __future__ import annotations

import time as _time
from typing import Optional

from rclpy.clock_type import ClockType
from rclpy.duration import Duration
from rclpy.time import Time


class Clock:
    """`Clock(clock_type=ClockType.SYSTEM_TIME).now()`."""

    def __init__(self, *, clock_type: ClockType = ClockType.SYSTEM_TIME) -> None:
        if not isinstance(clock_type, ClockType):
            raise TypeError('Clock type must be a ClockType enum')
        if clock_type == ClockType.ROS_TIME and type(self) is Clock:
            self.__class__ = ROSClock
            ROSClock.__init__(self)  # type: ignore[misc]
            return
        self._clock_type = clock_type

    @property
    def clock_type(self) -> ClockType:
        return self._clock_type

    def now(self) -> Time:
        if self._clock_type == ClockType.STEADY_TIME:
            return Time(nanoseconds=_time.monotonic_ns(), clock_type=self._clock_type)
        return Time(nanoseconds=_time.time_ns(), clock_type=self._clock_type)

    def sleep_for(self, rel_time: Duration, context: object = None) -> bool:
        return self.sleep_until(self.now() + rel_time, context)

    def sleep_until(self, until: Time, context: object = None) -> bool:
        """Sleep (in short slices, so shutdown is noticed) until `until`; False if the context shut down."""
        from rclpy.utilities import get_default_context
        ctx = context or get_default_context()
        while ctx.ok():
            remaining = (until - self.now()).nanoseconds
            if remaining <= 0:
                return True
            _time.sleep(min(remaining / 1e9, 0.05))
        return False

    def __repr__(self) -> str:
        return f'Clock(clock_type={self._clock_type.name})'


class ROSClock(Clock):
    """The ROS clock: system time, or the last `/clock` time when ROS time is active."""

    def __init__(self) -> None:
        self._clock_type = ClockType.ROS_TIME
        self._ros_time_active = False
        self._ros_time_override: Optional[int] = None

    @property
    def ros_time_is_active(self) -> bool:
        return self._ros_time_active

    def _set_ros_time_is_active(self, enabled: bool) -> None:
        self._ros_time_active = enabled

    def set_ros_time_override(self, time: Time) -> None:
        self._ros_time_override = time.nanoseconds

    def now(self) -> Time:
        if self._ros_time_active:
            return Time(nanoseconds=self._ros_time_override or 0, clock_type=ClockType.ROS_TIME)
        return Time(nanoseconds=_time.time_ns(), clock_type=ClockType.ROS_TIME)
