"""ROS 2 node adapters of cage_sim (rclpy in, messages out); the cores stay ROS-free."""
