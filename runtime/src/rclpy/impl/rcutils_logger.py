"""rcutils-style console logging for nodes (`[INFO] [1700000000.123456789] [node]: message`).

Why not the `logging` module: ROS users read and grep the rcutils console format; node code passes
rclpy-only keywords (`throttle_duration_sec`, `once`, `skip_first`); and levels are per logger name with
dotted-hierarchy inheritance, as in rcutils.  Honours RCUTILS_CONSOLE_OUTPUT_FORMAT (the {severity},
{time}, {name}, {message}, {function_name}, {file_name}, {line_number} fields) and
RCUTILS_LOGGING_USE_STDOUT (default: stderr).
"""

from __future__ import annotations

import inspect
import os
import sys
import threading
import time
from typing import Any

from rclpy.impl.logging_severity import LoggingSeverity

_DEFAULT_FORMAT = '[{severity}] [{time}] [{name}]: {message}'
_levels: dict[str, int] = {}
_default_level = int(LoggingSeverity.INFO)
_lock = threading.Lock()
_once_seen: set[tuple[str, str, int]] = set()
_throttle_last: dict[tuple[str, str, int], float] = {}
_skip_first_seen: set[tuple[str, str, int]] = set()
#: Extra destinations of every emitted line (nodes' /rosout publishers): sink(name, level, msg, caller).
_sinks: list = []
_in_sink = threading.local()


def add_sink(sink: Any) -> None:
    with _lock:
        _sinks.append(sink)


def remove_sink(sink: Any) -> None:
    with _lock:
        if sink in _sinks:
            _sinks.remove(sink)


def set_default_level(level: int) -> None:
    global _default_level
    _default_level = int(level)


def set_level(name: str, level: int) -> None:
    with _lock:
        _levels[name] = int(level)


def effective_level(name: str) -> int:
    while name:
        level = _levels.get(name)
        if level is not None and level != LoggingSeverity.UNSET:
            return level
        name = name.rpartition('.')[0]
    return _default_level


def _severity_name(level: int) -> str:
    try:
        return LoggingSeverity(level).name
    except ValueError:
        return str(level)


def emit(name: str, level: int, message: str, caller: inspect.FrameInfo | None) -> None:
    now = time.time_ns()
    fmt = os.environ.get('RCUTILS_CONSOLE_OUTPUT_FORMAT') or _DEFAULT_FORMAT
    text = fmt.format_map({
        'severity': _severity_name(level),
        'time': f'{now // 1_000_000_000}.{now % 1_000_000_000:09d}',
        'name': name,
        'message': message,
        'function_name': caller.function if caller else '',
        'file_name': caller.filename if caller else '',
        'line_number': caller.lineno if caller else 0,
        'time_as_nanoseconds': now,
    })
    stream = sys.stdout if os.environ.get('RCUTILS_LOGGING_USE_STDOUT') == '1' else sys.stderr
    try:
        stream.write(text + '\n')
        stream.flush()
    except (ValueError, OSError):  # stream closed at interpreter exit
        pass
    if _sinks and not getattr(_in_sink, 'active', False):
        _in_sink.active = True  # a sink that logs must not recurse
        try:
            for sink in list(_sinks):
                try:
                    sink(name, level, message, caller, now)
                except Exception:  # noqa: BLE001 - logging never raises into node code
                    pass
        finally:
            _in_sink.active = False


class RcutilsLogger:
    """A named logger; `get_child()` builds `parent.child` names like rclpy."""

    def __init__(self, name: str = '') -> None:
        self.name = name

    def get_child(self, name: str) -> 'RcutilsLogger':
        if not name:
            raise ValueError('Child logger name must not be empty.')
        return RcutilsLogger(f'{self.name}.{name}' if self.name else name)

    def set_level(self, level: int) -> None:
        set_level(self.name, LoggingSeverity(level))

    def get_effective_level(self) -> LoggingSeverity:
        return LoggingSeverity(effective_level(self.name))

    def is_enabled_for(self, severity: int) -> bool:
        return int(severity) >= effective_level(self.name)

    def log(self, message: Any, severity: int, **kwargs: Any) -> bool:
        """Log `message`; returns whether it was emitted (rclpy's contract).

        Supported filters: `once`, `throttle_duration_sec` (+ `throttle_time_source_type`, ignored:
        the steady clock is used), `skip_first`.  The call site identifies the statement for filters.
        """
        severity = int(severity)
        if not self.is_enabled_for(severity):
            return False
        unknown = set(kwargs) - {'once', 'throttle_duration_sec', 'throttle_time_source_type',
                                 'skip_first', 'name'}
        if unknown:
            raise TypeError(f'unsupported logging keyword(s): {", ".join(sorted(unknown))}')
        frame = inspect.currentframe()
        caller_frame = frame.f_back.f_back if frame and frame.f_back else None  # the node code's frame
        site = (self.name, caller_frame.f_code.co_filename if caller_frame else '',
                caller_frame.f_lineno if caller_frame else 0)
        with _lock:
            if kwargs.get('once'):
                if site in _once_seen:
                    return False
                _once_seen.add(site)
            if kwargs.get('skip_first') and site not in _skip_first_seen:
                _skip_first_seen.add(site)
                return False
            period = kwargs.get('throttle_duration_sec')
            if period:
                now = time.monotonic()
                last = _throttle_last.get(site)
                if last is not None and now - last < float(period):
                    return False
                _throttle_last[site] = now
        caller = inspect.getframeinfo(caller_frame, context=0) if caller_frame else None
        emit(kwargs.get('name') or self.name, severity, str(message), caller)
        return True

    def debug(self, message: Any, **kwargs: Any) -> bool:
        return self.log(message, LoggingSeverity.DEBUG, **kwargs)

    def info(self, message: Any, **kwargs: Any) -> bool:
        return self.log(message, LoggingSeverity.INFO, **kwargs)

    def warning(self, message: Any, **kwargs: Any) -> bool:
        return self.log(message, LoggingSeverity.WARN, **kwargs)

    warn = warning

    def error(self, message: Any, **kwargs: Any) -> bool:
        return self.log(message, LoggingSeverity.ERROR, **kwargs)

    def fatal(self, message: Any, **kwargs: Any) -> bool:
        return self.log(message, LoggingSeverity.FATAL, **kwargs)
