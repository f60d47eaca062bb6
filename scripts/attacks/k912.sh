# 3.12: kill -9 of cyborg sim at a random moment of its start, 10 trials, then a restart each time
C="/work/main/.venv/bin/python -m cyborg.cli"
rm -rf dk; $C sim --speed max --duration 2 --data-dir dk --port 0 >/dev/null 2>&1
ok=0
for i in $(seq 10); do
  $C sim --data-dir dk --port 0 > /dev/null 2>&1 & P=$!
  sleep $(python3 -c "import random; print(round(random.uniform(0.8, 3.0), 2))"); kill -9 $P; wait $P 2>/dev/null
  a=$(sqlite3 dk/controller.db "pragma integrity_check"); b=$(sqlite3 dk/navigation.db "pragma integrity_check")
  timeout 60 $C sim --speed max --duration 2 --data-dir dk --port 0 > r.log 2>&1; rc=$?
  w=$(grep -c "WARNING cyborg.storage" r.log)
  [ "$a" = ok ] && [ "$b" = ok ] && [ $rc = 0 ] && [ $w = 0 ] && ok=$((ok+1))
done
echo "3.12: $ok/10 intact and restarted cleanly"
