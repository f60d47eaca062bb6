"""mkhour.py MINUTES OUT: a 16 kHz mono WAV with a question every 30 s (espeak-ng), silence between."""
import subprocess, sys, wave, io
import numpy as np
from scipy.signal import resample_poly
minutes, out = float(sys.argv[1]), sys.argv[2]
lines = ["where is the cafeteria", "take me to the library", "what is happening today", "hello robot"]
clips = []
for t in lines:
    raw = subprocess.run(["espeak-ng", "--stdout", t], capture_output=True, check=True).stdout
    with wave.open(io.BytesIO(raw)) as w:
        a = np.frombuffer(w.readframes(w.getnframes()), dtype=np.int16).astype(np.float64); rate = w.getframerate()
    clips.append(np.clip(resample_poly(a, 16000, rate), -32768, 32767).astype(np.int16))
seg = 30 * 16000; n = int(minutes * 2)
with wave.open(out, "wb") as w:
    w.setnchannels(1); w.setsampwidth(2); w.setframerate(16000)
    for i in range(n):
        buf = np.zeros(seg, dtype=np.int16); c = clips[i % len(clips)]; buf[16000:16000 + len(c)] = c
        w.writeframes(buf.tobytes())
