"""rclpy.action: ActionServer and ActionClient over rcl_action's three services and two topics."""

from rclpy.action.client import ActionClient, ClientGoalHandle
from rclpy.action.server import ActionServer, CancelResponse, GoalResponse, ServerGoalHandle

__all__ = ['ActionServer', 'ActionClient', 'CancelResponse', 'GoalResponse', 'ServerGoalHandle',
           'ClientGoalHandle', 'get_action_names_and_types']


def get_action_names_and_types(node: object) -> list:
    """[(action name, [type])] from the graph: topics `<name>/_action/feedback` of type `*_FeedbackMessage`."""
    out = []
    for topic, types in node.get_topic_names_and_types():  # type: ignore[attr-defined]
        if topic.endswith('/_action/feedback'):
            names = sorted(t[:-len('_FeedbackMessage')] for t in types if t.endswith('_FeedbackMessage'))
            if names:
                out.append((topic[:-len('/_action/feedback')], names))
    return out
