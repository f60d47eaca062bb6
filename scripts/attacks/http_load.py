"""http_load.py PORT MODE: conc (200 clients 8 s: half GET /api/status, half POST /api/event) |
slowloris N S (N sockets send a header line a second for S s; status probes) | ws N (N websocket readers) |
wsburst N (N websockets at the same instant)."""
import asyncio, json, socket, sys, time
import aiohttp
PORT, MODE = int(sys.argv[1]), sys.argv[2]
URL = f"http://127.0.0.1:{PORT}"
async def probe(s, res):
    t = time.monotonic()
    try:
        async with s.get(URL + "/api/status", timeout=aiohttp.ClientTimeout(total=10)) as r:
            await r.read(); res.append((r.status, time.monotonic() - t))
    except Exception as e:
        res.append((type(e).__name__, time.monotonic() - t))
async def conc():
    counts, lat = {}, []
    async with aiohttp.ClientSession(connector=aiohttp.TCPConnector(limit=200)) as s:
        stop = time.monotonic() + 8
        async def c(i):
            while time.monotonic() < stop:
                t = time.monotonic()
                try:
                    if i % 2:
                        async with s.get(URL + "/api/status") as r: await r.read(); st = r.status
                    else:
                        async with s.post(URL + "/api/event", data=json.dumps({"name": "music_play"}), headers={"Content-Type": "application/json"}) as r: await r.read(); st = r.status
                except Exception as e: st = type(e).__name__
                counts[st] = counts.get(st, 0) + 1; lat.append(time.monotonic() - t)
        await asyncio.gather(*(c(i) for i in range(200)))
    lat.sort()
    print(f"4.8 conc: {sum(counts.values())} requests {counts} p50 {lat[len(lat)//2]*1000:.0f} ms p99 {lat[int(len(lat)*.99)]*1000:.0f} ms")
async def slowloris(n, secs):
    socks = []
    for i in range(n):
        try:
            so = socket.create_connection(("127.0.0.1", PORT), timeout=2); so.setblocking(False)
            so.send(b"GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\n"); socks.append(so)
        except OSError: pass
    res = []
    async with aiohttp.ClientSession() as s:
        end = time.monotonic() + secs
        while time.monotonic() < end:
            for so in socks:
                try: so.send(b"X-a: b\r\n")
                except OSError: pass
            await probe(s, res); await asyncio.sleep(0.5)
    closed = 0
    for so in socks:
        try:
            if so.recv(1) == b"": closed += 1
            else: closed += 1
        except BlockingIOError: pass
        except OSError: closed += 1
    ok = sum(1 for st, _ in res if st == 200)
    print(f"4.9 slowloris: {len(socks)} opened, {closed} closed by the server; probes {ok}/{len(res)} 200, worst {max(t for _, t in res)*1000:.0f} ms")
async def ws(n, burst):
    async with aiohttp.ClientSession() as s:
        async def one():
            try:
                w = await s.ws_connect(URL + "/api/ws"); return w
            except Exception as e: return e
        if burst: got = await asyncio.gather(*(one() for _ in range(n)))
        else: got = [await one() for _ in range(n)]
        ok = [g for g in got if not isinstance(g, Exception)]
        res = []; await probe(s, res)
        print(f"4.{'18' if burst else '11'} ws{' burst' if burst else ''}: {len(ok)} accepted of {n}; refusals {set(str(g)[:60] for g in got if isinstance(g, Exception))}; status {res}")
        for w in ok: await w.close()
async def say2k():
    counts, lat = {}, []
    text = json.dumps({"text": "where is the cafeteria " + "a" * 1970})
    async with aiohttp.ClientSession(connector=aiohttp.TCPConnector(limit=100)) as s:
        stop = time.monotonic() + 8
        async def c():
            while time.monotonic() < stop:
                try:
                    async with s.post(URL + "/api/say", data=text, headers={"Content-Type": "application/json"}) as r: await r.read(); st = r.status
                except Exception as e: st = type(e).__name__
                counts[st] = counts.get(st, 0) + 1
        async def probes():
            while time.monotonic() < stop:
                res = []; await probe(s, res); lat.append(res[0][1]); await asyncio.sleep(0.2)
        await asyncio.gather(probes(), *(c() for _ in range(100)))
    lat.sort()
    print(f"4.20 say flood: {sum(counts.values())} says {counts} ({sum(counts.values())/8:.0f}/s); status p50 {lat[len(lat)//2]*1000:.0f} ms, max {lat[-1]*1000:.0f} ms")
async def wsstall(n):
    async with aiohttp.ClientSession() as s:
        ws = [await s.ws_connect(URL + "/api/ws") for _ in range(n)]  # never read
        text = json.dumps({"text": "hello there"})
        for _ in range(500):
            async with s.post(URL + "/api/say", data=text, headers={"Content-Type": "application/json"}) as r: await r.read()
        res = []; await probe(s, res)
        print(f"4.12 {n} stalled websockets + 500 says: status {res}")
        for w in ws: await w.close()
async def wsspam():
    async with aiohttp.ClientSession() as s:
        w = await s.ws_connect(URL + "/api/ws"); n = 0; end = time.monotonic() + 6
        while time.monotonic() < end:
            for _ in range(1000): await w.send_str("x")
            n += 1000
        try:
            await w.send_bytes(b"x" * 4_000_000); msg = await w.receive(timeout=10); close = (msg.type, w.close_code)
        except Exception as e: close = type(e).__name__
        res = []; await probe(s, res)
        print(f"4.13 ws spam: {n} messages, then a 4 MB frame -> {close}; status {res}")
if MODE == "say2k": asyncio.run(say2k())
elif MODE == "wsstall": asyncio.run(wsstall(int(sys.argv[3])))
elif MODE == "wsspam": asyncio.run(wsspam())
elif MODE == "conc": asyncio.run(conc())
elif MODE == "slowloris": asyncio.run(slowloris(int(sys.argv[3]), float(sys.argv[4])))
else: asyncio.run(ws(int(sys.argv[3]), MODE == "wsburst"))
