"""Test node in the ros2/examples style: publishes std_msgs/String on `chatter` at a rate.

Parameters: `period` (double, s), `text` (string), `latched` (bool: depth-1 transient local, publish once),
`reliable` (bool), `count` (int, 0 = forever).  Prints READY once its publisher exists.
"""

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String


class Talker(Node):
    def __init__(self) -> None:
        super().__init__('talker')
        self.declare_parameter('period', 0.05)
        self.declare_parameter('text', 'hello')
        self.declare_parameter('latched', False)
        self.declare_parameter('reliable', True)
        self.declare_parameter('count', 0)
        latched = self.get_parameter('latched').value
        qos = QoSProfile(
            depth=1 if latched else 10,
            reliability=ReliabilityPolicy.RELIABLE if self.get_parameter('reliable').value
            else ReliabilityPolicy.BEST_EFFORT,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
        self.pub = self.create_publisher(String, 'chatter', qos)
        self.i = 0
        if latched:
            self.pub.publish(String(data=self.get_parameter('text').value))
        else:
            self.create_timer(self.get_parameter('period').value, self.tick)
        print('READY', self.pub.topic_name, flush=True)

    def tick(self) -> None:
        count = self.get_parameter('count').value
        if count and self.i >= count:
            return
        self.i += 1
        self.pub.publish(String(data=f'{self.get_parameter("text").value} {self.i}'))


def main(args=None) -> None:
    rclpy.init(args=args)
    node = Talker()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        print('CLEAN EXIT', flush=True)


if __name__ == '__main__':
    main()
