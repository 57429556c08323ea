"""rclpy.parameter_service: the six parameter services rclpy creates for every node, and /parameter_events.

Services (under the node's private namespace, `qos_profile_parameters`): `~/list_parameters`,
`~/get_parameters`, `~/set_parameters`, `~/set_parameters_atomically`, `~/describe_parameters`,
`~/get_parameter_types`.  They call the node's own parameter API, so `add_on_set_parameters_callback`
callbacks see remote sets and a rejection travels back with its reason.  Every declare/set/undeclare is
published on `/parameter_events` (rcl_interfaces/ParameterEvent) by the node.
"""

from __future__ import annotations

from typing import Any, List

from rcl_interfaces.msg import ListParametersResult, ParameterDescriptor, ParameterEvent, SetParametersResult
from rcl_interfaces.srv import (DescribeParameters, GetParameters, GetParameterTypes, ListParameters,
                                SetParameters, SetParametersAtomically)

from rclpy.exceptions import ParameterNotDeclaredException, ParameterUninitializedException
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_parameters

_NOT_DECLARED = 'One or more parameters were not declared before setting'


class ParameterService:
    """The parameter services of `node` (created by Node unless start_parameter_services=False)."""

    def __init__(self, node: Any) -> None:
        self._node = node
        prefix = node.get_fully_qualified_name()
        self._services = [
            node.create_service(DescribeParameters, f'{prefix}/describe_parameters', self._describe,
                                qos_profile=qos_profile_parameters),
            node.create_service(GetParameters, f'{prefix}/get_parameters', self._get,
                                qos_profile=qos_profile_parameters),
            node.create_service(GetParameterTypes, f'{prefix}/get_parameter_types', self._get_types,
                                qos_profile=qos_profile_parameters),
            node.create_service(ListParameters, f'{prefix}/list_parameters', self._list,
                                qos_profile=qos_profile_parameters),
            node.create_service(SetParameters, f'{prefix}/set_parameters', self._set,
                                qos_profile=qos_profile_parameters),
            node.create_service(SetParametersAtomically, f'{prefix}/set_parameters_atomically',
                                self._set_atomically, qos_profile=qos_profile_parameters),
        ]

    def _describe(self, request: Any, response: Any) -> Any:
        for name in request.names:
            try:
                response.descriptors.append(self._node.describe_parameter(name))
            except ParameterNotDeclaredException:
                response.descriptors.append(ParameterDescriptor(name=name))
        return response

    def _get(self, request: Any, response: Any) -> Any:
        for name in request.names:
            try:
                param = self._node.get_parameter(name)
            except (ParameterNotDeclaredException, ParameterUninitializedException):
                param = Parameter(name, Parameter.Type.NOT_SET)
            response.values.append(param.get_parameter_value())
        return response

    def _get_types(self, request: Any, response: Any) -> Any:
        response.types = [t.value for t in self._node.get_parameter_types(list(request.names))]
        return response

    def _list(self, request: Any, response: Any) -> Any:
        response.result = list_parameters(self._node._parameters.keys(), list(request.prefixes),  # noqa: SLF001
                                          int(request.depth))
        return response

    def _set(self, request: Any, response: Any) -> Any:
        for msg in request.parameters:
            try:
                result = self._node.set_parameters([Parameter.from_parameter_msg(msg)])[0]
            except ParameterNotDeclaredException:
                result = SetParametersResult(successful=False, reason=_NOT_DECLARED)
            except Exception as exc:  # noqa: BLE001 - a bad value is a failed set, never a dead node
                result = SetParametersResult(successful=False, reason=str(exc))
            response.results.append(result)
        return response

    def _set_atomically(self, request: Any, response: Any) -> Any:
        try:
            response.result = self._node.set_parameters_atomically(
                [Parameter.from_parameter_msg(m) for m in request.parameters])
        except ParameterNotDeclaredException:
            response.result = SetParametersResult(successful=False, reason=_NOT_DECLARED)
        except Exception as exc:  # noqa: BLE001
            response.result = SetParametersResult(successful=False, reason=str(exc))
        return response

    def destroy(self) -> None:
        for srv in self._services:
            self._node.destroy_service(srv)


def list_parameters(names: Any, prefixes: List[str], depth: int) -> Any:
    """rclpy's list_parameters: names under the prefixes (all if none) within `depth` dots; their prefixes."""
    result = ListParametersResult()
    recursive = depth == ListParameters.Request.DEPTH_RECURSIVE
    for name in sorted(names):
        if prefixes:
            matched = [p for p in prefixes if name == p or name.startswith(p + '.')]
            if not matched:
                continue
            if not recursive and not any(name.count('.') - p.count('.') <= depth for p in matched):
                continue
        elif not recursive and name.count('.') >= depth:
            continue
        result.names.append(name)
        if '.' in name:
            prefix = name.rsplit('.', 1)[0]
            if prefix not in result.prefixes:
                result.prefixes.append(prefix)
    return result


def parameter_event(node: Any, new: List[Parameter] = (), changed: List[Parameter] = (),
                    deleted: List[Parameter] = ()) -> Any:
    """The ParameterEvent a node publishes on /parameter_events."""
    return ParameterEvent(stamp=node.get_clock().now().to_msg(), node=node.get_fully_qualified_name(),
                          new_parameters=[p.to_parameter_msg() for p in new],
                          changed_parameters=[p.to_parameter_msg() for p in changed],
                          deleted_parameters=[p.to_parameter_msg() for p in deleted])
