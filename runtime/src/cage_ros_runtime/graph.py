"""The ROS graph over DDS: `ros_discovery_info` (who runs which nodes) and builtin-topic discovery.

Why: `ros2 node list` on ROS 2 reads `ros_discovery_info` (rmw_dds_common/msg/ParticipantEntitiesInfo:
the participant GID and, per node, the GIDs of its readers and writers), published by every participant with
KEEP_LAST 1, RELIABLE, TRANSIENT_LOCAL.  GIDs are the 16-byte DDS GUIDs.  Topics and their types/QoS come
from DDS discovery itself (the DCPSPublication/DCPSSubscription builtin topics).  Note: the builtin topics
must be read with `BuiltinDataReader`; a plain DataReader on them segfaults cyclonedds 11.0.1.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any, Iterable

from cyclonedds.builtin import (BuiltinDataReader, BuiltinTopicDcpsParticipant,
                                BuiltinTopicDcpsPublication, BuiltinTopicDcpsSubscription)
from cyclonedds.domain import DomainParticipant

from cage_ros_runtime import messages
from cage_ros_runtime.dds import Domain, RawReader, RawWriter
from cage_ros_runtime.typestore import ros_type_name

DISCOVERY_TOPIC = 'ros_discovery_info'
DISCOVERY_TYPE = 'rmw_dds_common/msg/ParticipantEntitiesInfo'


def _discovery_qos(writer: bool) -> Any:
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from cage_ros_runtime.dds import endpoint_qos
    depth = 1 if writer else 100
    profile = QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    return endpoint_qos(profile, DISCOVERY_TYPE, writer=writer)


def _gid(raw: bytes) -> Any:
    gid_cls = messages.message_class('rmw_dds_common/msg/Gid')
    return gid_cls(data=list(raw[:16]))


class GraphPublisher:
    """Publishes this participant's ParticipantEntitiesInfo whenever its nodes or endpoints change."""

    def __init__(self, domain: Domain) -> None:
        self._domain = domain
        self._writer = RawWriter.create(domain, DISCOVERY_TOPIC, DISCOVERY_TYPE, _discovery_qos(True))
        self._lock = threading.Lock()

    def publish(self, nodes: Iterable[Any]) -> None:
        info_cls = messages.message_class(DISCOVERY_TYPE)
        node_cls = messages.message_class('rmw_dds_common/msg/NodeEntitiesInfo')
        entries = []
        for node in nodes:
            entries.append(node_cls(
                node_namespace=node.get_namespace(), node_name=node.get_name(),
                reader_gid_seq=[_gid(g) for g in node._reader_gids()],  # noqa: SLF001
                writer_gid_seq=[_gid(g) for g in node._writer_gids()]))  # noqa: SLF001
        msg = info_cls(gid=_gid(self._domain.gid), node_entities_info_seq=entries)
        with self._lock:
            self._writer.write(messages.serialize(msg))


@dataclass
class Endpoint:
    """One discovered DDS endpoint of a ROS topic (or, with `dds_topic` rq/rr, of a service)."""

    topic: str          # ROS name, e.g. /cage/scan (services: the service name)
    ros_type: str       # pkg/msg/Name (services: pkg/srv/Name, the service type)
    kind: str           # 'publisher' or 'subscription'
    qos: Any            # cyclonedds Qos
    participant: bytes  # participant GUID prefix key
    gid: bytes = b''    # the endpoint's GUID (what ros_discovery_info lists per node)
    dds_topic: str = ''

    @property
    def type_hash(self) -> str:
        from cage_ros_runtime.reqrep import user_data_key, _user_data
        return user_data_key(_user_data(self), 'typehash') or ''


def _service_of(dds_topic: str, dds_type: str) -> tuple[str, str] | None:
    """(`/name`, `pkg/srv/Name`) for a request/reply topic, None for anything else."""
    for prefix, suffix, type_suffix in (('rq/', 'Request', '_Request'), ('rr/', 'Reply', '_Response')):
        if dds_topic.startswith(prefix) and dds_topic.endswith(suffix):
            ros_type = ros_type_name(dds_type)
            if ros_type is None or not ros_type.endswith(type_suffix):
                return None
            return '/' + dds_topic[len(prefix):-len(suffix)].lstrip('/'), ros_type[:-len(type_suffix)]
    return None


class GraphObserver:
    """Reads DDS discovery data (topics, types, QoS) and ros_discovery_info, for tools and nodes.

    Needs its own participant (or the context's) in the domain to observe.
    """

    def __init__(self, participant: DomainParticipant, with_nodes: bool = True) -> None:
        self._pub = BuiltinDataReader(participant, BuiltinTopicDcpsPublication)
        self._sub = BuiltinDataReader(participant, BuiltinTopicDcpsSubscription)
        self._ppant = BuiltinDataReader(participant, BuiltinTopicDcpsParticipant)
        self._nodes_reader = None
        if with_nodes:
            domain_like = _ParticipantDomain(participant)
            self._nodes_reader = RawReader.create(domain_like, DISCOVERY_TOPIC, DISCOVERY_TYPE,  # type: ignore[arg-type]
                                                  _discovery_qos(False), 256)
        self._node_info: dict[bytes, Any] = {}
        self._created = time.monotonic()

    def endpoints(self, services: bool = False) -> list[Endpoint]:
        """Every alive ROS topic endpoint (`rt/` topics with mangled type names) seen so far; with
        `services`, the request/reply endpoints of services instead."""
        self._young_wait()
        out = []
        for reader, kind in ((self._pub, 'publisher'), (self._sub, 'subscription')):
            for sample in reader.read(N=10000):
                if getattr(sample, 'sample_info', None) is not None and \
                        sample.sample_info.instance_state != 16:  # 16 = ALIVE
                    continue
                name = getattr(sample, 'topic_name', '') or ''
                dds_type = getattr(sample, 'type_name', '') or ''
                gid = bytes(sample.key.bytes)
                ppant = bytes(sample.participant_key.bytes)
                if services:
                    found = _service_of(name, dds_type)
                    if found is not None:
                        out.append(Endpoint(found[0], found[1], kind, sample.qos, ppant, gid, name))
                    continue
                ros_type = ros_type_name(dds_type)
                if not name.startswith('rt/') or ros_type is None:
                    continue
                out.append(Endpoint('/' + name[3:].lstrip('/'), ros_type, kind, sample.qos, ppant, gid,
                                    name))
        return out

    def node_of_endpoints(self) -> dict[bytes, tuple[str, str]]:
        """{endpoint GID: (namespace, node name)} from ros_discovery_info."""
        self._take_node_info()
        out: dict[bytes, tuple[str, str]] = {}
        for info in self._node_info.values():
            for n in info.node_entities_info_seq:
                for g in list(n.reader_gid_seq) + list(n.writer_gid_seq):
                    out[bytes(bytearray(g.data))] = (n.node_namespace, n.node_name)
        return out

    def topics(self) -> dict[str, set[str]]:
        """{topic: {types}} over publishers and subscriptions."""
        out: dict[str, set[str]] = {}
        for ep in self.endpoints():
            out.setdefault(ep.topic, set()).add(ep.ros_type)
        return out

    def alive_participants(self) -> set[bytes]:
        out = set()
        for sample in self._ppant.read(N=10000):
            info = getattr(sample, 'sample_info', None)
            if info is not None and info.instance_state != 16:
                continue
            out.add(bytes(sample.key.bytes))
        return out

    def _discovery_writers(self) -> set[bytes]:
        """Participants that publish ros_discovery_info (ROS participants), as discovered so far."""
        out = set()
        for sample in self._pub.read(N=10000):
            info = getattr(sample, 'sample_info', None)
            if info is not None and info.instance_state != 16:
                continue
            if getattr(sample, 'topic_name', '') == DISCOVERY_TOPIC:
                out.add(bytes(sample.participant_key.bytes))
        return out

    def _take_node_info(self) -> None:
        if self._nodes_reader is not None:
            for data in self._nodes_reader.take():
                info = messages.deserialize(data, DISCOVERY_TYPE)
                self._node_info[bytes(bytearray(info.gid.data))] = info

    def _young_wait(self) -> None:
        """A fresh participant has not heard SPDP from its peers yet: give discovery 0.3 s once."""
        young = 0.3 - (time.monotonic() - self._created)
        if young > 0:
            time.sleep(young)

    def settle(self, timeout: float = 1.0) -> None:
        """Wait (bounded) until every discovered ROS participant's ros_discovery_info has arrived.

        Why: a participant is discovered before its (transient local) ros_discovery_info sample is
        delivered, so an immediate query would miss its nodes.  ros2cli without a daemon waits too.
        A fresh observer first gives discovery a moment (SPDP) to find the remote participants.
        """
        self._young_wait()
        deadline = time.monotonic() + timeout
        while True:
            self._take_node_info()
            if self._discovery_writers() <= set(self._node_info) or time.monotonic() >= deadline:
                return
            time.sleep(0.01)

    def nodes(self) -> list[tuple[str, str]]:
        """(namespace, name) of every node announced in ros_discovery_info by an alive participant."""
        if self._nodes_reader is not None:
            self.settle()
        alive = self.alive_participants()
        out = []
        for gid, info in self._node_info.items():
            if gid not in alive:
                continue
            for n in info.node_entities_info_seq:
                out.append((n.node_namespace, n.node_name))
        return sorted(out)

    def wait(self, seconds: float) -> None:
        """Give discovery time to complete (tools without a daemon must wait, as ros2cli does)."""
        time.sleep(seconds)


class _ParticipantDomain:
    """Adapter so RawReader.create can be used with a bare participant (tools' observers)."""

    def __init__(self, participant: DomainParticipant) -> None:
        self.participant = participant

    def topic(self, dds_name: str, ros_type: str) -> Any:
        from cyclonedds.topic import Topic

        from cage_ros_runtime.idl import idl_type
        return Topic(self.participant, dds_name, idl_type(ros_type))
