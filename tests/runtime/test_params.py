"""Parameters and remapping from the command line and params files (rclpy semantics)."""

from __future__ import annotations

import textwrap

import pytest

from runtime_testlib import spin_until

pytestmark = pytest.mark.timeout(30)


@pytest.fixture
def make_context(ros_env):
    """Contexts initialized from given command lines (args=...), shut down at teardown."""
    import rclpy
    from rclpy.context import Context
    from rclpy.signals import SignalHandlerOptions
    made = []

    def _make(*argv: str):
        ctx = Context()
        rclpy.init(args=['prog', *argv], context=ctx, domain_id=int(ros_env['ROS_DOMAIN_ID']),
                   signal_handler_options=SignalHandlerOptions.NO)
        made.append(ctx)
        return ctx
    yield _make
    for ctx in made:
        ctx.try_shutdown()


def test_defaults_types_and_overrides(make_context) -> None:
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    ctx = make_context('--ros-args', '-p', 'speed:=2.5', '-p', 'n:=7', '-p', 'name:=cage',
                       '-p', 'on:=true', '-p', 'gains:=[1.0, 2.0]', '-p', 'other:node_only:=1')
    node = Node('planner', context=ctx)
    assert node.declare_parameter('speed', 1.0).value == 2.5
    assert node.declare_parameter('n', 1).value == 7
    assert node.declare_parameter('name', 'x').value == 'cage'
    assert node.declare_parameter('on', False).value is True
    assert node.declare_parameter('gains', [0.0]).value == [1.0, 2.0]
    assert node.declare_parameter('untouched', 0.25).value == 0.25
    assert node.declare_parameter('node_only', 5).value == 5  # rule for another node
    assert node.get_parameter('speed').type_ == Parameter.Type.DOUBLE
    assert node.has_parameter('n') and not node.has_parameter('nope')
    assert node.get_parameter('use_sim_time').value is False
    params = node.declare_parameters('limits', [('max', 3.0), ('min', -3.0)])
    assert [p.name for p in params] == ['limits.max', 'limits.min']
    assert node.get_parameters_by_prefix('limits') == {'max': params[0], 'min': params[1]}


def test_wrong_type_is_refused(make_context) -> None:
    from rclpy.exceptions import (InvalidParameterTypeException, ParameterAlreadyDeclaredException,
                                  ParameterNotDeclaredException)
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    ctx = make_context('--ros-args', '-p', 'speed:=fast', '-p', 'ratio:=1')
    node = Node('planner', context=ctx)
    with pytest.raises(InvalidParameterTypeException, match="expecting type 'DOUBLE'"):
        node.declare_parameter('speed', 1.0)
    # rclpy does not promote an integer override to a double parameter
    with pytest.raises(InvalidParameterTypeException):
        node.declare_parameter('ratio', 0.5)
    node.declare_parameter('gain', 1.0)
    with pytest.raises(ParameterAlreadyDeclaredException):
        node.declare_parameter('gain', 2.0)
    result = node.set_parameters([Parameter('gain', value='high')])[0]
    assert not result.successful and node.get_parameter('gain').value == 1.0
    assert node.set_parameters([Parameter('gain', value=3.0)])[0].successful
    assert node.get_parameter('gain').value == 3.0
    with pytest.raises(ParameterNotDeclaredException):
        node.get_parameter('undeclared')


def test_params_file_wildcards_namespaces_and_order(make_context, tmp_path) -> None:
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    f = tmp_path / 'params.yaml'
    f.write_text(textwrap.dedent('''\
        /**:
          ros__parameters:
            common: 1
            speed: 0.5
        /cage/planner:
          ros__parameters:
            speed: 1.5
            nested:
              depth: 4
        other_node:
          ros__parameters:
            speed: 9.0
        cage:
          '*':
            ros__parameters:
              star: "yes"
        '''))
    ctx = make_context('--ros-args', '--params-file', str(f), '-p', 'common:=2')
    node = Node('planner', namespace='/cage', context=ctx,
                parameter_overrides=[Parameter('ctor', value='c')])
    assert node.declare_parameter('speed', 0.0).value == 1.5
    assert node.declare_parameter('common', 0).value == 2  # the later -p wins
    assert node.declare_parameter('nested.depth', 0).value == 4
    assert node.declare_parameter('star', 'no').value == 'yes'
    assert node.declare_parameter('ctor', '').value == 'c'
    root = Node('planner', context=ctx)  # /planner: only the wildcard applies
    assert root.declare_parameter('speed', 0.0).value == 0.5


def test_remaps_names_and_private_topics(make_context) -> None:
    from rclpy.node import Node
    from std_msgs.msg import String
    ctx = make_context('--ros-args', '-r', 'scan:=/sim/scan', '-r', '__ns:=/cage',
                       '-r', 'talker:out:=/special')
    node = Node('talker', context=ctx)
    assert node.get_namespace() == '/cage' and node.get_fully_qualified_name() == '/cage/talker'
    assert node.create_subscription(String, 'scan', lambda m: None, 1).topic_name == '/sim/scan'
    assert node.create_publisher(String, 'plain', 1).topic_name == '/cage/plain'
    assert node.create_publisher(String, '/abs', 1).topic_name == '/abs'
    assert node.create_publisher(String, '~/status', 1).topic_name == '/cage/talker/status'
    assert node.create_publisher(String, 'out', 1).topic_name == '/special'
    renamed = Node('talker', context=make_context('--ros-args', '-r', '__node:=renamed'))
    assert renamed.get_name() == 'renamed'
    assert renamed.get_logger().name == 'renamed'


def test_command_line_reaches_a_node_process(context, spawn, tmp_path) -> None:
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from std_msgs.msg import String
    f = tmp_path / 'p.yaml'
    f.write_text('talker:\n  ros__parameters:\n    text: from-file\n    period: 0.02\n')
    spawn('talker.py', '--ros-args', '--params-file', str(f), '-r', 'chatter:=/remapped')
    node = Node('check', context=context)
    got: list[str] = []
    node.create_subscription(String, '/remapped', lambda m: got.append(m.data), 10)
    ex = SingleThreadedExecutor(context=context)
    ex.add_node(node)
    assert spin_until(ex, lambda: len(got) >= 2, 15.0)
    assert got[0].startswith('from-file ')


def test_refused_override_type_fails_the_process(spawn) -> None:
    p = spawn('talker.py', '--ros-args', '-p', 'period:=slow')
    assert p.finish(20) != 0
    assert 'InvalidParameterTypeException' in p.output


def test_bad_parameter_values_are_refused_at_parse_naming_them(tmp_path) -> None:
    import pytest

    from cage_ros_runtime.arguments import RosArgumentError, parse
    with pytest.raises(RosArgumentError, match=r"'-p gains:=\[1, a\]': a list mixing types"):
        parse(['--ros-args', '-p', 'gains:=[1, a]'])
    f = tmp_path / 'p.yaml'
    f.write_text('/**:\n  ros__parameters:\n    route: [{x: 1}]\n')
    with pytest.raises(RosArgumentError, match="parameter 'route'"):
        parse(['--ros-args', '--params-file', str(f)])
    f.write_text('talker:\n  period: 0.1\n')
    with pytest.raises(RosArgumentError, match="'talker/period' is not a node mapping"):
        parse(['--ros-args', '--params-file', str(f)])
