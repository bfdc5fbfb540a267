"""Helpers shared by the test files: the CLI in a child process, stopped by a signal, the
recording-screenshot script of ``diagrams/`` (its Chromium flags serve the browser tests too), and
quaternion helpers the tests use as references (normalising without checks, the rotation matrix,
a pose moved by a twist)."""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import io
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core._kernels import _normalize_quaternion_rows
from drake_disamb.core.geometry import (
    check_vectors,
    normalized_quaternions,
    quat_from_rotvec_unchecked,
    quat_multiply_unchecked,
)
from drake_disamb.study.data.records import TrialRecord

REPO = Path(__file__).resolve().parents[1]
SRC = REPO / "src"


def cli_process(*argv: str) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.Popen(
        [sys.executable, "-m", "drake_disamb.cli", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


MULTICAST_HELP = (
    "UDP multicast on loopback does not work here; on Linux: `sudo ip link set lo multicast on` and "
    "`sudo ip route add 239.0.0.0/8 dev lo` (see docs/real_arm.md, The arm on LCM)"
)


def multicast_url(port: int) -> str:
    """A udpm:// URL on loopback that delivers here, or skip the test saying how to enable it."""
    import pytest
    from pydrake.lcm import DrakeLcm

    url = f"udpm://239.255.76.67:{port}?ttl=0"
    try:
        lcm = DrakeLcm(url)
    except RuntimeError as exc:
        pytest.skip(f"{MULTICAST_HELP} ({exc})")
    got: list[bytes] = []
    lcm.Subscribe("DRAKE_DISAMB_PROBE", got.append)
    lcm.Publish("DRAKE_DISAMB_PROBE", b"probe")
    lcm.HandleSubscriptions(500)
    if not got:
        pytest.skip(MULTICAST_HELP)
    return url


def wait_for_line(proc: subprocess.Popen, text: str, timeout: float) -> list[str]:
    """Lines of ``proc``'s stdout up to the first whole line (its newline read too) holding ``text``.
    Reads the pipe's bytes directly: ``readline`` on the text wrapper would buffer lines that
    ``select`` then cannot see. Unbuffered (``PYTHONUNBUFFERED``), ``print`` writes a line's text
    and its newline separately: waiting for the newline leaves nothing of the line in the pipe."""
    fd = proc.stdout.fileno()
    data = b""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        ready, _, _ = select.select([fd], [], [], 0.5)
        if ready:
            chunk = os.read(fd, 65536)
            if not chunk:
                break
            data += chunk
            lines = data.decode(errors="replace").splitlines(keepends=True)
            if any(text in line and line.endswith("\n") for line in lines):
                return lines
    proc.kill()
    err = proc.stderr.read()
    raise AssertionError(f"no line with {text!r} within {timeout} s; got {data!r}, stderr {err}")


def interrupt(
    proc: subprocess.Popen, sig: signal.Signals, ready: str = "running the trial", after: float = 3.0
) -> tuple[str, str]:
    """Send ``sig`` ``after`` seconds past the line holding ``ready``; the command must end cleanly
    with status 130. Its remaining stdout and its stderr."""
    try:
        wait_for_line(proc, ready, timeout=180)
        time.sleep(after)
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    return out, err


def screenshot_script() -> ModuleType:
    """``diagrams/recording_screenshot.py`` as a module."""
    spec = importlib.util.spec_from_file_location(
        "recording_screenshot", REPO / "diagrams" / "recording_screenshot.py"
    )
    module = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    spec.loader.exec_module(module)  # type: ignore[union-attr]
    return module


def report_compared(here: Path, there: Path) -> str:
    """``drake-disamb study report HERE --compare THERE --no-mixed-model`` in this process (it must
    succeed); its standard output."""
    from drake_disamb.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["study", "report", str(here), "--compare", str(there), "--no-mixed-model"]) == 0
    return out.getvalue()


@contextlib.contextmanager
def benchmark_module(name: str) -> Iterator[ModuleType]:
    """``benchmarks/<name>.py`` imported as a module, with ``benchmarks/`` on ``sys.path`` meanwhile
    (the scripts import their neighbour ``_host``)."""
    path = str(REPO / "benchmarks")
    sys.path.insert(0, path)
    try:
        yield importlib.import_module(name)
    finally:
        sys.path.remove(path)


def normalized_quaternions_unchecked(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`drake_disamb.core.geometry.normalized_quaternions` without its checks, on the kernel
    the core's fused paths use: ``q`` is a float array ``(..., 4)`` of finite quaternions whose
    norms are at least 1e-12 and do not overflow."""
    rows = np.ascontiguousarray(q, dtype=float).reshape(-1, 4)
    out = np.empty_like(rows)
    _normalize_quaternion_rows(rows, out)
    return out.reshape(np.shape(q))


def integrate_pose(
    position: ArrayLike, quat: ArrayLike, twist_vw: ArrayLike, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Move a pose by a constant world-frame twist for ``dt`` seconds.

    Args:
        position: ``(..., 3)`` positions (m).
        quat: ``(..., 4)`` orientations ``[qw, qx, qy, qz]``.
        twist_vw: ``(..., 6)`` twists ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s) in W.
        dt: Duration (s), finite and >= 0.

    Returns:
        ``(position + v dt, exp(w dt) (x) quat)`` broadcast together; the quaternion is unit.
    """
    if not (np.isfinite(dt) and dt >= 0):
        raise ValueError(f"dt: expected a finite number >= 0, got {dt!r}")
    p = check_vectors(position, 3, "position")
    q = normalized_quaternions(quat, "quat")
    t = check_vectors(twist_vw, 6, "twist_vw")
    new_position = p + t[..., :3] * dt
    new_quat = quat_multiply_unchecked(quat_from_rotvec_unchecked(t[..., 3:6] * dt), q)
    w, x, y, z = new_quat[..., 0:1], new_quat[..., 1:2], new_quat[..., 2:3], new_quat[..., 3:4]
    return new_position, new_quat / np.sqrt(w * w + x * x + y * y + z * z)


MODES = ("vx_vy", "vx_vz", "wx_wz", "wy")
"""The joystick's arm modes, as records name them (:func:`study_trial` cycles through them)."""


def study_trial(
    n: int, interface: str, task: str, paradigm: str, presses: int, requests: int = 0
) -> TrialRecord:
    """A trial with ``presses`` button presses (``requests`` of them requests), 3 s apart: the
    authors' cleaning keeps every one."""
    switches = presses - requests
    return TrialRecord(
        trial_id=f"t{n:03d}",
        subject=f"S{n % 3 + 1:02d}",
        interface=interface,
        task=task,
        paradigm=paradigm,
        disambiguation_method="algorithm1" if paradigm == "disambiguation" else None,
        repetition=n % 3,
        seed=n,
        start_pose=0,
        initial_mode=None,
        intended_goals=[1] if task == "reaching" else [0, 1],
        reached_goals=[1] if task == "reaching" else [0, 1],
        success=True,
        done=True,
        duration=200.0,
        completion_time=200.0,
        mode_switches=switches,
        requests=requests,
        automatic_switches=0,
        button_presses=presses,
        request_times=[60.0 + 7.0 * (n % 5) + 4.0 * i for i in range(requests)],
        mode_switch_times=[3.0 * i for i in range(switches)],
        mode_switch_modes=[MODES[i % len(MODES)] for i in range(switches)],
        automatic_switch_times=[],
        mean_alpha=0.2,
        assistance_onset=None,
        wall_time=1.0,
    )
