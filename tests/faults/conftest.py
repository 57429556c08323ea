"""Fault-suite fixtures: the node-graph fixtures (own DDS domain, `ros2 run` processes, probe node)
from tests/graph, plus helpers for hostile inputs (tests/faults/faultlib.py)."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

_GRAPH = Path(__file__).resolve().parents[1] / "graph"
sys.path.insert(0, str(_GRAPH))
sys.path.insert(0, str(Path(__file__).resolve().parent))
_spec = importlib.util.spec_from_file_location("graph_conftest", _GRAPH / "conftest.py")
_graph = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_graph)

ros_env = _graph.ros_env
launch = _graph.launch
probe = _graph.probe
