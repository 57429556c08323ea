"""Actions of `cage_planner_msgs`, built on first use from the runtime's type store (cage_ros_runtime.msgpkg)."""

from cage_ros_runtime.msgpkg import module_hooks

__getattr__, __dir__ = module_hooks('cage_planner_msgs', 'action')
