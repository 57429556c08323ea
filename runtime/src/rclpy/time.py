"""rclpy.time: a point in time (integer nanoseconds) tied to a clock type."""

from __future__ import annotations

from typing import Any

from rclpy.clock_type import ClockType
from rclpy.duration import Duration

_NS = 1_000_000_000


class Time:
    """`Time(seconds=..., nanoseconds=..., clock_type=ClockType.SYSTEM_TIME)`; never negative."""

    __slots__ = ('_nanoseconds', '_clock_type')

    def __init__(self, *, seconds: float = 0, nanoseconds: int = 0,
                 clock_type: ClockType = ClockType.SYSTEM_TIME) -> None:
        if not isinstance(clock_type, ClockType):
            raise TypeError('Clock type must be a ClockType enum')
        if seconds < 0:
            raise ValueError('Seconds value must not be negative')
        if nanoseconds < 0:
            raise ValueError('Nanoseconds value must not be negative')
        total = int(seconds * _NS) + int(nanoseconds)
        if total >= 2 ** 63:
            raise OverflowError('Total nanoseconds value is too large to store in C time point.')
        self._nanoseconds = total
        self._clock_type = clock_type

    @property
    def nanoseconds(self) -> int:
        return self._nanoseconds

    @property
    def clock_type(self) -> ClockType:
        return self._clock_type

    def seconds_nanoseconds(self) -> tuple[int, int]:
        return divmod(self._nanoseconds, _NS)

    def __repr__(self) -> str:
        return f'Time(nanoseconds={self._nanoseconds}, clock_type={self._clock_type.name})'

    def __str__(self) -> str:
        return repr(self)

    def __add__(self, other: Any) -> 'Time':
        if isinstance(other, Duration):
            return Time(nanoseconds=self._nanoseconds + other.nanoseconds, clock_type=self._clock_type)
        return NotImplemented

    __radd__ = __add__

    def __sub__(self, other: Any) -> Any:
        if isinstance(other, Time):
            if other._clock_type != self._clock_type:
                raise TypeError("Can't subtract times with different clock types")
            return Duration(nanoseconds=self._nanoseconds - other._nanoseconds)
        if isinstance(other, Duration):
            return Time(nanoseconds=self._nanoseconds - other.nanoseconds, clock_type=self._clock_type)
        return NotImplemented

    def _check(self, other: Any) -> 'Time':
        if not isinstance(other, Time):
            raise TypeError("Can't compare time with object of type: " + str(type(other)))
        if other._clock_type != self._clock_type:
            raise TypeError("Can't compare times with different clock types")
        return other

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Time):
            return self._clock_type == other._clock_type and self._nanoseconds == other._nanoseconds
        return NotImplemented

    def __hash__(self) -> int:
        return hash((self._nanoseconds, self._clock_type))

    def __lt__(self, other: 'Time') -> bool:
        return self._nanoseconds < self._check(other)._nanoseconds

    def __le__(self, other: 'Time') -> bool:
        return self._nanoseconds <= self._check(other)._nanoseconds

    def __gt__(self, other: 'Time') -> bool:
        return self._nanoseconds > self._check(other)._nanoseconds

    def __ge__(self, other: 'Time') -> bool:
        return self._nanoseconds >= self._check(other)._nanoseconds

    def to_msg(self) -> Any:
        from builtin_interfaces.msg import Time as TimeMsg
        sec, nsec = divmod(self._nanoseconds, _NS)
        return TimeMsg(sec=sec, nanosec=nsec)

    @classmethod
    def from_msg(cls, msg: Any, clock_type: ClockType = ClockType.ROS_TIME) -> 'Time':
        return cls(seconds=msg.sec, nanoseconds=msg.nanosec, clock_type=clock_type)
