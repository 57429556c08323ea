"""Services across real processes: rmw_cyclonedds' wire (rq/rr topics, request header, client ids)."""

from __future__ import annotations

from typing import Any, Callable

from runtime_testlib import spin_until


def test_service_call_across_processes(spawn: Callable[..., Any], context: Any) -> None:
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from std_srvs.srv import SetBool, Trigger

    server = spawn('service_server.py')
    assert server.read_until('READY', 60), server.output
    node = Node('caller', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    client = node.create_client(SetBool, 'set_flag')
    assert client.wait_for_service(timeout_sec=20)
    futures = [client.call_async(SetBool.Request(data=v)) for v in (True, False, True)]
    assert spin_until(executor, lambda: all(f.done() for f in futures), 20)
    assert [f.result().message for f in futures] == ['was False', 'was True', 'was False']
    assert server.read_until('FLAG True', 5)

    slow = node.create_client(Trigger, 'slow_trigger')
    assert slow.wait_for_service(timeout_sec=20)
    future = slow.call_async(Trigger.Request())
    assert spin_until(executor, future.done, 20)
    assert future.result().success and future.result().message == 'after tick'
    node.destroy_node()


def test_service_in_process_with_wire_header(context: Any) -> None:
    """Client and service in one process still go through DDS; the reply is matched by the header."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from std_srvs.srv import SetBool

    from cage_ros_runtime import reqrep

    node = Node('both', context=context)
    node.create_service(SetBool, '/ns/toggle', lambda req, resp: SetBool.Response(
        success=req.data, message='ok'))
    clients = [node.create_client(SetBool, '/ns/toggle') for _ in range(2)]
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    assert spin_until(executor, lambda: all(c.service_is_ready() for c in clients), 20)
    f1 = clients[0].call_async(SetBool.Request(data=True))
    f2 = clients[1].call_async(SetBool.Request(data=False))
    assert spin_until(executor, lambda: f1.done() and f2.done(), 20)
    assert f1.result().success is True and f2.result().success is False
    assert reqrep.request_topics('/ns/toggle') == ('rq/ns/toggleRequest', 'rr/ns/toggleReply')
    assert reqrep.unwrap(reqrep.wrap(7, 9, b'\x00\x01\x00\x00abcd')) == (7, 9, b'\x00\x01\x00\x00abcd')
    assert reqrep.id_string(bytes(range(16))) == ' 0.1.2.3.4.5.6.7.8.9.a.b.c.d.e.f'
    node.destroy_node()


def test_graph_sees_services_and_clients(context: Any) -> None:
    from rclpy.node import Node
    from std_srvs.srv import Trigger

    node = Node('grapher', context=context)
    node.create_service(Trigger, 'poke', lambda req, resp: resp)
    node.create_client(Trigger, 'poke')
    import time
    deadline = time.monotonic() + 20
    while node.count_services('poke') < 1 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert node.count_services('poke') == 1 and node.count_clients('poke') == 1
    assert ('/poke', ['std_srvs/srv/Trigger']) in node.get_service_names_and_types()
    assert node.wait_for_node('/grapher', 10) and '/grapher' in node.get_fully_qualified_node_names()
    node.destroy_node()


def test_reply_waits_until_the_clients_reader_is_matched(context: Any, ros_env: dict) -> None:
    """rmw_cyclonedds' rule: a reply goes out only once the reply writer has matched a reader with the
    requesting client's `clientid`; until then it is kept (not dropped)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.qos import qos_profile_services_default
    from rclpy.signals import SignalHandlerOptions
    from std_srvs.srv import SetBool

    from cage_ros_runtime import messages, reqrep
    from cage_ros_runtime.dds import RawReader, endpoint_qos

    node = Node('late_reply', context=context)
    srv = node.create_service(SetBool, 'late', lambda req, resp: resp)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    srv.send_response(SetBool.Response(message='kept'), (7, 1, 'the-late-client', True))
    assert len(srv._pending) == 1  # noqa: SLF001 - no reader with that clientid yet

    other = Context()
    rclpy.init(args=[], context=other, domain_id=int(ros_env['ROS_DOMAIN_ID']),
               signal_handler_options=SignalHandlerOptions.NO)
    try:
        domain = other._get_domain()  # noqa: SLF001
        reader = RawReader.create(domain, 'rr/lateReply', 'std_srvs/srv/SetBool_Response', endpoint_qos(
            qos_profile_services_default, 'std_srvs/srv/SetBool', writer=False,
            user_data='clientid=the-late-client;'), 8)
        got: list = []

        def received() -> bool:
            got.extend(reader.take())
            return bool(got)

        assert spin_until(executor, received, 20)
        guid, seq, body = reqrep.unwrap(got[0])
        assert (guid, seq) == (7, 1)
        assert messages.deserialize(body, 'std_srvs/srv/SetBool_Response').message == 'kept'
        assert srv._pending == []  # noqa: SLF001
        reader.close()
    finally:
        other.try_shutdown()
    node.destroy_node()
