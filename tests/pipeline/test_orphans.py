"""Worker processes of parallel_map end when their parent is killed (a scheduler's time
limit, kill -9), instead of going on as orphans."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

SCRIPT = textwrap.dedent("""
    import sys, time
    from fallgen.pipeline.executor import parallel_map

    def init():
        pass

    def work(u):
        import os
        print(os.getpid(), flush=True)
        time.sleep(60)
        return u

    if __name__ == "__main__":
        for _ in parallel_map(work, [0, 1], init, (), 2):
            pass
""")


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_workers_end_when_the_parent_is_killed(tmp_path):
    script = tmp_path / "job.py"
    script.write_text(SCRIPT)
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True,
                            cwd=tmp_path)
    try:
        workers = [int(proc.stdout.readline()) for _ in range(2)]
        assert all(_alive(w) for w in workers)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
        deadline = time.monotonic() + 15
        while any(_alive(w) for w in workers) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not any(_alive(w) for w in workers)
    finally:
        if proc.poll() is None:
            proc.kill()
