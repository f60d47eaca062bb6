"""flood.py URL SECONDS CLIENTS: CLIENTS keep-alive clients POST /api/event (stubborn_go, music_play, stop) for SECONDS; then a person's music_play, and the counters."""
import asyncio, json, sys, time
import aiohttp
URL, SECONDS, CLIENTS = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
J = {"Content-Type": "application/json"}
async def client(session, stop, counts, i):
    names = ["stubborn_go", "music_play", "stop"]
    n = 0
    while time.monotonic() < stop:
        try:
            async with session.post(URL + "/api/event", data=json.dumps({"name": names[(i + n) % 3]}), headers=J) as r:
                await r.read(); counts[r.status] = counts.get(r.status, 0) + 1
        except Exception as e:
            counts[type(e).__name__] = counts.get(type(e).__name__, 0) + 1
        n += 1
async def main():
    counts = {}
    async with aiohttp.ClientSession(connector=aiohttp.TCPConnector(limit=CLIENTS)) as s:
        stop = time.monotonic() + SECONDS
        await asyncio.gather(*(client(s, stop, counts, i) for i in range(CLIENTS)))
        t = time.monotonic()
        async with s.get(URL + "/api/health") as r:
            st = await r.json()
        print("posts", counts, "health after flood in %.0f ms" % ((time.monotonic() - t) * 1000))
        print("stats", json.dumps(st["stats"]))
        await asyncio.sleep(1)
        t0 = time.monotonic()
        async with s.post(URL + "/api/event", data=json.dumps({"name": "stubborn_go"}), headers=J) as r:
            await r.read()
        async with s.post(URL + "/api/event", data=json.dumps({"name": "music_play"}), headers=J) as r:
            await r.read()
        while time.monotonic() - t0 < 60:
            async with s.get(URL + "/api/status") as r:
                state = (await r.json())["state"]
            if state == "music":
                print("person's stubborn_go + music_play -> music after %.1f s" % (time.monotonic() - t0)); break
            await asyncio.sleep(0.2)
        else:
            print("person's music_play NOT taken within 60 s; state", state)
asyncio.run(main())
