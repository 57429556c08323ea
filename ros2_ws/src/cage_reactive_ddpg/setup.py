from glob import glob

from setuptools import find_packages, setup

package_name = 'cage_reactive_ddpg'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={package_name: ['weights/*']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
    ],
    # torch==2.13.0, safetensors, tqdm, tensorboard, matplotlib come from the repo's requirements.txt.
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='cage planner maintainers',
    maintainer_email='cage-planner@example.org',
    description='Reactive DDPG layer: networks, trainer, evaluator, shipped policy, policy node',
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
    entry_points={
        'console_scripts': [
            'policy_node = cage_reactive_ddpg.nodes.policy_node:main',
            'train = cage_reactive_ddpg.train:main',
            'evaluate = cage_reactive_ddpg.evaluate:main',
            'sweep = cage_reactive_ddpg.sweep:main',
        ],
    },
)
