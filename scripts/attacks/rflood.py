"""rflood.py NAME SECONDS: a rospy stranger publishing valid events on /cyborg_controller/register_event as fast as it can."""
import sys, time
import rospy
from std_msgs.msg import String
rospy.init_node(sys.argv[1], disable_signals=True)
pub = rospy.Publisher("/cyborg_controller/register_event", String, queue_size=1000)
time.sleep(1.5)
n = 0; end = time.monotonic() + float(sys.argv[2]); names = ["stubborn_go", "music_play", "stop"]
while time.monotonic() < end:
    pub.publish(String(names[n % 3])); n += 1
print(f"{sys.argv[1]} sent {n} ({n/float(sys.argv[2]):,.0f}/s)", flush=True)
time.sleep(0.5)
