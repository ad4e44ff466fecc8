#!/usr/bin/env python3
"""Writes the recorded takes of the MIDI demos (midi-scale.mid, midi-twist.mid)
beside this script: knob sweeps as a performer would play them on an Akai
LPD8 (knobs send CC 1-8 on channel 1), so the demos render without the
controller:

    isoray render examples/realtime/midi-scale.toml --midi examples/realtime/midi-scale.mid \
        --frames 0.. -o midi-scale.gif

Standard MIDI file, format 0, 480 ticks a beat at 120 beats a minute (960
ticks a second). Python's standard library only.
"""
import math
import pathlib
import struct

HERE = pathlib.Path(__file__).resolve().parent
TICKS_PER_SECOND = 960


def vlq(n):
    out = [n & 0x7F]
    n >>= 7
    while n:
        out.append(0x80 | (n & 0x7F))
        n >>= 7
    return bytes(reversed(out))


def smf(events):
    """events: (seconds, status, data1, data2) in any order."""
    body = bytearray()
    body += vlq(0) + b"\xff\x51\x03" + (500000).to_bytes(3, "big")  # tempo: 120 bpm
    last = 0
    for t, status, a, b in sorted(events):
        tick = round(t * TICKS_PER_SECOND)
        body += vlq(tick - last) + bytes([status, a, b])
        last = tick
    body += vlq(0) + b"\xff\x2f\x00"
    header = b"MThd" + struct.pack(">IHHH", 6, 0, 1, 480)
    return header + b"MTrk" + struct.pack(">I", len(body)) + bytes(body)


def sweep(cc, start, length, phase, rate=20):
    """A knob turned smoothly from the middle, up and down, `rate` messages a second."""
    out = []
    n = int(length * rate)
    last = None
    for i in range(n + 1):
        t = start + i / rate
        v = round(63.5 + 63.5 * math.sin(2 * math.pi * (i / n) + phase))
        v = max(0, min(127, v))
        if v != last:
            out.append((t, 0xB0, cc, v))  # control change, channel 1
            last = v
    return out


def main():
    # midi-scale: five knobs, one a primitive, each swept in turn, overlapping.
    scale = []
    for k in range(5):
        scale += sweep(1 + k, 0.4 * k, 2.4, 0.0)
    (HERE / "midi-scale.mid").write_bytes(smf(scale))
    # midi-twist: knob 1 twists everything back and forth; knob 2 lifts the sphere.
    twist = sweep(1, 0.0, 4.0, 0.0) + sweep(2, 1.0, 2.5, math.pi / 2)
    (HERE / "midi-twist.mid").write_bytes(smf(twist))


if __name__ == "__main__":
    main()
