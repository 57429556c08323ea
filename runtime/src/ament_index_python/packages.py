"""Package lookup without an ament index.

Why: ROS node code finds its config files with `get_package_share_directory(pkg)`.  In this world the
project's ament_python packages are pip-installed, and their setup.py `data_files` put share files under
`<sys.prefix>/share/<pkg>`.  Lookup order:
1. every prefix in AMENT_PREFIX_PATH holding `share/<pkg>` (a colcon install, if any);
2. `<sys.prefix>/share/<pkg>` (pip-installed data_files);
3. the source tree `<repo>/ros2_ws/src/<pkg>` (editable/development checkouts), whose layout
   (`config/`, `launch/`, `package.xml`) matches an installed share directory.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

_REPO_ROOT = Path(__file__).resolve().parents[3]


class PackageNotFoundError(KeyError):
    """Raised when a package is not found (ament_index_python's exception)."""


def _candidates(package_name: str) -> list[tuple[Path, Path]]:
    """[(prefix, share directory)] in lookup order."""
    out = []
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix:
            out.append((Path(prefix), Path(prefix) / 'share' / package_name))
    out.append((Path(sys.prefix), Path(sys.prefix) / 'share' / package_name))
    src = _REPO_ROOT / 'ros2_ws' / 'src' / package_name
    out.append((src, src))
    return out


def get_package_share_directory(package_name: str, print_warning: bool = True) -> str:
    for _prefix, share in _candidates(package_name):
        if share.is_dir():
            return str(share)
    raise PackageNotFoundError(
        f"package '{package_name}' not found, searching: "
        f"{[str(s) for _, s in _candidates(package_name)]}")


def get_package_share_path(package_name: str, print_warning: bool = True) -> Path:
    return Path(get_package_share_directory(package_name, print_warning))


def get_package_prefix(package_name: str) -> str:
    for prefix, share in _candidates(package_name):
        if share.is_dir():
            return str(prefix)
    raise PackageNotFoundError(f"package '{package_name}' not found")


def get_packages_with_prefixes() -> dict[str, str]:
    out: dict[str, str] = {}
    roots = [Path(p) / 'share' for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    roots.append(Path(sys.prefix) / 'share')
    for root in roots:
        if root.is_dir():
            for d in root.iterdir():
                if (d / 'package.xml').is_file():
                    out.setdefault(d.name, str(root.parent))
    src = _REPO_ROOT / 'ros2_ws' / 'src'
    if src.is_dir():
        for d in src.iterdir():
            if (d / 'package.xml').is_file():
                out.setdefault(d.name, str(d))
    return out
