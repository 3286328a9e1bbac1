#!/usr/bin/env python3
"""Samples of the main thread taken while no other thread of the process had any: the work that
ran on one thread in a multi-threaded run (docs/performance.md#first-touch).

    perf record -F 1999 -g -o perf.data build/drivers/obs run SCENE ... -t 2
    perf script -i perf.data -F tid,time,ip,sym > perf.txt
    python3 scripts/serial_samples.py perf.txt [--window 0.01] [--top 30]

The run is cut into windows (10 ms by default). A sample of the main thread (the thread of the
first sample) counts as serial when no other thread has a sample in its window. Printed: the
number of samples, the serial ones, the serial ones by the innermost obs:: function of their stack
(the innermost frame if none), and a timeline of the serial samples in 100 ms steps.
"""
import argparse
import collections
import re
import signal

HEADER = re.compile(r"^\s*(\d+)\s+(\d+\.\d+):")


def read_samples(path):
    samples, current = [], None
    with open(path) as f:
        for line in f:
            line = line.rstrip("\n")
            if not line.strip():
                if current:
                    samples.append(current)
                current = None
                continue
            header = HEADER.match(line)
            if header:  # "TID TIME:" (perf pads the thread id with blanks)
                current = (int(header.group(1)), float(header.group(2)), [])
            elif current:
                parts = line.strip().split(None, 1)
                current[2].append(parts[1] if len(parts) > 1 else "?")
    if current:
        samples.append(current)
    return samples


def frame_name(stack):
    for frame in stack:
        if "obs::" in frame and "forRanges" not in frame:
            return frame.split("(")[0][:100]
    return stack[0][:100] if stack else "?"


def main():
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # quiet when piped into head
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("perf_script_output")
    parser.add_argument("--window", type=float, default=0.01, help="window in seconds (0.01)")
    parser.add_argument("--top", type=int, default=30, help="functions listed (30)")
    args = parser.parse_args()
    samples = read_samples(args.perf_script_output)
    if not samples:
        raise SystemExit(f"{args.perf_script_output}: no samples "
                         "(the output of perf script -F tid,time,ip,sym?)")
    main_tid, start = samples[0][0], samples[0][1]
    window = collections.defaultdict(set)
    for tid, t, _ in samples:
        window[int((t - start) / args.window)].add(tid)
    serial = [(t, stack) for tid, t, stack in samples
              if tid == main_tid and window[int((t - start) / args.window)] == {main_tid}]
    threads = len({tid for tid, _, _ in samples})
    print(f"samples {len(samples)} on {threads} threads; "
          f"serial samples of the main thread {len(serial)}")
    for name, count in collections.Counter(frame_name(s) for _, s in serial).most_common(args.top):
        print(f"{count:6d}  {name}")
    print("timeline of the serial samples (start s, samples, the three largest functions):")
    timeline = collections.defaultdict(collections.Counter)
    for t, stack in serial:
        timeline[int((t - start) / 0.1)][frame_name(stack)[:60]] += 1
    for k in sorted(timeline):
        top = ", ".join(f"{n} {c}" for n, c in timeline[k].most_common(3))
        print(f"{k / 10:5.1f} {sum(timeline[k].values()):5d}  {top}")


if __name__ == "__main__":
    main()
