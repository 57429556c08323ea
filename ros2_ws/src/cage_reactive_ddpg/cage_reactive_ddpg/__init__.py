"""cage_reactive_ddpg: the reactive DDPG layer (ROS-free except ``policy_node``).

Modules: ``networks`` (actor/critic, the only definition), ``config`` (one typed config + presets),
``buffer`` (replay), ``agent`` (DDPG/TD3 updates), ``policy`` (load a shipped/trained policy),
``train`` and ``evaluate`` (console scripts).
"""
__version__ = "0.1.0"
