"""ROS 2 glue of the capture suite: thin nodes around the pure core.

sim_node       owns the scenario and the kernel; publishes states, target pose, /clock,
               markers and the simulation's EpisodeResult
monitor_node   computes CQI terms and locked pairs from received states with the core's
               functions; decides the verdict at the end of the settling time
actuator_node  turns an EpisodeSetup (nominal design, seed, noise settings) into noisy
               LaunchCommand / ClosingCommand with the core's single noise sampler
capture_node   the RunCapture service: validates requests, broadcasts the EpisodeSetup,
               records the bag, waits for the result and the verdict

Shared names, QoS and parameter defaults live in :mod:`.common`; message <-> core
conversions in :mod:`.convert`.  Nothing here re-implements physics or metrics.
"""
