"""What ActionServer and ActionClient share: entity names, QoS and goal ids (rcl_action's conventions)."""

from __future__ import annotations

import uuid
from typing import Any

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_services_default

#: rcl_action_qos_profile_status_default: latched, one sample per writer.
STATUS_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
FEEDBACK_QOS = QoSProfile(depth=10)
SERVICE_QOS = qos_profile_services_default


def entity_names(action_name: str) -> dict[str, str]:
    """rcl_action's names under the (resolved) action name."""
    base = f'{action_name}/_action/'
    return {k: base + k for k in ('send_goal', 'cancel_goal', 'get_result', 'feedback', 'status')}


def new_goal_id() -> Any:
    from unique_identifier_msgs.msg import UUID
    return UUID(uuid=list(uuid.uuid4().bytes))


def goal_key(goal_id: Any) -> bytes:
    return bytes(bytearray(int(b) & 0xFF for b in goal_id.uuid))


def zero_time(stamp: Any) -> bool:
    return stamp.sec == 0 and stamp.nanosec == 0
