"""ros2_attacks.py DOMAIN EMPTY_DOMAIN API_PORT: the review's section 10 against `cyborg launch --ros2` of this checkout."""
import json, os, random, signal, subprocess, sys, time, urllib.request
HERE = os.getcwd()  # run from a scratch folder holding rosdemo.yaml and the stranger scripts
R2 = os.environ.get("CYBORG_ROS2_PYTHON", os.path.join(os.path.dirname(__file__), "..", "..", ".venv-ros2", "bin", "python"))
DOMAIN, EMPTY, API = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
URL = f"http://127.0.0.1:{API}"
base = {k: v for k, v in os.environ.items() if not k.startswith("ROS_") and k not in ("VIRTUAL_ENV", "PYTHONPATH")}
base.update(ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", ROS_LOG_DIR=os.path.join(HERE, "r2log"), NO_COLOR="1", PYTHONUNBUFFERED="1")
env = dict(base, PYTHONPATH=os.environ.get("CYBORG_SRC", os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", "src"))), ROS_DOMAIN_ID=str(DOMAIN))
stranger_env = dict(base, ROS_DOMAIN_ID=str(DOMAIN))
procs = []
def start(cmd, log, e=env):
    p = subprocess.Popen(cmd, stdout=open(os.path.join(HERE, log), "w"), stderr=subprocess.STDOUT, env=e, start_new_session=True, cwd=HERE)
    procs.append(p); return p
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
    for pid in descendants(root):
        try: cmd = open(f"/proc/{pid}/cmdline").read().split("\0")
        except OSError: continue
        if "node" in cmd and node in cmd: return pid
    raise SystemExit(f"no {node} under {root}")
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
        if state() == target: return round(time.monotonic() - t0, 2)
        time.sleep(0.1)
    return None
def lines(name): return open(os.path.join(HERE, name), errors="replace").read().splitlines()
def cyborg(*args, e=env, timeout=120):
    t0 = time.monotonic()
    r = subprocess.run([R2, "-m", "cyborg.cli", *args], capture_output=True, text=True, env=e, timeout=timeout, cwd=HERE)
    return r.returncode, round(time.monotonic() - t0, 1), (r.stdout + r.stderr).strip().splitlines()
def cleanup():
    tree = [q for p in procs if p.poll() is None for q in descendants(p.pid)]
    for p in procs:
        if p.poll() is None:
            try: os.killpg(p.pid, signal.SIGINT)
            except ProcessLookupError: pass
    time.sleep(5)
    for q in tree:
        try: os.kill(q, signal.SIGKILL)
        except ProcessLookupError: pass
try:
    # 10.13 on an empty domain
    e0 = dict(env, ROS_DOMAIN_ID=str(EMPTY))
    print("10.13 status --ros2 on an empty domain:", cyborg("status", "--ros2", e=e0)[:2], cyborg("status", "--ros2", e=e0)[2][-1:])
    rc, t, out = cyborg("event", "music_play", "--ros2", e=e0); print("10.13 event --ros2:", rc, t, out[-1:])
    # 10.10 a stranger named cyborg_parameters, then the launch
    fh = start([R2, "r2stranger.py", "fakehome", "200"], "fakehome.log", stranger_env); time.sleep(4)
    rc, t, out = cyborg("launch", "--ros2", "--config", "rosdemo.yaml", "--port", str(API), "--db", "d10fh", "--no-record", "--duration", "30", timeout=150)
    print("10.10 launch beside a foreign cyborg_parameters:", rc, t, [l[:300] for l in out if "parameters" in l or "refus" in l][:3])
    os.killpg(fh.pid, signal.SIGINT); fh.wait(10); time.sleep(2)
    # the robot
    lp = start([R2, "-m", "cyborg.cli", "launch", "--ros2", "--config", "rosdemo.yaml", "--port", str(API), "--db", "d10", "--no-record"], "launch_r2.log")
    print("launch up, idle after", wait_state("idle", 150)); time.sleep(3)
    # 10.1
    event("music_play"); print("10.1 music after", wait_state("music", 10)); time.sleep(1)
    os.kill(pid_of("cyborg_music", lp.pid), signal.SIGKILL)
    print("10.1 after kill -9 of cyborg_music: idle after", wait_state("idle", 20), [l[:200] for l in lines("launch_r2.log") if "cyborg_music" in l and ("stopped" in l or "again" in l)])
    time.sleep(8); event("music_play"); print("10.1 music_play again -> music after", wait_state("music", 20))
    # 10.2
    event("stubborn_go"); print("10.2 stubborn after", wait_state("stubborn", 10)); time.sleep(1)
    print("10.2 stop -> idle after", wait_state("idle", 0.01) or (event("stop") or wait_state("idle", 15)))
    event("music_play"); print("10.2 later music_play -> music after", wait_state("music", 10))
    # 10.4, 10.5
    before = get("/api/status"); pad0 = (before["pleasure"], before["arousal"], before["dominance"])
    n0 = len(lines("launch_r2.log"))
    r = subprocess.run([R2, "r2stranger.py", "nan"], capture_output=True, text=True, env=stranger_env, timeout=60); time.sleep(2)
    after = get("/api/status"); pad1 = (after["pleasure"], after["arousal"], after["dominance"])
    print("10.4 nan feedback:", r.stdout.strip(), "PAD", pad0, "->", pad1, [l[:220] for l in lines("launch_r2.log")[n0:] if "reject" in l][:3])
    s0 = state(); r = subprocess.run([R2, "r2stranger.py", "wrongtype"], capture_output=True, text=True, env=stranger_env, timeout=60); time.sleep(1)
    print("10.5 wrong type:", r.stdout.strip(), r.returncode, "state", s0, "->", state(), "launch alive", lp.poll() is None)
    # 10.3
    n0 = len(lines("launch_r2.log")); h0 = get("/api/health")["stats"]
    fl = [start([R2, "r2stranger.py", "flood", "6"], f"r2flood{i}.log", stranger_env) for i in (1, 2)]
    for p in fl: p.wait(90)
    event("stubborn_go"); event("music_play"); took = wait_state("music", 90)
    print("10.3 person's stubborn_go+music_play after the flood -> music after", took)
    time.sleep(2); h1 = get("/api/health")["stats"]; new = lines("launch_r2.log")[n0:]
    print("10.3 stats delta", {k: h1[k] - h0.get(k, 0) for k in h1 if h1[k] != h0.get(k, 0)}, "launch lines", len(new), "drop lines", sum("dropped" in l for l in new))
    for i in (1, 2): print("    ", lines(f"r2flood{i}.log")[-1:])
    # 10.11
    rc, t, out = cyborg("node", "cyborg_music", "--ros2", "--config", "rosdemo.yaml", "--db", "d10b", timeout=90)
    print("10.11 second cyborg_music node:", rc, t, [l[:300] for l in out if "already" in l or "refus" in l][:2])
    event("stop"); wait_state("idle", 10); event("music_play"); print("10.11 music_play after -> music after", wait_state("music", 10))
    # 10.12
    os.kill(pid_of("cyborg_controller", lp.pid), signal.SIGKILL); t0 = time.monotonic(); time.sleep(3)
    back = None
    while time.monotonic() - t0 < 60:
        try:
            if get("/api/health").get("active_state"): back = round(time.monotonic() - t0, 1); break
        except Exception: pass
        time.sleep(0.5)
    print("10.12 controller killed; answering again after", back, [l[:220] for l in lines("launch_r2.log") if "cyborg_controller" in l and ("stopped" in l or "resumed" in l or "again" in l)][-3:])
    event("music_play"); print("10.12 music_play after the restart -> music after", wait_state("music", 15) or state())
finally:
    cleanup()
