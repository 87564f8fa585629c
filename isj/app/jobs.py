"""Slow work of ``isj app`` in a child process: the FE solve of one design, the surrogate's build.

A :class:`Job` starts ``python -m isj.app.jobs ...`` (or ``isj rom build``) in its own process
group, reads its output lines in a thread (the page shows the last as progress) and can be
stopped: :meth:`Job.cancel` ends the whole group, so a closed page or a stopped server leaves
no process behind (:func:`cancel_all` runs at exit).

The FE job goes through the FE result cache (:func:`isj.caches.fe_cache_dir`, honouring
``$ISJ_FE_CACHE_DIR``) with :func:`isj.calibration.runner.run_designs`, so a design solved
once, here or by any other command with the same settings, comes back from the cache.
"""

from __future__ import annotations

import atexit
import json
import os
import signal
import subprocess
import sys
import threading
import time
import weakref

#: Mesh resolutions the FE job takes: those of ``isj fem solve --resolution`` (isj._cli._common).
RESOLUTION_RANGE = (0.1, 8.0)

#: Prefix of the line that carries a job's result (JSON).
RESULT_PREFIX = "result: "

_RUNNING: weakref.WeakSet = weakref.WeakSet()


class Job:
    """A child process whose output lines are collected; ``result`` is its JSON result line.

    Parameters
    ----------
    argv : the command (a list of strings)
    """

    def __init__(self, argv: list[str]):
        self.started = time.monotonic()
        self.lines: list[str] = []
        self.result: dict | None = None
        self.cancelled = False
        self._proc = subprocess.Popen(
            argv,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            bufsize=1,
            start_new_session=True,  # its own process group: cancel() ends its children too
        )
        _RUNNING.add(self)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self._proc.stdout:
            line = line.rstrip("\n")
            if line.startswith(RESULT_PREFIX):
                try:
                    self.result = json.loads(line[len(RESULT_PREFIX) :])
                except ValueError:
                    self.lines.append(line)
            elif line.strip():
                self.lines.extend(p for p in line.split("\r") if p.strip())
        self._proc.wait()

    @property
    def pid(self) -> int:
        return self._proc.pid

    @property
    def done(self) -> bool:
        """The process has exited and its output is read."""
        return self._proc.poll() is not None and not self._reader.is_alive()

    @property
    def returncode(self) -> int | None:
        return self._proc.returncode

    @property
    def elapsed_s(self) -> float:
        return time.monotonic() - self.started

    @property
    def last_line(self) -> str:
        return self.lines[-1] if self.lines else ""

    def cancel(self, wait_s: float = 3.0) -> None:
        """End the process group (SIGTERM, then SIGKILL after ``wait_s``); nothing if it has exited."""
        if self._proc.poll() is not None:
            return
        self.cancelled = True
        for sig in (signal.SIGTERM, signal.SIGKILL):
            try:
                os.killpg(self._proc.pid, sig)
            except ProcessLookupError:
                return
            try:
                self._proc.wait(wait_s)
                return
            except subprocess.TimeoutExpired:
                continue


def cancel_all() -> None:
    """Cancel every job still running (at exit, and when the server stops)."""
    for job in list(_RUNNING):
        job.cancel()


atexit.register(cancel_all)


def fe_job(payload: dict) -> Job:
    """Start the FE solve of ``payload`` (:func:`_fe_main`'s keys) in a child process."""
    return Job([sys.executable, "-m", "isj.app.jobs", "fe", json.dumps(payload)])


def rom_build_job(order: int, resolution: float) -> Job:
    """Start ``isj rom build`` of the calibration's mesh (the default geometry) in a child process."""
    return Job(
        [
            sys.executable,
            "-m",
            "isj",
            "rom",
            "build",
            "--order",
            str(order),
            "--resolution",
            f"{resolution:g}",
        ]
    )


def _fe_main(payload: dict) -> int:
    """The FE job; ``payload``: ``moduli`` (Pa), ``geometry`` (m), ``joint``, ``pressure_pa``, ``order``,
    ``resolution``."""
    from isj.caches import fe_cache_dir
    from isj.calibration.runner import run_designs
    from isj.design import Geometry
    from isj.errors import InvalidParameter
    from isj.fem.batch import evaluate_design, fe_settings
    from isj.fem.sizing import check_mesh_size

    order, resolution = int(payload["order"]), float(payload["resolution"])
    lo, hi = RESOLUTION_RANGE
    if not lo <= resolution <= hi:
        raise InvalidParameter(f"resolution = {resolution:g}: must be in [{lo:g}, {hi:g}]")
    geometry = Geometry(**payload["geometry"]) if payload.get("geometry") else None
    check_mesh_size(geometry, order, resolution)  # refuses, before meshing, a model over the memory limit
    print(f"FE: P{order} mesh at resolution {resolution:g}, meshing and solving", flush=True)
    settings = fe_settings(
        order=order,
        resolution=resolution,
        geometry=payload["geometry"],
        pressure_pa=float(payload["pressure_pa"]),
        joint=payload["joint"],
    )
    t0 = time.perf_counter()
    (record,) = run_designs(
        [dict(payload["moduli"])], evaluate_design, settings, fe_cache_dir(), max_workers=0, progress=False
    )
    res = record["result"]
    out = {k: res[k] for k in ("alpha_rad", "beta_rad", "n_dofs")} | {"seconds": time.perf_counter() - t0}
    print(RESULT_PREFIX + json.dumps(out), flush=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m isj.app.jobs fe JSON``: one job, its result as the last line."""
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 2 or argv[0] != "fe":
        print("usage: python -m isj.app.jobs fe JSON", file=sys.stderr)
        return 2
    # Job.cancel() sends SIGTERM: exit through Python so that the finally blocks of the cache's
    # atomic writes remove their temporary files (the default action ends the process at once)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(128 + signal.SIGTERM))
    try:
        return _fe_main(json.loads(argv[1]))
    except (ValueError, RuntimeError) as exc:  # bad settings, a failed mesh or solve: one line
        print(f"error: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}", flush=True)
        return 1


if __name__ == "__main__":
    sys.exit(main())
