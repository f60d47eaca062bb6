"""embflood.py CONFIG SECONDS: the robot of CONFIG in one process (embedded transport, real clock); a node floods
register_event with the current state's valid events for SECONDS; then a person's event. Prints counts, log records,
the longest loop stall, RSS, and when the person's event was taken."""
import asyncio, logging, resource, sys, tempfile, time
from pathlib import Path
from cyborg.app.config import load_config
from cyborg.app.robot import build_robot
from cyborg.transport import topics
from cyborg.transport.clock import RealClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String

config = load_config(sys.argv[1]); SECONDS = float(sys.argv[2])
records = []
class Count(logging.Handler):
    def emit(self, r): records.append(r)
logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s", stream=open("embflood.log", "w"))
logging.getLogger().addHandler(Count())
clock = RealClock(); transport = EmbeddedTransport(clock)
robot = build_robot(config, transport, data_dir=Path(tempfile.mkdtemp()))
pub = transport.node("stranger").publisher(topics.REGISTER_EVENT, String)
person = transport.node("person").publisher(topics.REGISTER_EVENT, String)
def rss(): return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
async def main():
    robot.start(); await asyncio.sleep(3)
    lag = [0.0]
    async def ticker():
        while True:
            t = time.monotonic(); await asyncio.sleep(0.01); lag[0] = max(lag[0], time.monotonic() - t - 0.01)
    tick = asyncio.ensure_future(ticker())
    r0, n0 = rss(), len(records)
    sent = 0; stop = time.monotonic() + SECONDS
    while time.monotonic() < stop:
        valid = list(robot.controller.valid_events()) or ["stop"]
        for i in range(200):
            pub.publish(String(valid[i % len(valid)])); sent += 1
        await asyncio.sleep(0)
    print(f"sent {sent} in {SECONDS:g} s ({sent/SECONDS:,.0f}/s); stats {robot.controller.stats}")
    print(f"log records during the flood: {len(records)-n0}; longest loop stall {lag[0]*1000:.0f} ms; maxrss {r0:.0f} -> {rss():.0f} MB")
    t0 = time.monotonic(); target = "music"
    person.publish(String("stubborn_go")); person.publish(String("music_play"))
    while robot.controller.active_state != target and time.monotonic() - t0 < 60:
        await asyncio.sleep(0.05)
    print(f"person's stubborn_go+music_play: state {robot.controller.active_state} after {time.monotonic()-t0:.1f} s; log records in all {len(records)-n0}")
    tick.cancel(); await robot.controller.stop(); robot.close(); transport.shutdown()
clock.run(main()); clock.close()
