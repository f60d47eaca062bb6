"""mappng.py PORT PID: ten /api/map.png?max= at once, status probes meanwhile; times, sizes, peak RSS."""
import asyncio, sys, time
import aiohttp
PORT, PID = int(sys.argv[1]), int(sys.argv[2]); URL = f"http://127.0.0.1:{PORT}"
def rss():
    st = open(f"/proc/{PID}/status").read()
    return {l.split(":")[0]: l.split()[1] for l in st.splitlines() if l.startswith(("VmRSS", "VmHWM"))}
async def main():
    print("before", rss())
    async with aiohttp.ClientSession(timeout=aiohttp.ClientTimeout(total=600)) as s:
        async def png(m):
            t = time.monotonic()
            async with s.get(f"{URL}/api/map.png?max={m}") as r:
                b = await r.read(); return m, r.status, len(b), r.headers.get("Content-Type"), time.monotonic() - t
        waits = []; done = False
        async def probes():
            while not done:
                t = time.monotonic()
                async with s.get(URL + "/api/status") as r: await r.read()
                waits.append(time.monotonic() - t); await asyncio.sleep(0.1)
        pt = asyncio.create_task(probes())
        sizes = [300, 500, 640, 800, 1000, 1200, 1600, 2000, 3000, 4800]
        got = await asyncio.gather(*(png(m) for m in sizes))
        done = True; await pt
        for g in got: print(f"max={g[0]}: {g[1]} {g[3]} {g[2]:,} bytes in {g[4]:.1f} s")
        print(f"status probes {len(waits)}, longest {max(waits)*1000:.0f} ms")
        bad = []
        for q in ["max=0", "max=-5", "max=abc", "max=100000000"]:
            async with s.get(f"{URL}/api/map.png?{q}") as r: print(q, r.status, (await r.text())[:200] if r.status != 200 else len(await r.read()))
    print("after", rss())
asyncio.run(main())
