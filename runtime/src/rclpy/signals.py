"""rclpy.signals: SIGINT/SIGTERM handling that ends `spin` cleanly.

As in rclpy (Jazzy): the handler shuts down every initialized context and wakes their waits, then calls the
previously installed Python handler, so SIGINT still raises KeyboardInterrupt (from Python's
default_int_handler) while SIGTERM, whose previous handler is SIG_DFL, only shuts down: a `spin()` in
progress then raises ExternalShutdownException.  Node code in the ros2/examples style
(`except (KeyboardInterrupt, ExternalShutdownException): pass`) therefore exits 0 on both.
"""

from __future__ import annotations

import signal
import threading
import weakref
from enum import IntEnum
from typing import Any, Dict

_contexts: 'weakref.WeakSet' = weakref.WeakSet()
_previous: Dict[int, Any] = {}
_installed = None


class SignalHandlerOptions(IntEnum):
    NO = 0
    SIGINT = 1
    SIGTERM = 2
    ALL = 3


def _handler(signum: int, frame: Any) -> None:
    for ctx in list(_contexts):
        ctx._signal_shutdown()  # noqa: SLF001
    previous = _previous.get(signum)
    if callable(previous):
        previous(signum, frame)


def register_context(context: Any) -> None:
    _contexts.add(context)


def install_signal_handlers(options: SignalHandlerOptions = SignalHandlerOptions.ALL) -> None:
    """Install the handlers (main thread only; elsewhere Python forbids it and nothing is done)."""
    global _installed
    if threading.current_thread() is not threading.main_thread() or options == SignalHandlerOptions.NO:
        return
    wanted = []
    if options in (SignalHandlerOptions.SIGINT, SignalHandlerOptions.ALL):
        wanted.append(signal.SIGINT)
    if options in (SignalHandlerOptions.SIGTERM, SignalHandlerOptions.ALL):
        wanted.append(signal.SIGTERM)
    for signum in wanted:
        current = signal.getsignal(signum)
        if current is _handler:
            continue
        _previous[signum] = current
        signal.signal(signum, _handler)
    _installed = options


def get_current_signal_handlers_options() -> SignalHandlerOptions:
    return _installed if _installed is not None else SignalHandlerOptions.NO


def uninstall_signal_handlers() -> None:
    global _installed
    if threading.current_thread() is not threading.main_thread():
        return
    for signum, previous in list(_previous.items()):
        if signal.getsignal(signum) is _handler:
            signal.signal(signum, previous if previous is not None else signal.SIG_DFL)
        del _previous[signum]
    _installed = None
