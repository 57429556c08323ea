"""rclpy.client: a service client = request writer + reply reader (see cage_ros_runtime.reqrep)."""

from __future__ import annotations

import itertools
import threading
import time
from typing import TYPE_CHECKING, Any, Dict, Optional

from cage_ros_runtime import messages, reqrep
from cage_ros_runtime.dds import RawReader, RawWriter, endpoint_qos
from rclpy.exceptions import InvalidHandle
from rclpy.qos import QoSProfile
from rclpy.task import Future

if TYPE_CHECKING:
    from rclpy.node import Node

#: Sequence numbers are process-wide, as rmw_cyclonedds' static counter.
_sequence = itertools.count(1)
_sequence_lock = threading.Lock()


class Client:
    """Created with `Node.create_client(srv_type, srv_name)`."""

    def __init__(self, node: 'Node', srv_type: Any, srv_name: str, qos_profile: QoSProfile) -> None:
        self.srv_type = srv_type
        self.srv_name = srv_name
        self.qos_profile = qos_profile
        self._node = node
        ros_type = srv_type._type
        rq, rr = reqrep.request_topics(srv_name)
        csid = reqrep.unique_id(node._domain)  # noqa: SLF001
        user_data = f'clientid={reqrep.id_string(csid)};'
        self._writer: RawWriter | None = RawWriter.create(
            node._domain, rq, f'{ros_type}_Request',  # noqa: SLF001
            endpoint_qos(qos_profile, ros_type, writer=True, user_data=user_data))
        self._reader: RawReader | None = RawReader.create(
            node._domain, rr, f'{ros_type}_Response',  # noqa: SLF001
            endpoint_qos(qos_profile, ros_type, writer=False, user_data=user_data), 64)
        #: the id replies carry back (rmw: the request writer's instance handle)
        self._guid = self._writer.writer.get_instance_handle() & 0xFFFFFFFFFFFFFFFF
        self._pending: Dict[int, Future] = {}
        self._lock = threading.Lock()

    @property
    def service_name(self) -> str:
        return self.srv_name

    @property
    def handle(self) -> RawReader:
        if self._reader is None:
            raise InvalidHandle('client was destroyed')
        return self._reader

    def call_async(self, request: Any) -> Future:
        """Send `request`; the Future completes with the response when a spinning executor takes it."""
        if not isinstance(request, self.srv_type.Request):
            raise TypeError(f'Expected {self.srv_type.Request}, got {type(request)}')
        writer = self._writer
        if writer is None:
            raise InvalidHandle('client was destroyed')
        with _sequence_lock:
            seq = next(_sequence)
        future = Future()
        with self._lock:
            self._pending[seq] = future
        writer.write(reqrep.wrap(self._guid, seq, messages.serialize(request)))
        return future

    def call(self, request: Any, timeout_sec: Optional[float] = None) -> Any:
        """Blocking call: needs an executor spinning the node in another thread (as in rclpy)."""
        future = self.call_async(request)
        if not future._wait(timeout_sec):  # noqa: SLF001
            self.remove_pending_request(future)
            return None
        return future.result()

    def remove_pending_request(self, future: Future) -> None:
        with self._lock:
            for seq, f in list(self._pending.items()):
                if f is future:
                    del self._pending[seq]

    def _take(self) -> list:
        """[(future, response)] for replies to this client's pending requests."""
        reader = self._reader
        if reader is None:
            return []
        out = []
        for data in reader.take():
            try:
                guid, seq, body = reqrep.unwrap(data)
            except ValueError:
                continue
            if guid != self._guid:
                continue  # another client's reply on the shared topic
            with self._lock:
                future = self._pending.pop(seq, None)
            if future is None or future.done():
                continue
            try:
                out.append((future, messages.deserialize(body, f'{self.srv_type._type}_Response')))
            except Exception as exc:  # noqa: BLE001
                future.set_exception(exc)
        return out

    def service_is_ready(self) -> bool:
        """True once a service's request reader and reply writer are both matched."""
        if self._writer is None or self._reader is None:
            return False
        return self._writer.matched_count() > 0 and self._reader.matched_count() > 0

    def wait_for_service(self, timeout_sec: Optional[float] = None) -> bool:
        """Wait (without spinning) until the service is ready; False at the timeout."""
        deadline = None if timeout_sec is None else time.monotonic() + timeout_sec
        while self._node.context.ok():
            if self.service_is_ready():
                return True
            if deadline is not None and time.monotonic() >= deadline:
                return False
            time.sleep(0.01)
        return False

    def destroy(self) -> bool:
        return self._node.destroy_client(self)

    def _close(self) -> None:
        if self._writer is not None:
            self._writer.close()
            self._writer = None
        if self._reader is not None:
            self._reader.close()
            self._reader = None

    def __enter__(self) -> 'Client':
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy()
