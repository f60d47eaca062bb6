"""probe.py PORT SECONDS [INTERVAL]: GET /api/status every INTERVAL s until SIGTERM or SECONDS; longest wait."""
import signal, sys, time, urllib.request
port, secs = int(sys.argv[1]), float(sys.argv[2]); step = float(sys.argv[3]) if len(sys.argv) > 3 else 0.05
end = time.monotonic() + secs; waits = []; bad = 0; stop = [False]
signal.signal(signal.SIGTERM, lambda *a: stop.__setitem__(0, True))
while time.monotonic() < end and not stop[0]:
    t = time.monotonic()
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/status", timeout=60) as r: r.read()
    except Exception as e:
        bad += 1
    waits.append(time.monotonic() - t); time.sleep(step)
waits.sort()
print(f"probes {len(waits)}, failed {bad}, median {waits[len(waits)//2]*1000:.0f} ms, p99 {waits[int(len(waits)*.99)]*1000:.0f} ms, longest {waits[-1]*1000:.0f} ms", flush=True)
