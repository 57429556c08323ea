"""Test node in the ros2/examples style (minimal_action_server): `example_interfaces/Fibonacci` on
`fibonacci`.  Rejects negative orders, accepts cancel requests, publishes each partial sequence as
feedback; the execute callback is a coroutine that awaits a timer between steps (parameter `step`, s).
"""

import rclpy
from example_interfaces.action import Fibonacci
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.task import Future


class FibonacciServer(Node):
    def __init__(self) -> None:
        super().__init__('fibonacci_server')
        self.declare_parameter('step', 0.05)
        self._server = ActionServer(self, Fibonacci, 'fibonacci', self.execute,
                                    goal_callback=self.on_goal, cancel_callback=self.on_cancel)
        print('READY', flush=True)

    def on_goal(self, goal: Fibonacci.Goal) -> GoalResponse:
        return GoalResponse.REJECT if goal.order < 0 else GoalResponse.ACCEPT

    def on_cancel(self, goal_handle: object) -> CancelResponse:
        return CancelResponse.ACCEPT

    async def sleep(self, seconds: float) -> None:
        done = Future()
        timer = self.create_timer(seconds, lambda: done.set_result(None))
        await done
        self.destroy_timer(timer)

    async def execute(self, goal_handle) -> Fibonacci.Result:
        sequence = [0, 1]
        feedback = Fibonacci.Feedback()
        for _ in range(1, goal_handle.request.order):
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
                print('CANCELED', flush=True)
                return Fibonacci.Result(sequence=sequence)
            sequence.append(sequence[-1] + sequence[-2])
            feedback.sequence = sequence
            goal_handle.publish_feedback(feedback)
            await self.sleep(self.get_parameter('step').value)
        goal_handle.succeed()
        return Fibonacci.Result(sequence=sequence)


def main() -> None:
    rclpy.init()
    node = FibonacciServer()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
