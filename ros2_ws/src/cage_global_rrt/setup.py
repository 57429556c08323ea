from glob import glob

from setuptools import find_packages, setup

package_name = 'cage_global_rrt'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
    ],
    install_requires=['setuptools', 'numpy', 'ompl>=2.0'],
    zip_safe=True,
    maintainer='cage planner maintainers',
    maintainer_email='cage-planner@example.org',
    description='OMPL global planner over the known sea-cage map, and its ROS 2 node',
    license='Apache-2.0',
    extras_require={'test': ['pytest'], 'fast': ['numba']},
    entry_points={
        'console_scripts': [
            'rrt_node = cage_global_rrt.nodes.rrt_node:main',
        ],
    },
)
