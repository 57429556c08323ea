"""Implementation details of the runtime's rclpy (named as in rclpy)."""
