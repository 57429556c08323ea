"""Test node in the ros2/examples style: a `std_srvs/SetBool` service `set_flag` (plain callback) and a
`std_srvs/Trigger` service `slow_trigger` whose callback is a coroutine awaiting a timer-completed future.
Prints READY once both exist and `FLAG <value>` on each change.
"""

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.task import Future
from std_srvs.srv import SetBool, Trigger


class FlagServer(Node):
    def __init__(self) -> None:
        super().__init__('flag_server')
        self.flag = False
        self.create_service(SetBool, 'set_flag', self.on_set)
        self.create_service(Trigger, 'slow_trigger', self.on_trigger)
        print('READY', flush=True)

    def on_set(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        previous, self.flag = self.flag, request.data
        print('FLAG', self.flag, flush=True)
        response.success = True
        response.message = f'was {previous}'
        return response

    async def on_trigger(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        done = Future()
        timer = self.create_timer(0.05, lambda: done.set_result('tick'))
        value = await done
        self.destroy_timer(timer)
        response.success = True
        response.message = f'after {value}'
        return response


def main() -> None:
    rclpy.init()
    node = FlagServer()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
