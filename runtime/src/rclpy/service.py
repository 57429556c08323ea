"""rclpy.service: a service server = request reader + reply writer (see cage_ros_runtime.reqrep)."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any, Callable, List, Tuple

from cage_ros_runtime import messages, reqrep
from cage_ros_runtime.dds import RawReader, RawWriter, endpoint_qos
from rclpy.exceptions import InvalidHandle
from rclpy.qos import QoSProfile

if TYPE_CHECKING:
    from rclpy.node import Node

#: How long a reply waits for the client's reply reader to be matched before it is dropped.
REPLY_MATCH_TIMEOUT_S = 10.0


class Service:
    """Created with `Node.create_service(srv_type, srv_name, callback)`; callback(request, response)."""

    def __init__(self, node: 'Node', srv_type: Any, srv_name: str, callback: Callable[[Any, Any], Any],
                 qos_profile: QoSProfile) -> None:
        self.srv_type = srv_type
        self.srv_name = srv_name
        self.callback = callback
        self.qos_profile = qos_profile
        self._node = node
        ros_type = srv_type._type
        rq, rr = reqrep.request_topics(srv_name)
        csid = reqrep.unique_id(node._domain)  # noqa: SLF001
        user_data = f'serviceid={reqrep.id_string(csid)};'
        self._reader: RawReader | None = RawReader.create(
            node._domain, rq, f'{ros_type}_Request',  # noqa: SLF001
            endpoint_qos(qos_profile, ros_type, writer=False, user_data=user_data), 64)
        self._writer: RawWriter | None = RawWriter.create(
            node._domain, rr, f'{ros_type}_Response',  # noqa: SLF001
            endpoint_qos(qos_profile, ros_type, writer=True, user_data=user_data))
        #: replies waiting for the client's reader: (deadline, clientid, guid, seq, cdr)
        self._pending: List[Tuple[float, str, int, int, bytes]] = []
        #: caches: request writer handle -> (present, clientid); clientids of matched reply readers
        self._writer_ids: dict = {}
        self._matched_readers: set = set()

    @property
    def service_name(self) -> str:
        return self.srv_name

    @property
    def handle(self) -> RawReader:
        if self._reader is None:
            raise InvalidHandle('service was destroyed')
        return self._reader

    def _take(self) -> list:
        """[(request message, (guid, seq, clientid or None, writer present))] available now."""
        reader = self._reader
        if reader is None:
            return []
        out = []
        for data, info in reader.take_with_info():
            try:
                guid, seq, body = reqrep.unwrap(data)
                request = messages.deserialize(body, f'{self.srv_type._type}_Request')
            except Exception as exc:  # noqa: BLE001 - a malformed request must not stop the node
                self._node.get_logger().warning(f'{self.srv_name}: dropped a malformed request ({exc})')
                continue
            handle = info.publication_handle
            known = self._writer_ids.get(handle)
            if known is None:  # asking Cyclone for the writer's QoS costs ~0.5 ms: once per writer
                known = reqrep.writer_client_id(reader.reader, handle)
                if known[0]:
                    if len(self._writer_ids) > 1024:
                        self._writer_ids.clear()
                    self._writer_ids[handle] = known
            present, clientid = known
            out.append((request, (guid, seq, clientid, present)))
        return out

    def send_response(self, response: Any, header: Tuple[int, int, Any, bool]) -> None:
        """Send `response` for the request `header`; deferred until the client's reader is matched."""
        if self._writer is None:
            return
        guid, seq, clientid, present = header
        if not isinstance(response, self.srv_type.Response):
            raise TypeError(f'{self.srv_name}: the callback returned {type(response).__name__}, '
                            f'expected {self.srv_type.Response.__name__}')
        cdr = reqrep.wrap(guid, seq, messages.serialize(response))
        if not present:
            return  # the client is gone (rmw: GONE)
        if clientid is not None and clientid not in self._matched_readers:
            self._matched_readers = reqrep.matched_reader_ids(self._writer.writer)
        if clientid is None or clientid in self._matched_readers:
            self._writer.write(cdr)
        else:
            self._pending.append((time.monotonic() + REPLY_MATCH_TIMEOUT_S, clientid, guid, seq, cdr))

    def _flush_pending(self) -> bool:
        """Send deferred replies whose client reader is now matched; True while some are left."""
        if not self._pending or self._writer is None:
            return False
        matched = self._matched_readers = reqrep.matched_reader_ids(self._writer.writer)
        now = time.monotonic()
        left = []
        for item in self._pending:
            deadline, clientid, _guid, _seq, cdr = item
            if clientid in matched:
                self._writer.write(cdr)
            elif now < deadline:
                left.append(item)
            else:
                self._node.get_logger().warning(
                    f'{self.srv_name}: dropped a reply, the client\'s reader never matched')
        self._pending = left
        return bool(left)

    def destroy(self) -> bool:
        return self._node.destroy_service(self)

    def _close(self) -> None:
        if self._reader is not None:
            self._reader.close()
            self._reader = None
        if self._writer is not None:
            self._writer.close()
            self._writer = None

    def __enter__(self) -> 'Service':
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy()
