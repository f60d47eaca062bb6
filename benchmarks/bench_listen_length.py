"""Cutting a recording into utterances: time against the recording's length (issue 31, item 6).

Usage: .venv/bin/python benchmarks/bench_listen_length.py [--minutes 1,2,4,8]

`cyborg listen --wav` of an hour printed nothing after 400 s: each 30-ms frame the end-pointer
judged copied the rest of the recording (quadratic). For each length this times the robot's cutter
(``Utterances``, fed one second at a time as ``SpeechInput.listen_to`` does, and fed the whole
recording at once) beside the floor, pocketsphinx's end-pointer called directly on each frame of a
memoryview, in the same run. The audio is low noise with a loud burst every 30 s. Linear: the
seconds per minute of audio stay flat as the recording grows. Median of 3 per figure.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import machine_line

from cyborg.hearing.recogniser import SAMPLE_RATE, Utterances


def recording(minutes: float) -> bytes:
    rng = np.random.default_rng(7)
    samples = rng.normal(0, 30, int(minutes * 60 * SAMPLE_RATE))
    for start in range(0, len(samples), 30 * SAMPLE_RATE):
        burst = slice(start + 5 * SAMPLE_RATE, start + 7 * SAMPLE_RATE)
        samples[burst] += 6000 * np.sin(np.arange(len(samples[burst])) * 0.07)
    return bytes(np.clip(samples, -32768, 32767).astype("<i2").tobytes())


def by_seconds(audio: bytes) -> int:
    cutter = Utterances()
    found = 0
    for at in range(0, len(audio), 2 * SAMPLE_RATE):
        found += sum(1 for _ in cutter.feed(audio[at : at + 2 * SAMPLE_RATE]))
    return found + sum(1 for _ in cutter.finish())


def at_once(audio: bytes) -> int:
    cutter = Utterances()
    return sum(1 for _ in cutter.feed(audio)) + sum(1 for _ in cutter.finish())


def floor(audio: bytes) -> int:
    from pocketsphinx import Endpointer

    endpointer = Endpointer(window=0.3, ratio=0.9, vad_mode=2, sample_rate=SAMPLE_RATE)
    size = int(endpointer.frame_bytes)
    view = memoryview(audio)
    found = 0
    for at in range(0, len(audio) - size + 1, size):
        if endpointer.process(view[at : at + size]) is not None and not endpointer.in_speech:
            found += 1
    return found


def median_seconds(work: Callable[[bytes], int], audio: bytes) -> tuple[float, int]:
    times, found = [], 0
    for _ in range(3):
        started = time.perf_counter()
        found = work(audio)
        times.append(time.perf_counter() - started)
    return statistics.median(times), found


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--minutes", default="1,2,4,8")
    args = parser.parse_args()
    print(machine_line())
    print("minutes  by-second s (s/min)  at-once s (s/min)  floor s (s/min)  utterances")
    for minutes in (float(m) for m in args.minutes.split(",")):
        audio = recording(minutes)
        seconds, found = median_seconds(by_seconds, audio)
        whole, _ = median_seconds(at_once, audio)
        base, _ = median_seconds(floor, audio)
        print(
            f"{minutes:7g}  {seconds:6.2f} ({seconds / minutes:.3f})  {whole:6.2f} ({whole / minutes:.3f})  "
            f"{base:6.2f} ({base / minutes:.3f})  {found}"
        )


if __name__ == "__main__":
    main()
