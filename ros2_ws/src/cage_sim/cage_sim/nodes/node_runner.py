"""``main()`` for every node of the suite, in the ros2/examples style.

The node is created before the ``try`` (so ``finally`` never touches an unbound name); a constructor
that refuses its parameters (a parameter of the wrong type, a bad scenario, a mismatched weights
file) ends the
process with a one-line fatal log and exit status 2 instead of a traceback.
"""
from __future__ import annotations

import sys
from typing import Callable

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node


def run_node(factory: Callable[[], Node], args=None) -> None:
    rclpy.init(args=args)
    try:
        node = factory()
    except (ValueError, OSError, ParameterException) as err:
        rclpy.logging.get_logger(getattr(factory, "__name__", "node")).fatal(f"cannot start: {err}")
        rclpy.try_shutdown()
        sys.exit(2)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
