"""Test node: parameters behind the parameter services, a log line on /rosout, a timer on the node clock.

Parameters: `speed` (double; the on-set callback refuses negative values with a reason), `label`
(string), `shield` (bool), `gains` (double array).  Prints READY, `SET <name>=<value>` for every accepted
set (post-set callback) and, every 0.5 s of the node's clock (sim time with use_sim_time:=true), `TICK <ns>`.
"""

import rclpy
from rcl_interfaces.msg import SetParametersResult
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node


class ParamNode(Node):
    def __init__(self) -> None:
        super().__init__('param_node')
        self.declare_parameter('speed', 1.0)
        self.declare_parameter('label', 'cage')
        self.declare_parameter('shield', True)
        self.declare_parameter('gains', [0.5, 0.25])
        self.add_on_set_parameters_callback(self.check)
        self.add_post_set_parameters_callback(self.applied)
        self.create_timer(0.5, self.tick)
        self.get_logger().info('hello rosout')
        print('READY', flush=True)

    def check(self, params: list) -> SetParametersResult:
        for p in params:
            if p.name == 'speed' and p.value < 0:
                return SetParametersResult(successful=False, reason='speed must not be negative')
        return SetParametersResult(successful=True)

    def applied(self, params: list) -> None:
        for p in params:
            print(f'SET {p.name}={p.value}', flush=True)

    def tick(self) -> None:
        print(f'TICK {self.get_clock().now().nanoseconds}', flush=True)


def main() -> None:
    rclpy.init()
    node = ParamNode()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
