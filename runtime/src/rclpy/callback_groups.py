"""rclpy.callback_groups: accepted for compatibility.

The runtime runs every callback in the spinning thread, one at a time, so every group behaves as a
MutuallyExclusiveCallbackGroup; a ReentrantCallbackGroup is accepted (code written for rclpy's
MultiThreadedExecutor runs, serialised).  Callbacks that must overlap should be coroutines that await.
"""

from __future__ import annotations

from typing import Any


class CallbackGroup:
    """The base class of callback groups (rclpy.callback_groups.CallbackGroup)."""

    def __init__(self) -> None:
        self.entities: set = set()

    def add_entity(self, entity: Any) -> None:
        self.entities.add(entity)

    def has_entity(self, entity: Any) -> bool:
        return entity in self.entities

    def can_execute(self, entity: Any) -> bool:
        return True

    def beginning_execution(self, entity: Any) -> bool:
        return True

    def ending_execution(self, entity: Any) -> None:
        pass


class MutuallyExclusiveCallbackGroup(CallbackGroup):
    """Callbacks of the group never run at the same time (always true here)."""


class ReentrantCallbackGroup(CallbackGroup):
    """Callbacks of the group may run in parallel in rclpy's MultiThreadedExecutor (serialised here)."""
