"""The Cyclone DDS layer: one participant per rclpy context, raw-byte writers and readers, QoS as rmw maps it.

Why raw bytes: messages are encoded once by the runtime's codec (XCDR1, byte-identical to rmw_cyclonedds_cpp)
and handed to Cyclone with `ddspy_write`; received samples come back from `ddspy_take` as CDR bytes.  The
binding's own Python serializer is never used, so what goes on the wire is exactly what the tests compare
against rosbags.  Entities are created as rmw_cyclonedds_cpp creates them:

- topic `rt/<name>`, type `<pkg>::msg::dds_::<Name>_` (see :mod:`cage_ros_runtime.idl`);
- QoS from :func:`endpoint_qos` (writer autodispose off, durability service for transient local, XCDR1);
- USER_DATA `typehash=RIHS01_<hex>;` on every endpoint and `enclave=/;` on the participant (Jazzy).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING

from cyclonedds._clayer import ddspy_take, ddspy_write
from cyclonedds.core import GuardCondition, InstanceState, ReadCondition, SampleState, ViewState
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from cage_ros_runtime.idl import idl_type
from cage_ros_runtime.typestore import type_hash

if TYPE_CHECKING:
    from rclpy.qos import QoSProfile

#: Topic prefix rmw uses for ROS topics.
ROS_TOPIC_PREFIX = 'rt'
#: Read-condition / take mask that selects every sample.
ANY_STATE = SampleState.Any | ViewState.Any | InstanceState.Any


def delete_entity(entity: object) -> None:
    """Delete a Cyclone entity now (the binding otherwise deletes it when the Python object is collected)."""
    ref = getattr(entity, '_ref', None)
    if ref is None:
        return
    registry = type(entity)._entities  # the binding's ref -> entity map, consulted by __del__
    if ref in registry:
        del registry[ref]
        entity._delete(ref)  # noqa: SLF001


def dds_topic_name(ros_topic: str, avoid_ros_namespace_conventions: bool = False) -> str:
    """`/cage/scan` -> `rt/cage/scan` (rmw's make_fqtopic)."""
    return ros_topic if avoid_ros_namespace_conventions else ROS_TOPIC_PREFIX + ros_topic


def _dds_duration(seconds_nanoseconds: tuple[int, int] | None) -> int | None:
    if seconds_nanoseconds is None:
        return None
    sec, nsec = seconds_nanoseconds
    return sec * 1_000_000_000 + nsec


def endpoint_qos(profile: 'QoSProfile', ros_type: str, *, writer: bool, user_data: str = '') -> Qos:
    """Translate an rclpy QoSProfile into the Cyclone QoS rmw_cyclonedds_cpp would create.

    Mirrors rmw_cyclonedds' `create_readwrite_qos`: KEEP_LAST depth (system default -> 1), RELIABLE with
    infinite blocking or BEST_EFFORT, VOLATILE or TRANSIENT_LOCAL with a matching durability service,
    optional lifespan/deadline, AUTOMATIC liveliness, writer autodispose off; plus XCDR1 as the only data
    representation (what rmw_cyclonedds writes) and the Jazzy type hash in USER_DATA, after `user_data`
    (`clientid=...;` / `serviceid=...;` for service endpoints, as rmw_cyclonedds' rmw_init_cs).
    `BEST_AVAILABLE` is resolved by the caller against the discovered publishers (rclpy does it in rcl).
    """
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, LivelinessPolicy, ReliabilityPolicy

    policies: list = [Policy.DataRepresentation(use_cdrv0_representation=True),
                      Policy.Userdata(data=f'{user_data}typehash={type_hash(ros_type)};'.encode())]
    if profile.history == HistoryPolicy.KEEP_ALL:
        policies.append(Policy.History.KeepAll)
        hist_kind = Policy.History.KeepAll
    else:
        depth = profile.depth if profile.depth > 0 else 1
        policies.append(Policy.History.KeepLast(depth))
        hist_kind = Policy.History.KeepLast(depth)

    reliability = profile.reliability
    if reliability == ReliabilityPolicy.BEST_AVAILABLE:
        # A reader that accepts everything; a writer that satisfies every reader.
        reliability = ReliabilityPolicy.RELIABLE if writer else ReliabilityPolicy.BEST_EFFORT
    if reliability == ReliabilityPolicy.BEST_EFFORT:
        policies.append(Policy.Reliability.BestEffort)
    else:
        policies.append(Policy.Reliability.Reliable(max_blocking_time=duration(infinite=True)))

    durability = profile.durability
    if durability == DurabilityPolicy.BEST_AVAILABLE:
        durability = DurabilityPolicy.TRANSIENT_LOCAL if writer else DurabilityPolicy.VOLATILE
    if durability == DurabilityPolicy.TRANSIENT_LOCAL:
        policies.append(Policy.Durability.TransientLocal)
        policies.append(Policy.DurabilityService(
            cleanup_delay=0, history=hist_kind, max_samples=-1, max_instances=-1,
            max_samples_per_instance=-1))
    else:
        policies.append(Policy.Durability.Volatile)

    lifespan = _dds_duration(profile.lifespan_tuple())
    if lifespan:
        policies.append(Policy.Lifespan(lifespan))
    deadline = _dds_duration(profile.deadline_tuple())
    if deadline:
        policies.append(Policy.Deadline(deadline))
    lease = _dds_duration(profile.liveliness_lease_duration_tuple()) or duration(infinite=True)
    if profile.liveliness == LivelinessPolicy.MANUAL_BY_TOPIC:
        policies.append(Policy.Liveliness.ManualByTopic(lease))
    else:
        policies.append(Policy.Liveliness.Automatic(lease))
    if writer:
        policies.append(Policy.WriterDataLifecycle(autodispose=False))
    return Qos(*policies)


_domains: dict[int, list] = {}  # domain id -> [cyclonedds Domain or None, users]
_domains_lock = threading.Lock()


def _acquire_domain(domain_id: int) -> object:
    """Create the Cyclone domain with the ROS discovery configuration once per process and domain id
    (rmw_cyclonedds does the same with dds_create_domain); later contexts share it."""
    from cage_ros_runtime.discovery import domain_config
    with _domains_lock:
        entry = _domains.get(domain_id)
        if entry is None:
            config = domain_config()
            dds_domain = None
            if config is not None:
                from cyclonedds.domain import Domain as CycloneDomain
                try:
                    dds_domain = CycloneDomain(domain_id, config)
                except Exception as exc:  # noqa: BLE001 - e.g. the domain already exists in this process
                    raise RuntimeError(f'cannot configure DDS domain {domain_id} for discovery: {exc}') \
                        from None
            entry = _domains[domain_id] = [dds_domain, 0]
        entry[1] += 1
        return entry[0]


def _release_domain(domain_id: int) -> None:
    with _domains_lock:
        entry = _domains.get(domain_id)
        if entry is None:
            return
        entry[1] -= 1
        if entry[1] <= 0:
            del _domains[domain_id]
            if entry[0] is not None:
                delete_entity(entry[0])


class Domain:
    """The DDS side of one rclpy context: the participant, topic cache and a guard condition.

    Created lazily on the first node, as rmw_cyclonedds creates its participant on the first node.
    """

    def __init__(self, domain_id: int) -> None:
        self.domain_id = domain_id
        self._dds_domain = _acquire_domain(domain_id)
        self.participant = DomainParticipant(domain_id, qos=Qos(Policy.Userdata(data=b'enclave=/;')))
        self.gid = self.participant.guid.bytes
        self._topics: dict[tuple[str, str], Topic] = {}
        self._lock = threading.Lock()
        #: Triggered on shutdown (and by executors' wake-ups) so blocked waits return at once.
        self.guard = GuardCondition(self.participant)

    def topic(self, dds_name: str, ros_type: str) -> Topic:
        key = (dds_name, ros_type)
        with self._lock:
            topic = self._topics.get(key)
            if topic is None:
                request_header = dds_name.startswith(('rq/', 'rr/'))
                topic = Topic(self.participant, dds_name, idl_type(ros_type, request_header))
                self._topics[key] = topic
            return topic

    def close(self) -> None:
        """Delete the participant and everything under it (writers send their last acks first)."""
        self._topics.clear()
        delete_entity(self.participant)
        _release_domain(self.domain_id)


@dataclass
class RawWriter:
    """A DataWriter that takes CDR bytes."""

    writer: DataWriter
    ros_type: str

    @classmethod
    def create(cls, domain: 'Domain', dds_name: str, ros_type: str, qos: Qos) -> 'RawWriter':
        return cls(DataWriter(domain.participant, domain.topic(dds_name, ros_type), qos), ros_type)

    @property
    def gid(self) -> bytes:
        return self.writer.guid.bytes

    def write(self, data: bytes) -> None:
        pad = -len(data) % 4
        if pad:  # rmw pads the serialized payload to a multiple of 4 bytes
            data = data + b'\0' * pad
        ret = ddspy_write(self.writer._ref, data)  # noqa: SLF001
        if ret < 0:
            raise RuntimeError(f'DDS write failed ({ret}) on {self.writer.topic.name}')

    def matched_count(self) -> int:
        return self.writer.get_publication_matched_status().current_count

    def close(self) -> None:
        delete_entity(self.writer)


@dataclass
class RawReader:
    """A DataReader that yields CDR bytes, with a read condition for wait sets."""

    reader: DataReader
    condition: ReadCondition
    ros_type: str
    max_take: int

    @classmethod
    def create(cls, domain: Domain, dds_name: str, ros_type: str, qos: Qos, max_take: int) -> 'RawReader':
        reader = DataReader(domain.participant, domain.topic(dds_name, ros_type), qos)
        return cls(reader, ReadCondition(reader, ANY_STATE), ros_type, max(1, min(max_take, 256)))

    @property
    def gid(self) -> bytes:
        return self.reader.guid.bytes

    def take(self) -> list[bytes]:
        """Every valid sample available now (at most `max_take`), oldest first; never blocks."""
        return [data for data, _ in self.take_with_info()]

    def take_with_info(self) -> list[tuple[bytes, object]]:
        """Like :meth:`take`, with each sample's SampleInfo (publication handle, timestamps)."""
        ret = ddspy_take(self.reader._ref, ANY_STATE, self.max_take)  # noqa: SLF001
        if isinstance(ret, int):
            if ret < 0:
                raise RuntimeError(f'DDS take failed ({ret})')
            return []
        return [(data, info) for data, info in ret if info.valid_data]

    def matched_count(self) -> int:
        return self.reader.get_subscription_matched_status().current_count

    def close(self) -> None:
        delete_entity(self.condition)
        delete_entity(self.reader)
