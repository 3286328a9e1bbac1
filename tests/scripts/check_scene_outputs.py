#!/usr/bin/env python3
"""scripts/scene-outputs: two runs of the same scenes compare equal; a changed result is found, a
changed time or memory figure is not.

    check_scene_outputs.py OBS SCENE_OUTPUTS WORKDIR
"""
import json
import shutil
import subprocess
import sys
from pathlib import Path


def main() -> int:
    obs, tool, work = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
    if work.exists():
        shutil.rmtree(work)
    scenes = "cantilever,twobody_patch"
    for name in ("a", "b"):
        subprocess.run([sys.executable, str(tool), "run", str(work / name), "--obs", str(obs), "--scenes", scenes],
                       check=True, stderr=subprocess.DEVNULL)
    compare = [sys.executable, str(tool), "compare", str(work / "a"), str(work / "b")]
    failures = []
    if subprocess.run(compare, capture_output=True).returncode != 0:
        failures.append("two runs of the same scenes differ")
    summary = work / "b" / "cantilever" / "summary.json"
    data = json.loads(summary.read_text())
    data["times"]["total_s"] = data["times"]["total_s"] + 1.0  # a cost field: ignored
    summary.write_text(json.dumps(data))
    if subprocess.run(compare, capture_output=True).returncode != 0:
        failures.append("a changed time was reported as a difference")
    data["max_displacement"] = data["max_displacement"] * (1 + 1e-15) + 1e-300  # a result: found
    summary.write_text(json.dumps(data))
    out = subprocess.run(compare, capture_output=True, text=True)
    if out.returncode != 1 or "cantilever/summary.json" not in out.stdout:
        failures.append("a changed result was not reported: " + out.stdout)
    vtu = next((work / "b" / "twobody_patch").glob("*.vtu"))
    vtu.write_bytes(vtu.read_bytes() + b" ")
    out = subprocess.run(compare, capture_output=True, text=True)
    if vtu.name not in out.stdout:
        failures.append("a changed .vtu was not reported: " + out.stdout)
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
