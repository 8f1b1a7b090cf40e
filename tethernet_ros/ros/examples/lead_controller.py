"""An example closing controller: a user's node in place of the built-in policy.

The contract (docs/ros.md): answer every Measurement on /tethernet/measurement with a
ClosingDecision of the same episode and step on /tethernet/closing_decision, reliably.
This one closes when the sensed z_rel = z(net point) - z(target), extrapolated
``lead_time`` s ahead from its last two measurements, reaches the episode's closing
displacement.  With lead_time 0 it is the built-in threshold policy, bit for bit.

    ros2 run tethernet_ros example_controller --ros-args -p lead_time:=0.05
    tethernet validate --design time-min --via ros --controller example_controller
"""
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from tethernet_msgs.msg import ClosingDecision, Measurement


class LeadController(Node):
    def __init__(self):
        super().__init__("lead_controller")
        self.lead = self.declare_parameter("lead_time", 0.0).value      # s
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.pub = self.create_publisher(ClosingDecision, "/tethernet/closing_decision", qos)
        self.create_subscription(Measurement, "/tethernet/measurement", self.on_measurement, qos)
        self.episode, self.last = None, None          # this episode's last (time, z_rel)

    def on_measurement(self, m: Measurement) -> None:
        if m.episode_id != self.episode:              # a new episode: forget the last one
            self.episode, self.last = m.episode_id, None
        close = False
        if m.valid:                                   # (none yet while the latency lasts)
            t = m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec
            z_rel = m.net_point.z - m.target_position.z
            ahead = z_rel
            if self.lead and self.last is not None:
                ahead += self.lead * (z_rel - self.last[1]) / (t - self.last[0])
            close = ahead >= m.closing_displacement
            self.last = (t, z_rel)
        self.pub.publish(ClosingDecision(header=m.header, episode_id=m.episode_id, step=m.step,
                                         close=close, controller=self.get_name()))


def main(args=None) -> int:
    rclpy.init(args=args)
    node = LeadController()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
