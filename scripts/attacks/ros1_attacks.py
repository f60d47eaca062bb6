"""ros1_attacks.py: the review's sections 6.3 and 7 against `cyborg launch` (ROS 1) and `cyborg node` parts."""
import json, os, signal, subprocess, sys, time, urllib.request
HERE = os.getcwd()  # run from a scratch folder holding rosdemo.yaml and the stranger scripts
PY = sys.executable
env = dict(os.environ)
SETUP = os.path.join(os.path.dirname(sys.executable), "..", "ros", "setup.sh")  # written by scripts/install-ros
out = subprocess.run(["bash", "-c", f". {SETUP}; env -0"], capture_output=True, env=env).stdout.decode()
env = dict(kv.split("=", 1) for kv in out.split("\0") if "=" in kv)
env["PYTHONPATH"] = os.environ.get("CYBORG_SRC", os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", "src"))) + ":" + env["PYTHONPATH"]
env["NO_COLOR"] = "1"; env["PYTHONUNBUFFERED"] = "1"
MPORT = int(sys.argv[2]) if len(sys.argv) > 2 else 11771
env["ROS_MASTER_URI"] = f"http://localhost:{MPORT}"
API = int(sys.argv[3]) if len(sys.argv) > 3 else 18781
URL = f"http://127.0.0.1:{API}"
procs = []
def start(cmd, log):
    p = subprocess.Popen(cmd, stdout=open(os.path.join(HERE, log), "w"), stderr=subprocess.STDOUT, env=env, start_new_session=True, cwd=HERE)
    procs.append(p); return p
def get(path):
    with urllib.request.urlopen(URL + path, timeout=10) as r: return json.loads(r.read())
def event(name):
    req = urllib.request.Request(URL + "/api/event", data=json.dumps({"name": name}).encode(), headers={"Content-Type": "application/json"})
    urllib.request.urlopen(req, timeout=10).read()
def state():
    try: return get("/api/status")["state"]
    except Exception as e: return f"?{type(e).__name__}"
def wait_state(target, limit):
    t0 = time.monotonic()
    while time.monotonic() - t0 < limit:
        if state() == target: return time.monotonic() - t0
        time.sleep(0.1)
    return None
def descendants(root):
    kids = {}
    for p in os.listdir("/proc"):
        if p.isdigit():
            try: kids.setdefault(int(open(f"/proc/{p}/stat").read().rsplit(")", 1)[1].split()[1]), []).append(int(p))
            except OSError: pass
    out, todo = [], [root]
    while todo:
        q = todo.pop(); out.append(q); todo += kids.get(q, [])
    return out
def pid_of(node, root):
    """The pid of node NODE among the descendants of ROOT (never another user's process)."""
    for pid in descendants(root):
        try: cmd = open(f"/proc/{pid}/cmdline").read().split("\0")
        except OSError: continue
        if "node" in cmd and node in cmd: return pid
    raise SystemExit(f"no {node} under {root}")
def log_lines(name): return open(os.path.join(HERE, name), errors="replace").read().splitlines()
def cleanup():
    tree = [q for p in procs if p.poll() is None for q in descendants(p.pid)]
    for p in procs:
        if p.poll() is None:
            try: os.killpg(p.pid, signal.SIGINT)
            except ProcessLookupError: pass
    time.sleep(3)
    for p in procs:
        if p.poll() is None:
            try: os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError: pass
    for q in tree:
        try: os.kill(q, signal.SIGKILL)
        except ProcessLookupError: pass
def launch():
    start(["roscore", "-p", str(MPORT)], f"roscore{MPORT}.log"); time.sleep(4)
    lp = start([PY, "-m", "cyborg.cli", "launch", "--config", "rosdemo.yaml", "--port", str(API), "--db", f"dl{MPORT}", "--no-record"], f"launch{MPORT}.log")
    t = wait_state("idle", 120); print("launch up, idle after", t, "s", flush=True); time.sleep(3)
    return lp
what = sys.argv[1]
try:
    if what == "launch":   # 7.1, 7.3, 6.3, 7.6
        lp = launch()
        event("music_play"); print("7.1 music after", wait_state("music", 10)); time.sleep(1)
        pid = pid_of("cyborg_music", lp.pid); print("7.1 cyborg_music pid", pid); os.kill(pid, signal.SIGKILL); t0 = time.monotonic()
        print("7.1 after kill -9: idle after", wait_state("idle", 20), "s;", get("/api/records?type=state")[-1])
        time.sleep(4); event("music_play"); print("7.1 music_play again -> music after", wait_state("music", 15))
        # 7.3 stubborn preempted by stop
        event("stubborn_go"); print("7.3 stubborn after", wait_state("stubborn", 10)); time.sleep(1)
        t0 = time.monotonic(); event("stop"); print("7.3 stop -> idle after %.1f s" % (wait_state("idle", 15) or -1), get("/api/health")["stats"]["preempt_timeouts"], "preempt timeouts")
        event("music_play"); print("7.3 later music_play ->", wait_state("music", 10))
        # 6.3 flood
        n0 = len(log_lines(f"launch{MPORT}.log")); h0 = get("/api/health")["stats"]
        fl = [start([PY, "rflood.py", f"stranger{i}", "6"], f"rflood{i}.log") for i in (1, 2)]
        rt = start(["rostopic", "pub", "-r", "1000", "/cyborg_controller/register_event", "std_msgs/String", "data: stop"], "rtpub.log")
        for p in fl: p.wait(60)
        os.killpg(rt.pid, signal.SIGINT); time.sleep(1)
        t_end = time.monotonic()
        event("stubborn_go"); event("music_play")
        took = wait_state("music", 60)
        print("6.3 person's stubborn_go+music_play after the flood -> music after", took)
        time.sleep(2)
        h1 = get("/api/health")["stats"]; lines = log_lines(f"launch{MPORT}.log")[n0:]
        print("6.3 stats delta", {k: h1[k] - h0.get(k, 0) for k in h1 if h1[k] != h0.get(k, 0)})
        print("6.3 launch lines since the flood", len(lines), "drop lines", sum("dropped" in l for l in lines))
        for i in (1, 2): print("   ", log_lines(f"rflood{i}.log")[-1:])
        # 7.6 a second cyborg node cyborg_music
        r = subprocess.run([PY, "-m", "cyborg.cli", "node", "cyborg_music", "--config", "rosdemo.yaml", "--db", "dl2"], capture_output=True, text=True, env=env, timeout=60, cwd=HERE)
        print("7.6 second cyborg_music: exit", r.returncode, [l[:300] for l in r.stderr.splitlines() if "already" in l])
        event("stop"); wait_state("idle", 10); event("music_play"); print("7.6 music_play after ->", wait_state("music", 10))
        # 7.4/7.5 master outage
        master = procs[0]; kids = descendants(master.pid); print("7.4 roscore tree", kids)
        for pid in kids:
            try: os.kill(pid, signal.SIGKILL)
            except ProcessLookupError: pass
        master.wait(); time.sleep(0.5)
        print("7.4 roscore, rosmaster killed; master answers:", subprocess.run(["rosnode", "list"], capture_output=True, env=env, timeout=20).returncode == 0)
        time.sleep(3)
        for e, s in (("stop", "idle"), ("music_play", "music"), ("stop", "idle")):
            event(e); print(f"7.4 with master down: {e} -> {s} after", wait_state(s, 10))
        start(["roscore", "-p", str(MPORT)], f"roscore{MPORT}b.log"); time.sleep(20)
        nodes = subprocess.run(["rosnode", "list"], capture_output=True, text=True, env=env, timeout=30).stdout.split()
        print("7.5 rosnode list after restart:", nodes)
        svc = subprocess.run(["rosservice", "call", "/cyborg_controller/get_emotional_state"], capture_output=True, text=True, env=env, timeout=30)
        print("7.5 rosservice call:", svc.returncode, svc.stdout.strip().splitlines()[:1])
        subprocess.run(["rostopic", "pub", "-1", "/cyborg_controller/register_event", "std_msgs/String", "data: music_play"], env=env, timeout=30, capture_output=True)
        print("7.5 rostopic pub music_play -> music after", wait_state("music", 10))
        lines = log_lines(f"launch{MPORT}.log")
        print("7.4 master lines:", [l[:220] for l in lines if "master" in l.lower()])
    elif what == "nodes":   # 7.2: each part by cyborg node
        start(["roscore", "-p", str(MPORT)], f"roscore{MPORT}.log"); time.sleep(4)
        for n in ("cyborg_controller", "cyborg_idle", "cyborg_stubborn"):
            start([PY, "-m", "cyborg.cli", "node", n, "--config", "rosdemo.yaml", "--db", "dn"], f"node_{n}.log")
        mp = start([PY, "-m", "cyborg.cli", "node", "cyborg_music", "--config", "rosdemo.yaml", "--db", "dn"], "node_cyborg_music.log")
        time.sleep(15)
        start(["rostopic", "echo", "/cyborg_controller/state_change"], "states72.log"); time.sleep(3)
        def ev(name): subprocess.run(["rostopic", "pub", "-1", "/cyborg_controller/register_event", "std_msgs/String", f"data: {name}"], env=env, timeout=30, capture_output=True)
        ev("music_play"); time.sleep(3)
        os.killpg(mp.pid, signal.SIGKILL); t0 = time.monotonic(); time.sleep(5)
        ctl = log_lines("node_cyborg_controller.log")
        print("7.2 controller log after kill:", [l[:200] for l in ctl if "music" in l][-3:])
        ev("music_play"); time.sleep(5)
        print("7.2 music_play without server:", [l[:200] for l in log_lines("node_cyborg_controller.log") if "music" in l][-3:])
        mp = start([PY, "-m", "cyborg.cli", "node", "cyborg_music", "--config", "rosdemo.yaml", "--db", "dn"], "node_cyborg_music2.log")
        time.sleep(12); ev("music_play"); time.sleep(4)
        print("7.2 restarted node:", [l[:200] for l in log_lines("node_cyborg_music2.log")][-3:])
        print("7.2 state changes:", " | ".join(l.strip() for l in log_lines("states72.log") if l.strip() and "---" not in l))
finally:
    cleanup()
