"""11.10: a module whose close() raises; the rest is still closed."""
import logging, tempfile
from pathlib import Path
from cyborg.app.config import parse_config
from cyborg.app.registry import module_kinds
from cyborg.app.robot import build_robot
from cyborg.modules import ModuleKind, ModuleSettings
from cyborg.modules.behaviour import BehaviourModule
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
logging.basicConfig(level=logging.ERROR, format="%(levelname)s %(name)s: %(message)s")
class Bad(BehaviourModule):
    def close(self):
        raise RuntimeError("badplug: I fail at close")
KIND = ModuleKind(ModuleSettings, lambda node, settings, context: Bad(node))
cfg = parse_config("initial: idle\nstates:\n  idle: {action: cyborg_idle/idle, transitions: {aborted: idle}}\nmodules:\n  cyborg_bad: {kind: bad}\n  cyborg_idle: {kind: idle}\n")
clock = VirtualClock(); t = EmbeddedTransport(clock)
robot = build_robot(cfg, t, data_dir=Path(tempfile.mkdtemp()), kinds=module_kinds({"bad": KIND}))
robot.start(); clock.run(clock.sleep(1))
robot.close()
print("controller closed:", robot.store.save_status.saved is not None, "; idle server withdrawn:", not t._action_servers)
t.shutdown(); clock.close()
