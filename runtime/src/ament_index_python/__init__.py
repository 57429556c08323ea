"""ament_index_python for the cage runtime: where installed ROS packages keep their share files."""

from ament_index_python.packages import (PackageNotFoundError, get_package_prefix,  # noqa: F401
                                         get_package_share_directory, get_package_share_path,
                                         get_packages_with_prefixes)
