# 3.9: disk full while the robot runs: 1 MB tmpfs data folder, fill it, post 31 emotion values, free it
C="/work/main/.venv/bin/python -m cyborg.cli"; J='Content-Type: application/json'
mkdir -p /tmp/h4/mnt/df && mount -t tmpfs -o size=1m tmpfs /tmp/h4/mnt/df
$C sim --data-dir /tmp/h4/mnt/df/d --port 18769 --no-record > df.log 2>&1 & P=$!
for i in $(seq 120); do grep -q "dashboard and API" df.log && break; sleep 1; done
dd if=/dev/zero of=/tmp/h4/mnt/df/fill bs=4k 2>/dev/null
for i in $(seq 31); do curl -s -o /dev/null -H "$J" -d "{\"pleasure\": 0.$((i%9)), \"arousal\": 0.1, \"dominance\": 0.2}" http://127.0.0.1:18769/api/emotion/values; done
sleep 2
echo "full:"; curl -s -H "$J" -d '{"pleasure": 0.9, "arousal": 0.1, "dominance": 0.2}' http://127.0.0.1:18769/api/emotion/values; echo
curl -s http://127.0.0.1:18769/api/status | python3 -c "import json,sys; d=json.load(sys.stdin); print('storage', d['storage'])"
rm /tmp/h4/mnt/df/fill; sleep 3
curl -s -H "$J" -d '{"pleasure": 0.3, "arousal": 0.1, "dominance": 0.2}' http://127.0.0.1:18769/api/emotion/values; echo
sleep 3; curl -s http://127.0.0.1:18769/api/status | python3 -c "import json,sys; d=json.load(sys.stdin); print('after freeing: storage', d['storage'], 'P', d['pleasure'])"
kill -TERM $P; wait $P; echo "tracebacks: $(grep -c Traceback df.log)"; grep "WARNING cyborg.storage\|again" df.log | cut -c1-220
umount /tmp/h4/mnt/df
