#!/usr/bin/env python3
"""Cancel latency of `isoray render` (or `raster`) (issue: Ctrl-C stops any long command
within 0.2 s, exit code 130, leaving any existing output untouched).

Starts `isoray render SCENE --width 1280 --height 720` N times, sends SIGINT
(what Ctrl-C sends) at a random moment of the render, and measures the time
from the signal to the process's exit. Checks the exit code (130) and that
the output file, written before the run, is byte for byte what it was.

    python3 bench/live/cancel.py [--isoray target/release/isoray] [--scene examples/showcase.toml] [--runs 10]
    python3 bench/live/cancel.py --command raster --scene examples/reflections.toml -- --shadows envmap --reflections abuffer-map
"""
import argparse
import os
import random
import signal
import statistics
import subprocess
import sys
import tempfile
import time


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--isoray", default="target/release/isoray")
    ap.add_argument("--scene", default="examples/showcase.toml")
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--command", default="render", help="render or raster")
    ap.add_argument("extra", nargs="*", help="more arguments for the command")
    a = ap.parse_args()
    rnd = random.Random(a.seed)
    out = os.path.join(tempfile.mkdtemp(), "out.png")
    sentinel = b"an earlier output that Ctrl-C must not touch"
    args = [a.isoray, a.command, a.scene, "--width", "1280", "--height", "720", "-q", "-o", out] + a.extra
    # How long a whole render takes, to pick moments inside it.
    t0 = time.monotonic()
    subprocess.run(args, check=True)
    full = time.monotonic() - t0
    latencies = []
    i = 0
    while len(latencies) < a.runs and i < 3 * a.runs:
        i += 1
        with open(out, "wb") as f:
            f.write(sentinel)
        at = rnd.uniform(0.05, 0.8) * full
        p = subprocess.Popen(args)
        time.sleep(at)
        if p.poll() is not None:
            print(f"run {i}: finished before the signal at {at:.2f} s", file=sys.stderr)
            continue
        sent = time.monotonic()
        p.send_signal(signal.SIGINT)
        code = p.wait()
        lat = time.monotonic() - sent
        with open(out, "rb") as f:
            intact = f.read() == sentinel
        print(f"run {i}: signal at {at:.2f} s of {full:.2f} s, exit {code}, {lat * 1000:.1f} ms, output intact: {intact}")
        if code != 130 or not intact:
            print("FAIL", file=sys.stderr)
            sys.exit(1)
        latencies.append(lat)
    print(f"cancel latency: median {statistics.median(latencies) * 1000:.1f} ms, max {max(latencies) * 1000:.1f} ms over {len(latencies)} runs (full render {full:.2f} s)")


if __name__ == "__main__":
    main()
