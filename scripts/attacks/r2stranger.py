"""r2stranger.py MODE [SECONDS]: plain rclpy strangers. flood: valid events on register_event as fast as possible;
nan: EmotionalFeedback (nan, inf, -inf) and (1e308, 0, 0); wrongtype: std_msgs/Int32 on register_event;
fakehome: a node named cyborg_parameters with no parameter services (stays SECONDS)."""
import math, sys, time
import rclpy
from rclpy.node import Node
from std_msgs.msg import String, Int32
from cyborg_controller.msg import EmotionalFeedback
mode = sys.argv[1]; seconds = float(sys.argv[2]) if len(sys.argv) > 2 else 6
rclpy.init()
if mode == "fakehome":
    node = Node("cyborg_parameters", start_parameter_services=False)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.2)
    sys.exit(0)
node = Node(f"stranger_{mode}")
def matched(pub, limit=20):
    end = time.monotonic() + limit
    while pub.get_subscription_count() == 0 and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    time.sleep(0.5)
if mode == "flood":
    pub = node.create_publisher(String, "/cyborg_controller/register_event", 1000); matched(pub)
    n = 0; end = time.monotonic() + seconds; names = ["stubborn_go", "music_play", "stop"]
    while time.monotonic() < end:
        pub.publish(String(data=names[n % 3])); n += 1
    print(f"flood sent {n} ({n/seconds:,.0f}/s)", flush=True)
elif mode == "nan":
    pub = node.create_publisher(EmotionalFeedback, "/cyborg_controller/emotional_feedback", 10); matched(pub)
    for v in ((math.nan, math.inf, -math.inf), (1e308, 0.0, 0.0)):
        pub.publish(EmotionalFeedback(delta_pleasure=v[0], delta_arousal=v[1], delta_dominance=v[2])); time.sleep(0.3)
    print("nan sent", flush=True)
elif mode == "wrongtype":
    pub = node.create_publisher(Int32, "/cyborg_controller/register_event", 10)
    time.sleep(3)
    for i in range(5): pub.publish(Int32(data=i)); time.sleep(0.1)
    print("wrongtype sent", flush=True)
time.sleep(1.0)
node.destroy_node(); rclpy.shutdown()
