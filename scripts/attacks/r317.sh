# 3.17: import-ics of 50,000 events into the database of a running real-time robot, probing /api/status
C=${C:-"/work/main/.venv/bin/python -m cyborg.cli"}; PY=${PY:-/work/main/.venv/bin/python}
rm -rf d317; $C sim --data-dir d317 --port 18851 > s317.log 2>&1 & S=$!
for i in $(seq 300); do grep -q "dashboard and API" s317.log && break; sleep 0.5; done
$PY probe.py 18851 100000 0.05 > p317.out & PR=$!
s=$(date +%s.%N)
$C db --db d317/navigation.db import-ics huge50k.ics --default-location cafeteria 2>&1 | tail -2
echo "import took $(python3 -c "print(round($(date +%s.%N)-$s,1))") s"
sleep 5; kill $PR; wait $PR 2>/dev/null
curl -s -H 'Content-Type: application/json' -d '{"text":"what is happening today"}' http://127.0.0.1:18851/api/say; echo
sleep 3; curl -s 'http://127.0.0.1:18851/api/records?type=say' | python3 -c "import json,sys; print([r.get('text') for r in json.load(sys.stdin)][-2:])"
kill -TERM $S; wait $S; echo "sim exit $?"; grep -c Traceback s317.log; grep -i "warn\|error" s317.log | cut -c1-200 | head -5
cat p317.out
