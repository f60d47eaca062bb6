"""gen_ics.py N OUT: N one-hour events over a year, in one VCALENDAR."""
import sys, datetime as dt
n, out = int(sys.argv[1]), sys.argv[2]
start = dt.datetime(2026, 1, 1, 8, 0)
with open(out, "w") as f:
    f.write("BEGIN:VCALENDAR\r\nVERSION:2.0\r\nPRODID:-//h5//attack//EN\r\n")
    for i in range(n):
        s = start + dt.timedelta(minutes=10 * i); e = s + dt.timedelta(hours=1)
        f.write(f"BEGIN:VEVENT\r\nUID:ev{i}@h5\r\nDTSTAMP:20260101T000000Z\r\nDTSTART:{s:%Y%m%dT%H%M%S}\r\nDTEND:{e:%Y%m%dT%H%M%S}\r\nSUMMARY:seminar {i}\r\nLOCATION:room {i % 500}\r\nEND:VEVENT\r\n")
    f.write("END:VCALENDAR\r\n")
