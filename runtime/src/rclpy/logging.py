"""rclpy.logging: named loggers and severities (rcutils console format)."""

from __future__ import annotations

from rclpy.impl import rcutils_logger as _impl
from rclpy.impl.logging_severity import LoggingSeverity
from rclpy.impl.rcutils_logger import RcutilsLogger

__all__ = ['LoggingSeverity', 'RcutilsLogger', 'get_logger', 'set_logger_level',
           'get_logger_effective_level', 'get_logging_severity_from_string', 'initialize', 'clear_config']


def get_logger(name: str) -> RcutilsLogger:
    if not name:
        raise ValueError('Logger name must not be empty.')
    return RcutilsLogger(name)


def set_logger_level(name: str, level: LoggingSeverity, detailed_error: bool = False) -> None:
    _impl.set_level(name, LoggingSeverity(level))


def get_logger_effective_level(name: str) -> LoggingSeverity:
    return LoggingSeverity(_impl.effective_level(name))


def get_logging_severity_from_string(log_severity: str) -> LoggingSeverity:
    name = log_severity.upper()
    if name == 'WARNING':
        name = 'WARN'
    return LoggingSeverity[name]


def initialize() -> None:
    """Nothing to set up: the console sink needs no initialisation."""


def clear_config() -> None:
    _impl._levels.clear()
