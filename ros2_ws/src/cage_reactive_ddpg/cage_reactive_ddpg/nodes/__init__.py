"""ROS 2 node adapter of the reactive layer (policy_node)."""
