from glob import glob

from setuptools import find_packages, setup

package_name = 'cage_sim'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={package_name: ['scenarios/*.yaml']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
        ('share/' + package_name + '/config/rviz', glob('config/rviz/*.rviz')),
        ('share/' + package_name + '/config/foxglove', glob('config/foxglove/*.json')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='cage planner maintainers',
    maintainer_email='cage-planner@example.org',
    description='Sea-cage AUV simulation core and nodes',
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
    entry_points={
        'console_scripts': [
            'sim_node = cage_sim.nodes.sim_node:main',
            'vehicle_node = cage_sim.nodes.vehicle_node:main',
            'mission_client = cage_sim.nodes.mission_client_node:main',
            'navigator_node = cage_sim.nodes.navigator_node:main',
            'recorder_node = cage_sim.nodes.recorder_node:main',
            'cage_demo = cage_sim.demo:main',
        ],
    },
)
