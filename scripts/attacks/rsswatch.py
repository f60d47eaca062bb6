"""rsswatch.py OUT LIMIT_S cmd...: run cmd, sample RSS (MB) of its process tree every 5 s into OUT; SIGTERM after LIMIT_S."""
import os, signal, subprocess, sys, time
out, limit, cmd = sys.argv[1], float(sys.argv[2]), sys.argv[3:]
def tree_rss(pid):
    rows = {}
    for p in os.listdir('/proc'):
        if p.isdigit():
            try:
                st = open(f'/proc/{p}/stat').read().rsplit(')', 1)[1].split()
                rss = int(st[21]) * 4096 / 1e6
                rows[int(p)] = (int(st[1]), rss)
            except OSError:
                pass
    res, todo = {}, [pid]
    while todo:
        q = todo.pop()
        if q in rows:
            res[q] = rows[q][1]
        todo += [c for c, (pp, _) in rows.items() if pp == q]
    return res
t0 = time.monotonic()
proc = subprocess.Popen(cmd, stdout=open(out + '.log', 'w'), stderr=subprocess.STDOUT, start_new_session=True)
peak = 0.0
with open(out, 'w') as f:
    while proc.poll() is None:
        r = tree_rss(proc.pid)
        tot = sum(r.values()); peak = max(peak, tot)
        f.write(f"{time.monotonic()-t0:.0f} {tot:.1f} " + " ".join(f"{v:.1f}" for v in r.values()) + "\n"); f.flush()
        if time.monotonic() - t0 > limit:
            os.killpg(proc.pid, signal.SIGTERM); proc.wait(60); break
        time.sleep(5)
print(f"rc={proc.returncode} wall={time.monotonic()-t0:.0f}s peak_tree_rss={peak:.0f}MB")
