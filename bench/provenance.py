"""What made a result file: when, on which machine, by which command, with which code. Written
beside the file (``X.json`` -> ``X.provenance.json``) by the make target that made it, read by
``bench/docs_report.py`` to say under every generated figure where it came from.

    python bench/provenance.py build/loudness.json make loudness
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def memory_gib() -> float | None:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                return round(int(line.split()[1]) / 2 ** 20, 1)
    except OSError:
        pass
    return None


def machine() -> dict:
    """The CPU model, the cores this process may use, the memory."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    return {"cpu": cpu_model(), "cores": cores, "memory_gib": memory_gib(),
            "system": f"{platform.system()} {platform.machine()}",
            "python": platform.python_version()}


def commit() -> str | None:
    """The checkout's commit (``+`` when it has uncommitted changes), or None outside git."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short=10", "HEAD"], cwd=REPO,
                              capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=REPO, capture_output=True, text=True).stdout.strip()
        return head + ("+" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return None


def sidecar(path: Path) -> Path:
    """``X.json`` -> ``X.provenance.json``."""
    path = Path(path)
    return path.with_name(path.name.removesuffix(".json") + ".provenance.json")


def record(path: Path, command: str) -> dict:
    sys.path.insert(0, str(REPO / "src"))
    import fallgen

    return {"file": str(path), "command": command,
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "machine": machine(), "fallgen": fallgen.__version__, "commit": commit()}


def write(path: Path, command: str) -> Path:
    out = sidecar(path)
    out.write_text(json.dumps(record(path, command), indent=1) + "\n")
    return out


def main() -> None:
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    path = Path(sys.argv[1])
    if not path.is_file():
        sys.exit(f"provenance: {path}: no such file (the command that makes it failed?)")
    print(f"-> {write(path, ' '.join(sys.argv[2:]))}")


if __name__ == "__main__":
    main()
