"""rclpy.duration: a signed span of time in integer nanoseconds."""

from __future__ import annotations

from typing import Any

_NS = 1_000_000_000


class Duration:
    """`Duration(seconds=1.5)` or `Duration(seconds=1, nanoseconds=500_000_000)`."""

    __slots__ = ('_nanoseconds',)

    def __init__(self, *, seconds: float = 0, nanoseconds: int = 0) -> None:
        total = int(seconds * _NS) + int(nanoseconds)
        if not -(2 ** 63) <= total < 2 ** 63:
            raise OverflowError('Total nanoseconds value is too large to store in C duration.')
        self._nanoseconds = total

    @property
    def nanoseconds(self) -> int:
        return self._nanoseconds

    def __repr__(self) -> str:
        return f'Duration(nanoseconds={self._nanoseconds})'

    def __str__(self) -> str:
        return f'{self._nanoseconds / _NS} seconds'

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Duration):
            return self._nanoseconds == other._nanoseconds
        return NotImplemented

    def __lt__(self, other: 'Duration') -> bool:
        return self._nanoseconds < other._nanoseconds

    def __le__(self, other: 'Duration') -> bool:
        return self._nanoseconds <= other._nanoseconds

    def __gt__(self, other: 'Duration') -> bool:
        return self._nanoseconds > other._nanoseconds

    def __ge__(self, other: 'Duration') -> bool:
        return self._nanoseconds >= other._nanoseconds

    def __hash__(self) -> int:
        return hash(self._nanoseconds)

    def __add__(self, other: Any) -> Any:
        if isinstance(other, Duration):
            return Duration(nanoseconds=self._nanoseconds + other._nanoseconds)
        return NotImplemented

    def __sub__(self, other: Any) -> Any:
        if isinstance(other, Duration):
            return Duration(nanoseconds=self._nanoseconds - other._nanoseconds)
        return NotImplemented

    def __mul__(self, factor: float) -> 'Duration':
        return Duration(nanoseconds=int(self._nanoseconds * factor))

    __rmul__ = __mul__

    def __neg__(self) -> 'Duration':
        return Duration(nanoseconds=-self._nanoseconds)

    def to_msg(self) -> Any:
        from builtin_interfaces.msg import Duration as DurationMsg
        sec, nsec = divmod(self._nanoseconds, _NS)
        return DurationMsg(sec=sec, nanosec=nsec)

    @classmethod
    def from_msg(cls, msg: Any) -> 'Duration':
        return cls(seconds=msg.sec, nanoseconds=msg.nanosec)

    def get_c_duration(self) -> int:
        return self._nanoseconds

    def seconds_nanoseconds(self) -> tuple[int, int]:
        return divmod(self._nanoseconds, _NS)

    def to_seconds(self) -> float:  # not in Jazzy's rclpy, harmless convenience
        return self._nanoseconds / _NS


Infinite = Duration(nanoseconds=2 ** 63 - 1)
