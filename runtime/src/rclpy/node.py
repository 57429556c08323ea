"""rclpy.node.Node: names, publishers, subscriptions, timers, parameters, logger and clock of a node."""

from __future__ import annotations

import copy
from typing import Any, Callable, Dict, Iterator, List, Optional, Sequence, Tuple, Union

from cage_ros_runtime import arguments as _arguments
from cage_ros_runtime import messages
from cage_ros_runtime.dds import RawReader, RawWriter, dds_topic_name, endpoint_qos
from cage_ros_runtime.names import (apply_remaps, expand_topic_name, normalize_namespace,
                                    validate_node_name)
from rclpy.clock import ROSClock
from rclpy.clock_type import ClockType
from rclpy.context import Context
from rclpy.exceptions import (InvalidParameterTypeException, InvalidParameterValueException,
                              ParameterAlreadyDeclaredException, ParameterImmutableException,
                              ParameterNotDeclaredException, ParameterUninitializedException)
from rclpy.logging import get_logger
from rclpy.impl.rcutils_logger import RcutilsLogger
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile, qos_profile_from_depth_or_profile
from rclpy.subscription import Subscription
from rclpy.timer import Timer
from rclpy.utilities import get_default_context

_NOT_SET = object()


def _set_result(successful: bool, reason: str = '') -> Any:
    from rcl_interfaces.msg import SetParametersResult
    return SetParametersResult(successful=successful, reason=reason)


def _default_descriptor(name: str) -> Any:
    from rcl_interfaces.msg import ParameterDescriptor
    return ParameterDescriptor(name=name)


class Node:
    """A ROS node.  Mirrors rclpy's constructor keywords; unsupported ones are accepted and ignored
    where ignoring them cannot change behaviour (`enable_rosout`, `start_parameter_services`)."""

    PARAM_REL_TOL = 1e-6

    def __init__(self, node_name: str, *, context: Optional[Context] = None,
                 cli_args: Optional[List[str]] = None, namespace: Optional[str] = None,
                 use_global_arguments: bool = True, enable_rosout: bool = True,
                 start_parameter_services: bool = True,
                 parameter_overrides: Optional[List[Parameter]] = None,
                 allow_undeclared_parameters: bool = False,
                 automatically_declare_parameters_from_overrides: bool = False,
                 enable_logger_service: bool = False) -> None:
        self._context = get_default_context() if context is None else context
        if not self._context.ok():
            from rclpy.exceptions import NotInitializedException
            raise NotInitializedException('cannot create node')
        args = self._context.ros_arguments if use_global_arguments else _arguments.RosArguments()
        if cli_args:
            args = args.extend(_arguments.parse(['--ros-args', *cli_args]
                                                if '--ros-args' not in cli_args else cli_args))
        self._ros_args = args
        validate_node_name(node_name)
        self._name = args.node_name or node_name
        validate_node_name(self._name)
        self._namespace = normalize_namespace(args.namespace if args.namespace else namespace)
        self._logger = get_logger(self._logger_name())
        self._clock = ROSClock()
        self._publishers: List[Publisher] = []
        self._subscriptions: List[Subscription] = []
        self._timers: List[Timer] = []
        self._services: List[Any] = []
        self._clients: List[Any] = []
        self._waitables: List[Any] = []
        self._guards: List[Any] = []
        self._generation = 0  # bumped when the set of waitable entities changes
        self._destroyed = False
        self.__executor_weakref: Any = None

        self._parameters: Dict[str, Parameter] = {}
        self._descriptors: Dict[str, Any] = {}
        self._allow_undeclared_parameters = allow_undeclared_parameters
        self._on_set_callbacks: List[Callable[[List[Parameter]], Any]] = []
        self._post_set_callbacks: List[Callable[[List[Parameter]], None]] = []
        self._parameter_overrides: Dict[str, Parameter] = {}
        for name, value in _arguments.parameter_overrides(args, self._name, self._namespace).items():
            try:
                self._parameter_overrides[name] = Parameter(name, value=value)
            except TypeError as exc:
                raise InvalidParameterValueException(name, value, str(exc)) from None
        for p in parameter_overrides or []:
            self._parameter_overrides[p.name] = p

        self._domain = self._context._get_domain()  # noqa: SLF001
        self._context._track_node(self)  # noqa: SLF001
        self._context._graph_batch += 1  # noqa: SLF001 - one ros_discovery_info update at the end
        try:
            self._init_entities(enable_rosout, start_parameter_services,
                                automatically_declare_parameters_from_overrides)
        finally:
            self._context._graph_batch -= 1  # noqa: SLF001
        self._context._graph_changed()  # noqa: SLF001

    def _init_entities(self, enable_rosout: bool, start_parameter_services: bool,
                       automatically_declare_parameters_from_overrides: bool) -> None:
        """The entities every node has, and its declared overrides / use_sim_time."""
        self._parameter_event_publisher: Optional[Publisher] = None
        self._rosout_publisher: Optional[Publisher] = None
        self._rosout_sink: Any = None
        self._parameter_service: Any = None
        self._start_ros_interfaces(enable_rosout and self._ros_args.rosout_enabled,
                                   start_parameter_services)

        if automatically_declare_parameters_from_overrides:
            for name, p in self._parameter_overrides.items():
                if name not in self._parameters:
                    self.declare_parameter(name, p.value)
        if 'use_sim_time' not in self._parameters:
            self.declare_parameter('use_sim_time', False)
        self._clock_sub: Optional[Subscription] = None
        if self.get_parameter('use_sim_time').value:
            self._enable_sim_time()

    def _start_ros_interfaces(self, enable_rosout: bool, start_parameter_services: bool) -> None:
        """What every rclpy node has: /parameter_events, /rosout and the parameter services."""
        from rcl_interfaces.msg import ParameterEvent
        from rclpy.qos import qos_profile_parameter_events
        self._parameter_event_publisher = self.create_publisher(
            ParameterEvent, '/parameter_events', qos_profile_parameter_events)
        if enable_rosout:
            self._enable_rosout()
        if start_parameter_services:
            from rclpy.parameter_service import ParameterService
            self._parameter_service = ParameterService(self)

    def _enable_rosout(self) -> None:
        """Publish this node's log lines (its logger and child loggers) on /rosout, as rcl does."""
        from rcl_interfaces.msg import Log
        from rclpy.impl import rcutils_logger
        from rclpy.qos import qos_profile_rosout_default
        pub = self.create_publisher(Log, '/rosout', qos_profile_rosout_default)
        self._rosout_publisher = pub
        own = self._logger.name

        def sink(name: str, level: int, message: str, caller: Any, now_ns: int) -> None:
            if name != own and not name.startswith(own + '.'):
                return
            if self._destroyed or pub._writer is None:  # noqa: SLF001
                return
            from builtin_interfaces.msg import Time as TimeMsg
            pub.publish(Log(stamp=TimeMsg(sec=now_ns // 1_000_000_000, nanosec=now_ns % 1_000_000_000),
                            level=int(level), name=name, msg=message,
                            file=caller.filename if caller else '',
                            function=caller.function if caller else '',
                            line=caller.lineno if caller else 0))

        self._rosout_sink = sink
        rcutils_logger.add_sink(sink)

    def _publish_parameter_event(self, new: List[Parameter] = (), changed: List[Parameter] = (),
                                 deleted: List[Parameter] = ()) -> None:
        pub = self._parameter_event_publisher
        if pub is None or pub._writer is None:  # noqa: SLF001
            return
        from rclpy.parameter_service import parameter_event
        try:
            pub.publish(parameter_event(self, list(new), list(changed), list(deleted)))
        except Exception as exc:  # noqa: BLE001 - an event that cannot be encoded must not fail the set
            self._logger.debug(f'parameter event not published: {exc}')

    # ------------------------------------------------------------------ identity
    def _logger_name(self) -> str:
        ns = self._namespace.strip('/').replace('/', '.')
        return f'{ns}.{self._name}' if ns else self._name

    def get_name(self) -> str:
        return self._name

    def get_namespace(self) -> str:
        return self._namespace

    def get_fully_qualified_name(self) -> str:
        return ('' if self._namespace == '/' else self._namespace) + '/' + self._name

    @property
    def context(self) -> Context:
        return self._context

    @property
    def default_callback_group(self) -> None:
        return None

    @property
    def executor(self) -> Any:
        return self.__executor_weakref() if self.__executor_weakref else None

    @executor.setter
    def executor(self, new_executor: Any) -> None:
        import weakref
        current = self.executor
        if current is new_executor:
            return
        if current is not None:
            current.remove_node(self)
        if new_executor is None:
            self.__executor_weakref = None
        else:
            new_executor.add_node(self)
            self.__executor_weakref = weakref.ref(new_executor)

    def get_logger(self) -> RcutilsLogger:
        return self._logger

    def get_clock(self) -> ROSClock:
        return self._clock

    @property
    def publishers(self) -> Iterator[Publisher]:
        yield from self._publishers

    @property
    def subscriptions(self) -> Iterator[Subscription]:
        yield from self._subscriptions

    @property
    def timers(self) -> Iterator[Timer]:
        yield from self._timers

    @property
    def clients(self) -> Iterator[Any]:
        yield from self._clients

    @property
    def services(self) -> Iterator[Any]:
        yield from self._services

    @property
    def guards(self) -> Iterator[Any]:
        yield from self._guards

    @property
    def waitables(self) -> Iterator[Any]:
        yield from self._waitables

    def create_guard_condition(self, callback: Callable[[], Any], callback_group: Any = None) -> Any:
        """A guard condition whose `trigger()` runs `callback` in the executor spinning this node."""
        from rclpy.guard_condition import GuardCondition
        guard = GuardCondition(callback, self)
        self._guards.append(guard)
        return guard

    def destroy_guard_condition(self, guard: Any) -> bool:
        if guard in self._guards:
            self._guards.remove(guard)
            guard.destroy()
            return True
        return False

    def add_waitable(self, waitable: Any) -> None:
        self._waitables.append(waitable)
        self._generation += 1
        self._wake_executor()

    def remove_waitable(self, waitable: Any) -> None:
        if waitable in self._waitables:
            self._waitables.remove(waitable)
            self._generation += 1

    def resolve_topic_name(self, topic: str, *, only_expand: bool = False) -> str:
        """Fully qualified and (unless only_expand) remapped topic name, as rcl resolves it."""
        fq = expand_topic_name(topic, self._name, self._namespace)
        if only_expand:
            return fq
        return apply_remaps(fq, self._ros_args.remaps, self._name, self._namespace)

    resolve_service_name = resolve_topic_name

    # ------------------------------------------------------------------ endpoints
    def _check_alive(self) -> None:
        if self._destroyed:
            from rclpy.exceptions import InvalidHandle
            raise InvalidHandle('node was destroyed')

    def create_publisher(self, msg_type: Any, topic: str,
                         qos_profile: Union[QoSProfile, int], *,
                         callback_group: Any = None, event_callbacks: Any = None,
                         qos_overriding_options: Any = None, publisher_class: Any = None) -> Publisher:
        self._check_alive()
        profile = qos_profile_from_depth_or_profile(qos_profile)
        ros_type = messages.type_of(msg_type)
        name = self.resolve_topic_name(topic)
        writer = RawWriter.create(self._domain, dds_topic_name(name, profile.avoid_ros_namespace_conventions),
                                  ros_type, endpoint_qos(profile, ros_type, writer=True))
        pub = Publisher(self, msg_type, name, profile, writer)
        self._publishers.append(pub)
        self._context._graph_changed()  # noqa: SLF001
        return pub

    def create_subscription(self, msg_type: Any, topic: str, callback: Callable[[Any], None],
                            qos_profile: Union[QoSProfile, int], *,
                            callback_group: Any = None, event_callbacks: Any = None,
                            qos_overriding_options: Any = None, raw: bool = False) -> Subscription:
        self._check_alive()
        profile = qos_profile_from_depth_or_profile(qos_profile)
        ros_type = messages.type_of(msg_type)
        name = self.resolve_topic_name(topic)
        wire = self._best_available_for_subscription(profile, name)
        from rclpy.qos import HistoryPolicy
        max_take = 256 if profile.history == HistoryPolicy.KEEP_ALL else max(profile.depth, 1)
        reader = RawReader.create(self._domain, dds_topic_name(name, profile.avoid_ros_namespace_conventions),
                                  ros_type, endpoint_qos(wire, ros_type, writer=False), max_take)
        sub = Subscription(self, msg_type, name, callback, profile, reader, raw=raw)
        self._subscriptions.append(sub)
        self._generation += 1
        self._context._graph_changed()  # noqa: SLF001
        self._wake_executor()
        return sub

    def _best_available_for_subscription(self, profile: QoSProfile, topic: str) -> QoSProfile:
        """Resolve BEST_AVAILABLE policies against the publishers discovered now, as rmw_dds_common's
        qos_profile_get_best_available_for_subscription: reliable / transient local / manual-by-topic
        only if every publisher offers it (with no publisher: the strongest)."""
        from rclpy.qos import DurabilityPolicy, LivelinessPolicy, ReliabilityPolicy
        policies = (profile.reliability == ReliabilityPolicy.BEST_AVAILABLE,
                    profile.durability == DurabilityPolicy.BEST_AVAILABLE,
                    profile.liveliness == LivelinessPolicy.BEST_AVAILABLE)
        if not any(policies):
            return profile
        from cyclonedds.qos import Policy
        offered = [e.qos for e in self._observer().endpoints()
                   if e.kind == 'publisher' and e.topic == topic]

        def every(test: Callable[[Any], bool]) -> bool:
            return all(test(q) for q in offered)

        resolved = copy.copy(profile)
        if policies[0]:
            resolved.reliability = ReliabilityPolicy.RELIABLE if every(
                lambda q: isinstance(q[Policy.Reliability], Policy.Reliability.Reliable)) \
                else ReliabilityPolicy.BEST_EFFORT
        if policies[1]:
            resolved.durability = DurabilityPolicy.TRANSIENT_LOCAL if every(
                lambda q: q[Policy.Durability] == Policy.Durability.TransientLocal) \
                else DurabilityPolicy.VOLATILE
        if policies[2]:
            resolved.liveliness = LivelinessPolicy.MANUAL_BY_TOPIC if offered and every(
                lambda q: isinstance(q[Policy.Liveliness], Policy.Liveliness.ManualByTopic)) \
                else LivelinessPolicy.AUTOMATIC
        return resolved

    def create_timer(self, timer_period_sec: float, callback: Optional[Callable[[], Any]],
                     callback_group: Any = None, clock: Any = None, autostart: bool = True) -> Timer:
        self._check_alive()
        timer = Timer(callback, int(float(timer_period_sec) * 1e9), autostart=autostart,
                      clock=clock if clock is not None else self._clock)
        self._timers.append(timer)
        self._generation += 1
        self._wake_executor()
        return timer

    def create_rate(self, frequency: float, clock: Any = None) -> Any:
        from rclpy.rate import Rate
        return Rate(frequency, context=self._context)

    def create_service(self, srv_type: Any, srv_name: str, callback: Callable[[Any, Any], Any], *,
                       qos_profile: Optional[QoSProfile] = None, callback_group: Any = None) -> Any:
        """A service server; `callback(request, response)` returns the response (may be a coroutine)."""
        from rclpy.qos import qos_profile_services_default
        from rclpy.service import Service
        self._check_alive()
        name = self.resolve_service_name(srv_name)
        srv = Service(self, srv_type, name, callback, qos_profile or qos_profile_services_default)
        self._services.append(srv)
        self._generation += 1
        self._context._graph_changed()  # noqa: SLF001
        self._wake_executor()
        return srv

    def create_client(self, srv_type: Any, srv_name: str, *, qos_profile: Optional[QoSProfile] = None,
                      callback_group: Any = None) -> Any:
        """A service client (`call_async`, `call`, `wait_for_service`, `service_is_ready`)."""
        from rclpy.client import Client
        from rclpy.qos import qos_profile_services_default
        self._check_alive()
        name = self.resolve_service_name(srv_name)
        client = Client(self, srv_type, name, qos_profile or qos_profile_services_default)
        self._clients.append(client)
        self._generation += 1
        self._context._graph_changed()  # noqa: SLF001
        self._wake_executor()
        return client

    def destroy_service(self, service: Any) -> bool:
        if service in self._services:
            self._services.remove(service)
            self._generation += 1
            service._close()  # noqa: SLF001
            self._context._graph_changed()  # noqa: SLF001
            return True
        return False

    def destroy_client(self, client: Any) -> bool:
        if client in self._clients:
            self._clients.remove(client)
            self._generation += 1
            client._close()  # noqa: SLF001
            self._context._graph_changed()  # noqa: SLF001
            return True
        return False

    def _wake_executor(self) -> None:
        executor = self.executor
        if executor is not None:
            executor.wake()

    def destroy_publisher(self, publisher: Publisher) -> bool:
        if publisher in self._publishers:
            self._publishers.remove(publisher)
            publisher._close()  # noqa: SLF001
            self._context._graph_changed()  # noqa: SLF001
            return True
        return False

    def destroy_subscription(self, subscription: Subscription) -> bool:
        if subscription in self._subscriptions:
            self._subscriptions.remove(subscription)
            self._generation += 1
            subscription._close()  # noqa: SLF001
            self._context._graph_changed()  # noqa: SLF001
            return True
        return False

    def destroy_timer(self, timer: Timer) -> bool:
        if timer in self._timers:
            self._timers.remove(timer)
            self._generation += 1
            timer.destroy()
            return True
        return False

    def destroy_rate(self, rate: Any) -> bool:
        rate.destroy()
        return True

    def destroy_node(self) -> None:
        """Destroy every entity of the node; safe to call twice and after shutdown."""
        if self._destroyed:
            return
        executor = self.executor
        if executor is not None:
            try:
                executor.remove_node(self)
            except Exception:  # noqa: BLE001
                pass
        if self._rosout_sink is not None:
            from rclpy.impl import rcutils_logger
            rcutils_logger.remove_sink(self._rosout_sink)
            self._rosout_sink = None
        for pub in list(self._publishers):
            self._publishers.remove(pub)
            pub._close()  # noqa: SLF001
        for sub in list(self._subscriptions):
            self._subscriptions.remove(sub)
            sub._close()  # noqa: SLF001
        for timer in list(self._timers):
            self.destroy_timer(timer)
        for waitable in list(self._waitables):
            try:
                waitable.destroy()
            except Exception:  # noqa: BLE001 - best effort at teardown
                pass
        for srv in list(self._services):
            self.destroy_service(srv)
        for client in list(self._clients):
            self.destroy_client(client)
        self._destroyed = True
        self._generation += 1
        self._context._untrack_node(self)  # noqa: SLF001
        self._context._graph_changed()  # noqa: SLF001

    def _reader_gids(self) -> List[bytes]:
        out = [s.handle.gid for s in self._subscriptions if s._reader is not None]  # noqa: SLF001
        out += [e._reader.gid for e in self._reqrep_entities() if e._reader is not None]  # noqa: SLF001
        return out

    def _reqrep_entities(self) -> List[Any]:
        out = self._services + self._clients
        for waitable in self._waitables:
            for group in waitable._entities().values():  # noqa: SLF001
                out = out + list(group)
        return out

    def _writer_gids(self) -> List[bytes]:
        out = [p.handle.gid for p in self._publishers if p._writer is not None]  # noqa: SLF001
        out += [e._writer.gid for e in self._reqrep_entities() if e._writer is not None]  # noqa: SLF001
        return out

    # ------------------------------------------------------------------ graph queries
    def _observer(self) -> Any:
        """The context's graph observer (created with the participant, so it has been listening)."""
        return self._context._graph_observer()  # noqa: SLF001

    def get_topic_names_and_types(self, no_demangle: bool = False) -> List[Tuple[str, List[str]]]:
        return sorted((t, sorted(types)) for t, types in self._observer().topics().items())

    def get_node_names(self) -> List[str]:
        return [n for _, n in self._observer().nodes()]

    def get_node_names_and_namespaces(self) -> List[Tuple[str, str]]:
        return [(n, ns) for ns, n in self._observer().nodes()]

    def get_fully_qualified_node_names(self) -> List[str]:
        return [(ns.rstrip('/') + '/' + n) for ns, n in self._observer().nodes()]

    def wait_for_node(self, fully_qualified_node_name: str, timeout: float) -> bool:
        """Wait until the node is in the graph (polls discovery); False after `timeout` seconds."""
        import time
        name = fully_qualified_node_name if fully_qualified_node_name.startswith('/') \
            else '/' + fully_qualified_node_name
        deadline = time.monotonic() + timeout
        while name not in self.get_fully_qualified_node_names():
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.05)
        return True

    def get_service_names_and_types(self) -> List[Tuple[str, List[str]]]:
        out: Dict[str, set] = {}
        for e in self._observer().endpoints(services=True):
            out.setdefault(e.topic, set()).add(e.ros_type)
        return sorted((name, sorted(types)) for name, types in out.items())

    def count_services(self, service_name: str) -> int:
        name = self.resolve_service_name(service_name)
        return sum(1 for e in self._observer().endpoints(services=True)
                   if e.topic == name and e.kind == 'subscription' and e.dds_topic.startswith('rq/'))

    def count_clients(self, service_name: str) -> int:
        name = self.resolve_service_name(service_name)
        return sum(1 for e in self._observer().endpoints(services=True)
                   if e.topic == name and e.kind == 'publisher' and e.dds_topic.startswith('rq/'))

    def count_publishers(self, topic_name: str) -> int:
        name = self.resolve_topic_name(topic_name)
        return sum(1 for e in self._observer().endpoints() if e.kind == 'publisher' and e.topic == name)

    def count_subscribers(self, topic_name: str) -> int:
        name = self.resolve_topic_name(topic_name)
        return sum(1 for e in self._observer().endpoints()
                   if e.kind == 'subscription' and e.topic == name)

    # ------------------------------------------------------------------ time
    def _enable_sim_time(self) -> None:
        """Drive the node's ROS clock from /clock, as rclpy's TimeSource does with use_sim_time."""
        if self._clock_sub is not None:
            return
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rclpy.time import Time
        from rosgraph_msgs.msg import Clock as ClockMsg

        def on_clock(msg: Any) -> None:
            self._clock.set_ros_time_override(Time.from_msg(msg.clock, ClockType.ROS_TIME))

        self._clock._set_ros_time_is_active(True)  # noqa: SLF001
        self._clock_sub = self.create_subscription(
            ClockMsg, '/clock', on_clock, QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))

    def _disable_sim_time(self) -> None:
        """Back to system time (use_sim_time set to false)."""
        if self._clock_sub is None:
            return
        self.destroy_subscription(self._clock_sub)
        self._clock_sub = None
        self._clock._set_ros_time_is_active(False)  # noqa: SLF001

    # ------------------------------------------------------------------ parameters
    def declare_parameter(self, name: str, value: Any = None, descriptor: Any = None,
                          ignore_override: bool = False) -> Parameter:
        """Declare `name` typed by its default; a command-line override of another type is refused
        with InvalidParameterTypeException (rclpy behaviour, no int->double promotion)."""
        args: Tuple[Any, ...] = (name, value) if descriptor is None else (name, value, descriptor)
        return self.declare_parameters('', [args], ignore_override)[0]

    def declare_parameters(self, namespace: str, parameters: Sequence[Tuple[Any, ...]],
                           ignore_override: bool = False) -> List[Parameter]:
        declared: List[Parameter] = []
        staged: List[Tuple[Parameter, Any]] = []
        for entry in parameters:
            if isinstance(entry, str):
                entry = (entry,)
            if not isinstance(entry, tuple) or not 1 <= len(entry) <= 3:
                raise TypeError('Invalid parameter tuple; expected (name[, value[, descriptor]])')
            pname = f'{namespace}.{entry[0]}' if namespace else entry[0]
            if not isinstance(pname, str) or not pname:
                from rclpy.exceptions import InvalidParameterException
                raise InvalidParameterException(pname)
            value = entry[1] if len(entry) > 1 else None
            descriptor = entry[2] if len(entry) > 2 else None
            if descriptor is None:
                descriptor = _default_descriptor(pname)
            else:
                descriptor.name = pname
            if pname in self._parameters or any(p.name == pname for p, _ in staged):
                raise ParameterAlreadyDeclaredException(pname)
            if isinstance(value, Parameter.Type):
                declared_type = value
                value = None
            else:
                declared_type = Parameter.Type.from_parameter_value(value)
            if not descriptor.dynamic_typing and declared_type != Parameter.Type.NOT_SET:
                descriptor.type = declared_type.value
            elif descriptor.dynamic_typing:
                descriptor.type = declared_type.value
            if not ignore_override and pname in self._parameter_overrides:
                value = self._parameter_overrides[pname].value
            param = Parameter(pname, value=value)
            self._check_type(param, descriptor)
            staged.append((param, descriptor))
        result = self._run_on_set([p for p, _ in staged])
        if not result.successful:
            raise InvalidParameterValueException(
                ', '.join(p.name for p, _ in staged), [p.value for p, _ in staged], result.reason)
        for param, descriptor in staged:
            self._parameters[param.name] = param
            self._descriptors[param.name] = descriptor
            declared.append(param)
        self._run_post_set([p for p, _ in staged])
        self._publish_parameter_event(new=[p for p, _ in staged])
        return declared

    @staticmethod
    def _check_type(param: Parameter, descriptor: Any) -> None:
        if descriptor.dynamic_typing or descriptor.type == Parameter.Type.NOT_SET.value:
            return
        if param.type_ == Parameter.Type.NOT_SET:
            return  # declared by type only: uninitialized until set
        if param.type_.value != descriptor.type:
            raise InvalidParameterTypeException(param, Parameter.Type(descriptor.type).name)

    def undeclare_parameter(self, name: str) -> None:
        if name not in self._parameters:
            raise ParameterNotDeclaredException(name)
        if self._descriptors[name].read_only:
            raise ParameterImmutableException(name)
        param = self._parameters.pop(name)
        del self._descriptors[name]
        self._publish_parameter_event(deleted=[param])

    def has_parameter(self, name: str) -> bool:
        return name in self._parameters

    def get_parameter(self, name: str) -> Parameter:
        if name in self._parameters:
            param = self._parameters[name]
            if param.type_ == Parameter.Type.NOT_SET and not self._descriptors[name].dynamic_typing \
                    and self._descriptors[name].type != Parameter.Type.NOT_SET.value:
                raise ParameterUninitializedException(name)
            return param
        if self._allow_undeclared_parameters:
            return Parameter(name, Parameter.Type.NOT_SET, None)
        raise ParameterNotDeclaredException(name)

    def get_parameter_or(self, name: str, alternative_value: Optional[Parameter] = None) -> Parameter:
        if alternative_value is None:
            alternative_value = Parameter(name, Parameter.Type.NOT_SET)
        return self._parameters.get(name, alternative_value)

    def get_parameters(self, names: List[str]) -> List[Parameter]:
        return [self.get_parameter(n) for n in names]

    def get_parameters_by_prefix(self, prefix: str) -> Dict[str, Parameter]:
        prefix = prefix + '.' if prefix else ''
        return {k[len(prefix):]: v for k, v in self._parameters.items() if k.startswith(prefix)}

    def get_parameter_types(self, names: List[str]) -> List[Parameter.Type]:
        return [self._parameters[n].type_ if n in self._parameters else Parameter.Type.NOT_SET
                for n in names]

    def describe_parameter(self, name: str) -> Any:
        if name not in self._descriptors:
            raise ParameterNotDeclaredException(name)
        return self._descriptors[name]

    def describe_parameters(self, names: List[str]) -> List[Any]:
        return [self.describe_parameter(n) for n in names]

    def set_parameters(self, parameter_list: List[Parameter]) -> List[Any]:
        """Set each parameter on its own; returns one SetParametersResult per parameter."""
        return [self._set_parameters_atomically([p]) for p in parameter_list]

    def set_parameters_atomically(self, parameter_list: List[Parameter]) -> Any:
        return self._set_parameters_atomically(parameter_list)

    def _set_parameters_atomically(self, parameter_list: List[Parameter]) -> Any:
        for p in parameter_list:
            if p.name not in self._parameters:
                if not self._allow_undeclared_parameters:
                    raise ParameterNotDeclaredException(p.name)
                continue
            descriptor = self._descriptors[p.name]
            if descriptor.read_only:
                return _set_result(False, f"Trying to set a read-only parameter: {p.name}.")
            try:
                self._check_type(p, descriptor)
            except InvalidParameterTypeException as exc:
                return _set_result(False, str(exc))
        result = self._run_on_set(parameter_list)
        if not result.successful:
            return result
        new, changed, deleted = [], [], []
        for p in parameter_list:
            if p.name not in self._parameters:
                new.append(p)
            elif p.type_ == Parameter.Type.NOT_SET and self._allow_undeclared_parameters:
                deleted.append(p)
            else:
                changed.append(p)
        for p in parameter_list:
            if p.type_ == Parameter.Type.NOT_SET and p.name in self._parameters \
                    and self._allow_undeclared_parameters:
                del self._parameters[p.name]
                self._descriptors.pop(p.name, None)
                continue
            self._parameters[p.name] = p
            if p.name not in self._descriptors:
                self._descriptors[p.name] = _default_descriptor(p.name)
        self._run_post_set(parameter_list)
        self._publish_parameter_event(new, changed, deleted)
        for p in parameter_list:
            if p.name == 'use_sim_time':
                if p.value:
                    self._enable_sim_time()
                else:
                    self._disable_sim_time()
        return result

    def _run_on_set(self, params: List[Parameter]) -> Any:
        for cb in self._on_set_callbacks:
            result = cb(params)
            if not result.successful:
                return result
        return _set_result(True)

    def _run_post_set(self, params: List[Parameter]) -> None:
        for cb in self._post_set_callbacks:
            cb(params)

    def add_on_set_parameters_callback(self, callback: Callable[[List[Parameter]], Any]) -> Callable:
        self._on_set_callbacks.insert(0, callback)
        return callback

    def remove_on_set_parameters_callback(self, callback: Callable) -> None:
        self._on_set_callbacks.remove(callback)

    def add_post_set_parameters_callback(self, callback: Callable[[List[Parameter]], None]) -> Callable:
        self._post_set_callbacks.append(callback)
        return callback

    def remove_post_set_parameters_callback(self, callback: Callable) -> None:
        self._post_set_callbacks.remove(callback)

    # ------------------------------------------------------------------ misc
    def __enter__(self) -> 'Node':
        return self

    def __exit__(self, *exc: Any) -> None:
        self.destroy_node()

    def __repr__(self) -> str:
        return f'<Node {self.get_fully_qualified_name()}>'
