"""An example controller: a user's node in place of the built-in policies.

The contract (docs/ros.md): answer every Measurement on /tethernet/measurement, reliably,
with a decision of the same episode and step: before the net has left (``launched``
false, an episode with a launch policy) a LaunchDecision on /tethernet/launch_decision,
after it a ClosingDecision on /tethernet/closing_decision.

It fires the net as soon as the sensed long axis of the target lies within
``max_tilt_deg`` of the plane across the line of sight (a reactive rule: the built-in
'predictive' policy looks ahead to when the net arrives instead).  It closes when the
sensed z_rel = z(net point) - z(target), extrapolated ``lead_time`` s ahead from its last
two measurements, reaches the episode's closing displacement.  With lead_time 0 it is the
built-in threshold policy, bit for bit.

    ros2 run tethernet_ros example_controller --ros-args -p lead_time:=0.05
    tethernet validate --design time-min --via ros --controller example_controller
"""
import math

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from tethernet_msgs.msg import ClosingDecision, LaunchDecision, Measurement


class LeadController(Node):
    def __init__(self):
        super().__init__("lead_controller")
        self.lead = self.declare_parameter("lead_time", 0.0).value      # s
        self.max_tilt = self.declare_parameter("max_tilt_deg", 30.0).value   # deg
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.pub = self.create_publisher(ClosingDecision, "/tethernet/closing_decision", qos)
        self.pub_launch = self.create_publisher(LaunchDecision, "/tethernet/launch_decision",
                                                qos)
        self.create_subscription(Measurement, "/tethernet/measurement", self.on_measurement, qos)
        self.episode, self.last = None, None          # this episode's last (time, z_rel)

    def on_measurement(self, m: Measurement) -> None:
        if m.episode_id != self.episode:              # a new episode: forget the last one
            self.episode, self.last = m.episode_id, None
        if not m.launched:                            # the net is still stowed
            fire = False
            if m.valid:
                q = m.target_orientation              # the long (body x) axis' z component
                a_z = 2.0 * (q.x * q.z - q.w * q.y)
                fire = abs(a_z) <= math.sin(math.radians(self.max_tilt))
            self.pub_launch.publish(LaunchDecision(header=m.header, episode_id=m.episode_id,
                                                   step=m.step, launch=fire,
                                                   controller=self.get_name()))
            return
        close = False
        if m.valid:                                   # (none yet while the latency lasts)
            t = m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec
            z_rel = m.net_point.z - m.target_position.z
            ahead = z_rel
            if self.lead and self.last is not None and t > self.last[0]:   # (not a repeat)
                ahead += self.lead * (z_rel - self.last[1]) / (t - self.last[0])
            close = ahead >= m.closing_displacement
            self.last = (t, z_rel)
        self.pub.publish(ClosingDecision(header=m.header, episode_id=m.episode_id, step=m.step,
                                         close=close, controller=self.get_name()))


def main(args=None) -> int:
    rclpy.init(args=args)
    node = LeadController()
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        # short waits, not rclpy.spin(node): now and then a SIGTERM shuts the context down
        # without waking a wait that has no end, and the node would never exit
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.2)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
