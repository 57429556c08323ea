"""Interfaces (action) of `example_interfaces`, built on first use from the runtime's type store (cage_ros_runtime.msgpkg)."""

from cage_ros_runtime.msgpkg import module_hooks

__getattr__, __dir__ = module_hooks('example_interfaces', 'action')
