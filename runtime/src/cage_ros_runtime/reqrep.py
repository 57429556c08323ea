"""Request/reply over DDS as rmw_cyclonedds_cpp does it (its rmw_init_cs / rmw_send_request / rmw_send_response).

- Service `/a/b` = request topic `rq/a/bRequest` (type `pkg::srv::dds_::Name_Request_`) and reply topic
  `rr/a/bReply` (`..._Response_`).  A client writes requests and reads replies; a service the reverse.
- Each sample carries `cdds_request_header_t` in the CDR stream right after the encapsulation header:
  uint64 `guid` (the client's id for its request writer) and int64 `seq`; the message follows.  As the
  header is 16 bytes, the message's alignment is unchanged, so it is the plain message CDR spliced in.
- USER_DATA of both endpoints of one client (service) is `clientid=<id>;` (`serviceid=<id>;`) then the
  type hash; the id is the participant GUID prefix plus a big-endian counter, printed as rmw does.
- A service replies only once it has matched the reader of the client that sent the request (the
  `clientid` of the request's writer equals that of a reader matched by the reply writer); a reply that
  cannot be sent yet is kept and retried, a client that is gone is skipped (rmw: GONE).
- Replies carry the request's header; a client keeps those with its own `guid`.
"""

from __future__ import annotations

import itertools
import struct
import threading
from typing import Any

from cage_ros_runtime.dds import Domain

_HEADER = 16
_counters: dict[int, itertools.count] = {}
_lock = threading.Lock()


def request_topics(service_name: str) -> tuple[str, str]:
    """`/a/b` -> (`rq/a/bRequest`, `rr/a/bReply`) (rmw's make_fqtopic with the service prefixes)."""
    return f'rq{service_name}Request', f'rr{service_name}Reply'


def unique_id(domain: Domain) -> bytes:
    """16-byte client/service id: participant GUID prefix (12 bytes) + big-endian per-participant counter."""
    with _lock:
        counter = _counters.setdefault(id(domain), itertools.count(1))
        n = next(counter)
    return domain.gid[:12] + struct.pack('>I', n)


def id_string(csid: bytes) -> str:
    """rmw_cyclonedds' csid_to_string: hex bytes joined by '.', the first padded to width 2."""
    return f'{csid[0]:2x}' + ''.join(f'.{b:x}' for b in csid[1:])


def user_data_key(user_data: bytes | None, key: str) -> str | None:
    """Value of `key=` in a `k=v;k=v;` USER_DATA string (None when absent)."""
    if not user_data:
        return None
    for part in bytes(user_data).decode('utf-8', 'replace').split(';'):
        if part.startswith(key + '='):
            return part[len(key) + 1:]
    return None


def wrap(guid: int, seq: int, cdr: bytes) -> bytes:
    """Insert the request header after the encapsulation header of `cdr` (its byte order)."""
    order = '<' if cdr[1] == 1 else '>'
    return cdr[:4] + struct.pack(order + 'Qq', guid, seq) + cdr[4:]


def unwrap(data: bytes) -> tuple[int, int, bytes]:
    """(guid, seq, message CDR with its encapsulation header) of a request or reply sample."""
    if len(data) < 4 + _HEADER:
        raise ValueError(f'request/reply sample too short ({len(data)} bytes)')
    order = '<' if data[1] == 1 else '>'
    guid, seq = struct.unpack_from(order + 'Qq', data, 4)
    return guid, seq, bytes(data[:4]) + bytes(data[4 + _HEADER:])


def matched_reader_ids(writer: Any) -> set[str]:
    """`clientid`s in the USER_DATA of every reader a (reply) writer has matched."""
    out = set()
    try:
        handles = writer.get_matched_subscriptions()
    except Exception:  # noqa: BLE001 - entity going away
        return out
    for h in handles:
        try:
            ep = writer.get_matched_subscription_data(h)
        except Exception:  # noqa: BLE001
            continue
        value = user_data_key(_user_data(ep), 'clientid') if ep is not None else None
        if value is not None:
            out.add(value)
    return out


def writer_client_id(reader: Any, publication_handle: int) -> tuple[bool, str | None]:
    """(request writer still matched, its clientid) for a request that arrived on `reader`."""
    try:
        ep = reader.get_matched_publication_data(publication_handle)
    except Exception:  # noqa: BLE001 - unknown handle: the writer is gone
        return False, None
    if ep is None:
        return False, None
    return True, user_data_key(_user_data(ep), 'clientid')


def _user_data(endpoint: Any) -> bytes | None:
    from cyclonedds.qos import Policy
    qos = getattr(endpoint, 'qos', None)
    if qos is None:
        return None
    try:
        policy = qos[Policy.Userdata]
    except (KeyError, TypeError):
        return None
    return getattr(policy, 'data', None)
