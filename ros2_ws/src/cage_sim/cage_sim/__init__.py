"""cage_sim: the ROS-free sea-cage simulation core (world, sonar, vehicle, scenarios, env) and its nodes.

Import ``cage_sim.env`` to register the Gymnasium environments.
"""
