"""Interface files (`.msg`, `.srv`, `.action`) expanded into message types the way rosidl expands them.

Why by hand: rosbags parses `.msg` text but knows nothing of services and actions, and rosidl's expansion
is what decides the DDS type names (`pkg::srv::dds_::Name_Request_`) and the RIHS01 hashes Jazzy puts in
USER_DATA.  rosidl turns

- `pkg/srv/Name` into `Name_Request`, `Name_Response`, `Name_Event` (`service_msgs/ServiceEventInfo info`,
  `Name_Request[<=1] request`, `Name_Response[<=1] response`) and the service description `Name`
  (`request_message`, `response_message`, `event_message`), whose hash is the service's type hash;
- `pkg/action/Name` into `Name_Goal`, `Name_Result`, `Name_Feedback`, the services `Name_SendGoal`
  (`unique_identifier_msgs/UUID goal_id`, `Name_Goal goal` -> `bool accepted`, `builtin_interfaces/Time
  stamp`) and `Name_GetResult` (`goal_id` -> `int8 status`, `Name_Result result`), `Name_FeedbackMessage`
  (`goal_id`, `Name_Feedback feedback`) and the action description `Name`.

Default values written in the files (`float64 w 1.0`) are kept here, since rosbags drops them.
"""

from __future__ import annotations

import re
from typing import Any

import yaml
from rosbags.typesys import get_types_from_msg
from rosbags.typesys.base import Nodetype

EMPTY_MEMBER = 'structure_needs_at_least_one_member'
_SEPARATOR = re.compile(r'^\s*---\s*$', re.MULTILINE)
_UUID = 'unique_identifier_msgs/msg/UUID'
_TIME = 'builtin_interfaces/msg/Time'
_EVENT_INFO = 'service_msgs/msg/ServiceEventInfo'

#: Defaults of Jazzy's standard messages that rosbags' store does not carry.
JAZZY_DEFAULTS: dict[str, dict[str, Any]] = {
    'geometry_msgs/msg/Quaternion': {'x': 0.0, 'y': 0.0, 'z': 0.0, 'w': 1.0},
}

Fielddefs = dict[str, tuple[list, list]]


def _name(kind: int, arg: Any) -> tuple:
    return (kind, arg)


def _ref(ros_type: str) -> tuple:
    return (Nodetype.NAME, ros_type)


def _parse_section(text: str, pkg: str, name: str) -> tuple[Fielddefs, dict[str, Any]]:
    """One `.msg`-style section as the type `name` (e.g. `pkg/srv/X_Request`), with its defaults."""
    parsed = get_types_from_msg(text, f'{pkg}/msg/__section__')
    consts, fields = parsed.pop(f'{pkg}/msg/__section__')
    if parsed:  # get_types_from_msg only ever returns the one type
        raise ValueError(f'unexpected nested definitions: {sorted(parsed)}')
    if not fields:
        fields = [(EMPTY_MEMBER, (Nodetype.BASE, ('uint8', 0)))]
    return {name: (consts, fields)}, {name: d} if (d := _defaults(text)) else {}


def _defaults(text: str) -> dict[str, Any]:
    """`type name value` lines -> {name: value} (constants `TYPE NAME=VALUE` are not defaults)."""
    out: dict[str, Any] = {}
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith('#'):
            continue
        parts = line.split(None, 2)
        if len(parts) < 3 or '=' in parts[1] or parts[2].startswith('#') or parts[2].startswith('='):
            continue
        value_text = parts[2]
        if not value_text.startswith(('"', "'")):
            value_text = value_text.split('#', 1)[0].strip()
        if not value_text:
            continue
        try:
            value = yaml.safe_load(value_text)
        except yaml.YAMLError:
            value = value_text
        base = parts[0].split('[', 1)[0]
        if base.startswith('float') and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        elif base.startswith('float') and isinstance(value, list):
            value = [float(v) for v in value]
        out[parts[1]] = value
    return out


def _service(pkg: str, kind: str, stem: str, request: Fielddefs, response: Fielddefs) -> Fielddefs:
    req, resp = f'{pkg}/{kind}/{stem}_Request', f'{pkg}/{kind}/{stem}_Response'
    event = f'{pkg}/{kind}/{stem}_Event'
    out = dict(request)
    out.update(response)
    out[event] = ([], [('info', _ref(_EVENT_INFO)),
                       ('request', (Nodetype.SEQUENCE, (_ref(req), 1))),
                       ('response', (Nodetype.SEQUENCE, (_ref(resp), 1)))])
    out[f'{pkg}/{kind}/{stem}'] = ([], [('request_message', _ref(req)), ('response_message', _ref(resp)),
                                        ('event_message', _ref(event))])
    return out


def expand(pkg: str, kind: str, stem: str, text: str) -> tuple[Fielddefs, dict[str, dict[str, Any]]]:
    """Every type rosidl generates for one interface file, and the field defaults it declares."""
    sections = _SEPARATOR.split(text)
    expected = {'msg': 1, 'srv': 2, 'action': 3}[kind]
    if len(sections) != expected:
        raise ValueError(f'a .{kind} file has {expected} section(s) separated by ---, found {len(sections)}')
    types: Fielddefs = {}
    defaults: dict[str, dict[str, Any]] = {}

    def section(body: str, name: str) -> None:
        t, d = _parse_section(body, pkg, name)
        types.update(t)
        defaults.update(d)

    base = f'{pkg}/{kind}/{stem}'
    if kind == 'msg':
        section(sections[0], base)
        return types, defaults
    if kind == 'srv':
        section(sections[0], f'{base}_Request')
        section(sections[1], f'{base}_Response')
        req = {k: v for k, v in types.items() if k.endswith('_Request')}
        resp = {k: v for k, v in types.items() if k.endswith('_Response')}
        return _service(pkg, kind, stem, req, resp), defaults
    goal, result, feedback = f'{base}_Goal', f'{base}_Result', f'{base}_Feedback'
    section(sections[0], goal)
    section(sections[1], result)
    section(sections[2], feedback)
    send_goal = _service(pkg, kind, f'{stem}_SendGoal',
                         {f'{base}_SendGoal_Request': ([], [('goal_id', _ref(_UUID)), ('goal', _ref(goal))])},
                         {f'{base}_SendGoal_Response': ([], [('accepted', (Nodetype.BASE, ('bool', 0))),
                                                             ('stamp', _ref(_TIME))])})
    get_result = _service(pkg, kind, f'{stem}_GetResult',
                          {f'{base}_GetResult_Request': ([], [('goal_id', _ref(_UUID))])},
                          {f'{base}_GetResult_Response': ([], [('status', (Nodetype.BASE, ('int8', 0))),
                                                               ('result', _ref(result))])})
    types.update(send_goal)
    types.update(get_result)
    types[f'{base}_FeedbackMessage'] = ([], [('goal_id', _ref(_UUID)), ('feedback', _ref(feedback))])
    types[base] = ([], [('goal', _ref(goal)), ('result', _ref(result)), ('feedback', _ref(feedback)),
                        ('send_goal_service', _ref(f'{base}_SendGoal')),
                        ('get_result_service', _ref(f'{base}_GetResult')),
                        ('feedback_message', _ref(f'{base}_FeedbackMessage'))])
    return types, defaults


def _uint8(desc: tuple) -> tuple:
    kind, arg = desc
    if kind == Nodetype.BASE:
        return (kind, ('uint8', arg[1])) if arg[0] == 'char' else desc
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        sub, n = arg
        return (kind, (_uint8(sub), n))
    return desc


def chars_as_uint8(store: Any) -> None:
    """Rewrite msg `char` as `uint8` in every type (rosidl's mapping; it enters the RIHS01 hash)."""
    for name, (consts, fields) in list(store.fielddefs.items()):
        if 'char' not in repr(fields):
            continue
        store.fielddefs[name] = (consts, [(fname, _uint8(desc)) for fname, desc in fields])
    store.cache.clear()
