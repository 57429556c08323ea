"""cage-ros-runtime: the machinery behind this distribution's `rclpy`, message packages and `ros2` tool.

Modules: typestore (interfaces), messages (rclpy-style classes + CDR codec), msgpkg (lazy `<pkg>.msg`
modules), idl (DDS topic types), dds (participant, writers, readers, QoS), names and arguments (ROS naming and
command line), graph (ros_discovery_info and discovery), yaml_format and cli (the `ros2` command).
"""

__version__ = '0.1.0'
