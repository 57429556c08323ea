"""ROS 2 node adapter of the global planner (rrt_node)."""
