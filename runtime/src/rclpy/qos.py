"""rclpy.qos: QoS profiles and policies with Jazzy's names, values and presets.

The DDS translation (what a profile becomes on the wire) lives in cage_ros_runtime.dds.endpoint_qos.
"""

from __future__ import annotations

from enum import IntEnum
from typing import Any

from rclpy.duration import Duration


class InvalidQoSProfileException(Exception):
    """Raised when constructing a QoSProfile with invalid arguments."""

    def __init__(self, *args: Any) -> None:
        Exception.__init__(self, 'Invalid QoSProfile', *args)


class QoSPolicyEnum(IntEnum):
    """Base for policy enums: adds ROS 2's short keys (`best_effort`, `transient_local`, ...)."""

    @classmethod
    def short_keys(cls) -> list[str]:
        return [k.lower() for k in cls.__members__]

    @classmethod
    def get_from_short_key(cls, name: str) -> 'QoSPolicyEnum':
        return cls[name.upper()]

    @property
    def short_key(self) -> str:
        return self.name.lower()


class HistoryPolicy(QoSPolicyEnum):
    SYSTEM_DEFAULT = 0
    KEEP_LAST = 1
    KEEP_ALL = 2
    UNKNOWN = 3


class ReliabilityPolicy(QoSPolicyEnum):
    SYSTEM_DEFAULT = 0
    RELIABLE = 1
    BEST_EFFORT = 2
    UNKNOWN = 3
    BEST_AVAILABLE = 4


class DurabilityPolicy(QoSPolicyEnum):
    SYSTEM_DEFAULT = 0
    TRANSIENT_LOCAL = 1
    VOLATILE = 2
    UNKNOWN = 3
    BEST_AVAILABLE = 4


class LivelinessPolicy(QoSPolicyEnum):
    SYSTEM_DEFAULT = 0
    AUTOMATIC = 1
    MANUAL_BY_TOPIC = 3
    UNKNOWN = 4
    BEST_AVAILABLE = 5


# Deprecated aliases still found in node code.
QoSHistoryPolicy = HistoryPolicy
QoSReliabilityPolicy = ReliabilityPolicy
QoSDurabilityPolicy = DurabilityPolicy
QoSLivelinessPolicy = LivelinessPolicy

_UNSPECIFIED = Duration()


def _as_duration(value: Any) -> Duration:
    if isinstance(value, Duration):
        return value
    if value is None:
        return Duration()
    # builtin_interfaces/Duration or anything with sec/nanosec
    return Duration(seconds=getattr(value, 'sec', 0), nanoseconds=getattr(value, 'nanosec', 0))


class QoSProfile:
    """A QoS profile (history, depth, reliability, durability, lifespan, deadline, liveliness).

    As in rclpy: a profile needs `history` and/or `depth`; giving only `depth` means KEEP_LAST; the other
    policies default to rmw's default profile (RELIABLE, VOLATILE, AUTOMATIC liveliness).
    """

    __slots__ = ('_history', '_depth', '_reliability', '_durability', '_lifespan', '_deadline',
                 '_liveliness', '_liveliness_lease_duration', '_avoid_ros_namespace_conventions')

    def __init__(self, **kwargs: Any) -> None:
        known = {s[1:] for s in self.__slots__}
        unknown = set(kwargs) - known
        assert not unknown, f'Invalid arguments passed to constructor: {", ".join(sorted(unknown))}'
        if 'history' not in kwargs:
            if 'depth' not in kwargs:
                raise InvalidQoSProfileException('History and/or depth settings are required.')
            kwargs['history'] = HistoryPolicy.KEEP_LAST
        self.history = kwargs['history']
        if self.history == HistoryPolicy.KEEP_LAST and 'depth' not in kwargs:
            raise InvalidQoSProfileException('History set to KEEP_LAST without a depth setting.')
        self.depth = kwargs.get('depth', 0)
        self.reliability = kwargs.get('reliability', ReliabilityPolicy.RELIABLE)
        self.durability = kwargs.get('durability', DurabilityPolicy.VOLATILE)
        self.lifespan = kwargs.get('lifespan', Duration())
        self.deadline = kwargs.get('deadline', Duration())
        self.liveliness = kwargs.get('liveliness', LivelinessPolicy.SYSTEM_DEFAULT)
        self.liveliness_lease_duration = kwargs.get('liveliness_lease_duration', Duration())
        self.avoid_ros_namespace_conventions = kwargs.get('avoid_ros_namespace_conventions', False)

    history = property(lambda self: self._history,
                       lambda self, v: setattr(self, '_history', HistoryPolicy(v)))
    reliability = property(lambda self: self._reliability,
                           lambda self, v: setattr(self, '_reliability', ReliabilityPolicy(v)))
    durability = property(lambda self: self._durability,
                          lambda self, v: setattr(self, '_durability', DurabilityPolicy(v)))
    liveliness = property(lambda self: self._liveliness,
                          lambda self, v: setattr(self, '_liveliness', LivelinessPolicy(v)))
    lifespan = property(lambda self: self._lifespan,
                        lambda self, v: setattr(self, '_lifespan', _as_duration(v)))
    deadline = property(lambda self: self._deadline,
                        lambda self, v: setattr(self, '_deadline', _as_duration(v)))
    liveliness_lease_duration = property(
        lambda self: self._liveliness_lease_duration,
        lambda self, v: setattr(self, '_liveliness_lease_duration', _as_duration(v)))
    avoid_ros_namespace_conventions = property(
        lambda self: self._avoid_ros_namespace_conventions,
        lambda self, v: setattr(self, '_avoid_ros_namespace_conventions', bool(v)))

    @property
    def depth(self) -> int:
        return self._depth

    @depth.setter
    def depth(self, value: int) -> None:
        if not isinstance(value, int) or value < 0:
            raise ValueError('depth must be a non-negative int')
        self._depth = value

    def _tuple(self, d: Duration) -> tuple[int, int] | None:
        if d.nanoseconds == 0:
            return None
        return divmod(d.nanoseconds, 1_000_000_000)

    def lifespan_tuple(self) -> tuple[int, int] | None:
        return self._tuple(self._lifespan)

    def deadline_tuple(self) -> tuple[int, int] | None:
        return self._tuple(self._deadline)

    def liveliness_lease_duration_tuple(self) -> tuple[int, int] | None:
        return self._tuple(self._liveliness_lease_duration)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, QoSProfile):
            return False
        return all(getattr(self, s) == getattr(other, s) for s in self.__slots__)

    def __repr__(self) -> str:
        return ('QoSProfile(' + ', '.join(f'{s[1:]}={getattr(self, s)!r}' for s in self.__slots__)
                + ')')


def qos_profile_from_depth_or_profile(qos_profile: QoSProfile | int) -> QoSProfile:
    """What create_publisher/create_subscription do with their qos argument."""
    if isinstance(qos_profile, QoSProfile):
        return qos_profile
    if isinstance(qos_profile, int) and not isinstance(qos_profile, bool):
        if qos_profile < 0:
            raise ValueError('history depth must be greater than or equal to zero')
        return QoSProfile(depth=qos_profile)
    raise TypeError(
        'Expected QoSProfile or int, but received {!r}'.format(type(qos_profile)))


qos_profile_system_default = QoSProfile(history=HistoryPolicy.SYSTEM_DEFAULT,
                                        reliability=ReliabilityPolicy.SYSTEM_DEFAULT,
                                        durability=DurabilityPolicy.SYSTEM_DEFAULT)
qos_profile_sensor_data = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5,
                                     reliability=ReliabilityPolicy.BEST_EFFORT,
                                     durability=DurabilityPolicy.VOLATILE)
qos_profile_services_default = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10)
qos_profile_parameters = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000)
qos_profile_parameter_events = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000)
#: rcl's rosout profile (Jazzy): KEEP_LAST 1000, RELIABLE, TRANSIENT_LOCAL, lifespan 10 s.
qos_profile_rosout_default = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                                        durability=DurabilityPolicy.TRANSIENT_LOCAL,
                                        lifespan=Duration(seconds=10))
qos_profile_action_status_default = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                                               durability=DurabilityPolicy.TRANSIENT_LOCAL)
qos_profile_best_available = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                                        reliability=ReliabilityPolicy.BEST_AVAILABLE,
                                        durability=DurabilityPolicy.BEST_AVAILABLE,
                                        liveliness=LivelinessPolicy.BEST_AVAILABLE)
qos_profile_unknown = QoSProfile(history=HistoryPolicy.UNKNOWN,
                                 reliability=ReliabilityPolicy.UNKNOWN,
                                 durability=DurabilityPolicy.UNKNOWN)


class QoSPresetProfiles(IntEnum):
    """Named presets, e.g. `QoSPresetProfiles.SENSOR_DATA.value` or `get_from_short_key('sensor_data')`."""

    UNKNOWN = 0
    DEFAULT = 1
    SYSTEM_DEFAULT = 2
    SENSOR_DATA = 3
    SERVICES_DEFAULT = 4
    PARAMETERS = 5
    PARAMETER_EVENTS = 6
    ACTION_STATUS_DEFAULT = 7
    BEST_AVAILABLE = 8

    @property
    def value(self) -> QoSProfile:  # type: ignore[override]
        return _PRESETS[self.name]

    @classmethod
    def short_keys(cls) -> list[str]:
        return [k.lower() for k in cls.__members__]

    @classmethod
    def get_from_short_key(cls, name: str) -> QoSProfile:
        return _PRESETS[name.upper()]


_PRESETS = {
    'UNKNOWN': qos_profile_unknown,
    'DEFAULT': QoSProfile(depth=10),
    'SYSTEM_DEFAULT': qos_profile_system_default,
    'SENSOR_DATA': qos_profile_sensor_data,
    'SERVICES_DEFAULT': qos_profile_services_default,
    'PARAMETERS': qos_profile_parameters,
    'PARAMETER_EVENTS': qos_profile_parameter_events,
    'ACTION_STATUS_DEFAULT': qos_profile_action_status_default,
    'BEST_AVAILABLE': qos_profile_best_available,
}
