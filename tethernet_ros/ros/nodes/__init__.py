"""The five nodes of the capture suite, each a process with a ``main()``:

sim_node       owns the scenario and the kernel; publishes states, target pose, /clock,
               markers and the simulation's EpisodeResult; in lockstep episodes the true
               measurement of every control step, and waits for its ClosingDecision
monitor_node   computes CQI terms and locked pairs from received states with the core's
               functions; decides the verdict at the end of the settling time
actuator_node  turns an EpisodeSetup (nominal design, seed, noise settings) into noisy
               LaunchCommand / ClosingCommand with the core's single noise sampler; in
               lockstep episodes runs the closing policy (unless a user's node does)
sensor_node    in lockstep episodes: the sensed Measurement of each true one (the core's
               Sensor), and the sensed state as geometry_msgs with covariance
capture_node   the RunCapture service: validates requests, broadcasts the EpisodeSetup,
               records the bag, waits for the result and the verdict

``python -m tethernet_ros.ros.nodes.<node>``, the console script ``<node>``, or
``ros2 run tethernet_ros <node>``.  Nothing here re-implements physics or metrics.
"""
