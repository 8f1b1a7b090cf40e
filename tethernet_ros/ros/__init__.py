"""Everything of tethernet_ros that talks ROS 2 (the only package that imports rclpy).

names.py        topic and service names, message types, what the suite requires
parameters.py   node parameter defaults (config/tethernet.yaml mirrors them)
qos.py          QoS profiles
conversions/    message <-> core conversions (``*_msg`` / ``*_from_msg``), a module per
                message family
state.py        what nodes hold between messages: setup, commands, state snapshots
loop.py         the closed loop cut at its joints (lockstep episodes): ControlledSimulation,
                the episode's Sensor and Policy outside the kernel
markers.py      MarkerArray for Foxglove / RViz
publishing.py   the sim node's publishing simulation and outbox thread
recording.py    the capture node's record of one episode (completeness by stamps)
results.py      comparing results; an episode's result read back from its bag
runner.py       the nodes' main loop (clean shutdown on SIGINT and SIGTERM)
nodes/          sim_node, monitor_node, actuator_node, sensor_node, capture_node
suite.py        the five nodes (and a user's controller) as processes + a client: RosSuite,
                capture_via_ros
backend.py      RosBackend: the Monte Carlo EpisodeBackend over K suites side by side
controller_host.py  runs a user's controller Node class (module:Class) as a process
examples/       the example controller (console script example_controller)

The pure library (tethernet_ros.core, tethernet_ros.montecarlo) never imports this
package; modules here import rclpy lazily or only where a node needs it.
"""
