# 2.19: kill -9 of a 50,000-event import (python gen_ics.py 50000 huge50k.ics) at the given seconds, then
# at the given sizes of its write-ahead log (inside the one write): all or nothing? k9import.sh "3 8 14 19 22" "200000 2000000"
C=${C:-"/work/main/.venv/bin/python -m cyborg.cli"}
for t in $1; do
  rm -f K.db K.db-wal K.db-shm
  $C db --db K.db locations list > /dev/null 2>&1   # a fresh database with its places
  $C db --db K.db import-ics huge50k.ics --default-location cafeteria > k.out 2>&1 & P=$!
  sleep $t; kill -9 $P 2>/dev/null; wait $P 2>/dev/null; rc=$?
  echo "kill at $t s (exit $rc): integrity $(sqlite3 K.db 'pragma integrity_check'), events $(sqlite3 K.db 'select count(*) from events'), then: $($C db --db K.db events list --at now 2>&1 | tail -1 | cut -c1-100)"
done
for n in $2; do
  rm -f K.db K.db-wal K.db-shm
  $C db --db K.db locations list > /dev/null 2>&1
  $C db --db K.db import-ics huge50k.ics --default-location cafeteria > k.out 2>&1 & P=$!
  s=$(date +%s.%N)
  while kill -0 $P 2>/dev/null && [ $(stat -c %s K.db-wal 2>/dev/null || echo 0) -lt $n ]; do sleep 0.01; done
  w=$(stat -c %s K.db-wal 2>/dev/null); kill -9 $P 2>/dev/null; wait $P 2>/dev/null; rc=$?
  echo "kill with the WAL at $w bytes after $(python3 -c "print(round($(date +%s.%N)-$s,1))") s (exit $rc): integrity $(sqlite3 K.db 'pragma integrity_check'), events $(sqlite3 K.db 'select count(*) from events')"
done
