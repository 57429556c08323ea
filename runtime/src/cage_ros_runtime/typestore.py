"""The one type store of the runtime: rosbags' ROS 2 Jazzy interfaces plus `.msg`/`.srv`/`.action` files.

Why rosbags: it carries the Jazzy standard interfaces verbatim, computes the RIHS01 type hashes that Jazzy
puts into USER_DATA, and serializes classic CDR independently of Cyclone DDS.  The project's own interfaces
(`cage_planner_msgs`) are parsed from their `.msg` files at run time so that the files in `ros2_ws/src` stay
the single source of truth for both worlds (colcon/rosidl on ROS 2, this module here).

Where `.msg` files are looked for, first hit per package wins:
1. ``CAGE_MSG_PATH`` (os.pathsep-separated): each entry is a package directory holding ``msg/*.msg``
   (its base name is the package name), or a directory of such package directories.
2. ``<sys.prefix>/share/<pkg>/msg`` for every package directory under ``<sys.prefix>/share``
   that holds ``.msg`` files (what an installed ament package leaves behind).
3. The source tree this runtime was installed from: ``<repo>/ros2_ws/src/<pkg>/msg``.
4. The runtime's own copies of the Jazzy service definitions rosbags lacks (``share/``:
   rcl_interfaces' parameter services, action_msgs/CancelGoal, std_srvs).

Services and actions are expanded into messages exactly as rosidl does it (see
:mod:`cage_ros_runtime.interfaces`), so their DDS type names and RIHS01 hashes are rosidl's.
Two deliberate departures from rosbags, both to match rosidl: msg `char` is stored as `uint8` (rosidl
maps it so, which changes the type hash), and `.msg` default values are kept (:func:`field_defaults`).
"""

from __future__ import annotations

import functools
import os
import sys
from pathlib import Path

from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

#: Repository root when running from the source tree (runtime/src/cage_ros_runtime/typestore.py).
_REPO_ROOT = Path(__file__).resolve().parents[3]


_KINDS = ('msg', 'srv', 'action')
#: The runtime's copies of standard service definitions (lowest priority).
_BUILTIN_ROOT = Path(__file__).resolve().parent / 'share'


def _is_package_dir(path: Path) -> bool:
    return any((path / kind).is_dir() and any((path / kind).glob(f'*.{kind}')) for kind in _KINDS)


def _package_dirs_under(root: Path) -> list[Path]:
    """Package directories below `root` (or `root` itself) with `msg/`, `srv/` or `action/` files."""
    if not root.is_dir():
        return []
    if _is_package_dir(root):
        return [root]
    return sorted(p for p in root.iterdir() if p.is_dir() and _is_package_dir(p))


def msg_package_dirs() -> dict[str, Path]:
    """Map package name -> package directory for every project interface package that can be found."""
    roots: list[Path] = []
    for entry in os.environ.get('CAGE_MSG_PATH', '').split(os.pathsep):
        if entry:
            roots.append(Path(entry))
    roots.append(Path(sys.prefix) / 'share')
    roots.append(_REPO_ROOT / 'ros2_ws' / 'src')
    found: dict[str, Path] = {}
    for root in roots:
        for pkg_dir in _package_dirs_under(root):
            found.setdefault(pkg_dir.name, pkg_dir)
    return found


def interface_files() -> list[tuple[str, str, Path]]:
    """(package, kind, file) of every interface file to load: project packages, then the builtin copies.

    A package found in several places is read from the first; the builtin copies only add files
    (services) that rosbags' Jazzy store lacks.
    """
    out: list[tuple[str, str, Path]] = []
    for pkg, pkg_dir in msg_package_dirs().items():
        for kind in _KINDS:
            out.extend((pkg, kind, f) for f in sorted((pkg_dir / kind).glob(f'*.{kind}')))
    for pkg_dir in _package_dirs_under(_BUILTIN_ROOT):
        for kind in _KINDS:
            out.extend((pkg_dir.name, kind, f) for f in sorted((pkg_dir / kind).glob(f'*.{kind}')))
    return out


_DEFAULTS: dict[str, dict[str, object]] = {}


@functools.lru_cache(maxsize=1)
def typestore() -> Typestore:
    """The process-wide type store (built once; registering types is not thread-safe in rosbags)."""
    from cage_ros_runtime import interfaces
    store = get_typestore(Stores.ROS2_JAZZY)
    _DEFAULTS.update(interfaces.JAZZY_DEFAULTS)
    extra: dict = {}
    for pkg, kind, path in interface_files():
        name = f'{pkg}/{kind}/{path.stem}'
        if name in store.fielddefs or name in extra:
            continue  # never redefine a standard interface; first package directory wins
        try:
            types, defaults = interfaces.expand(pkg, kind, path.stem, path.read_text(encoding='utf-8'))
        except Exception as exc:  # noqa: BLE001 - one bad file must not take every interface down
            raise ValueError(f'{path}: {exc}') from None
        extra.update(types)
        _DEFAULTS.update(defaults)
    if extra:
        store.register(extra)
    interfaces.chars_as_uint8(store)
    return store


def field_defaults(ros_type: str) -> dict[str, object]:
    """Default values the interface file gives its fields (`float64 w 1.0`), as rosidl applies them."""
    typestore()
    return _DEFAULTS.get(ros_type, {})


def packages() -> set[str]:
    """All interface packages known to the type store."""
    return {name.split('/', 1)[0] for name in typestore().fielddefs}


def dds_type_name(ros_type: str) -> str:
    """`sensor_msgs/msg/LaserScan` -> `sensor_msgs::msg::dds_::LaserScan_` (rmw_cyclonedds naming)."""
    pkg, kind, name = ros_type.split('/')
    return f'{pkg}::{kind}::dds_::{name}_'


def ros_type_name(dds_name: str) -> str | None:
    """Inverse of :func:`dds_type_name`; None for names that are not ROS-mangled."""
    parts = dds_name.split('::')
    if len(parts) != 4 or parts[2] != 'dds_' or not parts[3].endswith('_'):
        return None
    return f'{parts[0]}/{parts[1]}/{parts[3][:-1]}'


@functools.lru_cache(maxsize=None)
def type_hash(ros_type: str) -> str:
    """RIHS01 hash of a type, as Jazzy advertises it in endpoint USER_DATA."""
    return typestore().hash_rihs01(ros_type)
