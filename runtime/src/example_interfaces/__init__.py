"""Interface package `example_interfaces` served by cage-ros-runtime (see cage_ros_runtime.msgpkg); a real ROS 2 install wins."""
