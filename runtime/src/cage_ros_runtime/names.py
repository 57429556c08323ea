"""ROS name rules: node/namespace validation, topic name expansion and remapping (as rcl does them)."""

from __future__ import annotations

import re

_NODE_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_]*\Z')
_TOKEN = re.compile(r'[A-Za-z_][A-Za-z0-9_]*\Z')


def validate_node_name(name: str) -> None:
    from rclpy.exceptions import InvalidNodeNameException
    if not name:
        raise InvalidNodeNameException(name, 'node name must not be empty', 0)
    if not _NODE_NAME.match(name):
        bad = next((i for i, c in enumerate(name) if not (c.isalnum() or c == '_')), 0)
        raise InvalidNodeNameException(
            name, 'node name must not contain characters other than alphanumerics or '
                  "'_', and must not start with a number", bad)


def normalize_namespace(namespace: str | None) -> str:
    """'' / None -> '/', 'ns' -> '/ns', '/a/b/' -> '/a/b'; validates the tokens."""
    from rclpy.exceptions import InvalidNamespaceException
    ns = namespace or '/'
    if not ns.startswith('/'):
        ns = '/' + ns
    if len(ns) > 1:
        ns = ns.rstrip('/')
    for token in ns.split('/')[1:]:
        if ns != '/' and not _TOKEN.match(token):
            raise InvalidNamespaceException(ns, 'namespace tokens must be alphanumerics or _, '
                                                'not starting with a number', max(ns.find(token), 0))
    return ns


def expand_topic_name(name: str, node_name: str, namespace: str) -> str:
    """Fully qualify `name` for a node: `~` is the node's private namespace, relative names get the
    node's namespace, `{node}` and `{ns}`/`{namespace}` are substituted (rcl_expand_topic_name)."""
    from rclpy.exceptions import InvalidTopicNameException
    if not name:
        raise InvalidTopicNameException(name, 'topic name must not be empty', 0)
    ns = namespace.rstrip('/') if namespace != '/' else ''
    if name.startswith('~'):
        name = f'{ns}/{node_name}' + name[1:]
    name = name.replace('{node}', node_name).replace('{ns}', ns or '/').replace(
        '{namespace}', ns or '/')
    if not name.startswith('/'):
        name = f'{ns}/{name}'
    name = re.sub('/+', '/', name)
    if len(name) > 1 and name.endswith('/'):
        raise InvalidTopicNameException(name, 'topic name must not end with a forward slash',
                                        len(name) - 1)
    for token in name.split('/')[1:]:
        if not token or not re.match(r'[A-Za-z_~{][A-Za-z0-9_]*\Z', token):
            raise InvalidTopicNameException(
                name, 'topic name tokens must be alphanumerics or _, not starting with a number',
                max(name.find(token), 0))
    return name


def apply_remaps(fq_name: str, rules: list[tuple[str | None, str, str]], node_name: str,
                 namespace: str) -> str:
    """First matching remap rule wins; rules' both sides are expanded relative to the node."""
    for rule_node, src, dst in rules:
        if rule_node is not None and rule_node != node_name:
            continue
        if src.startswith('__'):
            continue
        try:
            if expand_topic_name(src, node_name, namespace) == fq_name:
                return expand_topic_name(dst, node_name, namespace)
        except Exception:  # noqa: BLE001 - a malformed rule never matches
            continue
    return fq_name
