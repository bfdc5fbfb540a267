"""``core.warmup.warm_up`` loads every kernel a trial uses: after it, a whole trial (simulated
station and the station on a memq:// wire) compiles nothing new, so no control tick on a wire
stalls on a kernel's first load."""

from __future__ import annotations

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent(
    """
    from numba.core.registry import CPUDispatcher
    from drake_disamb.core import _kernels
    from drake_disamb.core.warmup import warm_up

    def signatures():
        return {n: set(d.signatures) for n, d in vars(_kernels).items() if isinstance(d, CPUDispatcher)}

    warm_up()
    before = signatures()
    from drake_disamb.builder import build_shared_control_diagram
    import dataclasses
    from drake_disamb.config import load_scenario
    from drake_disamb.station.backends import InProcessLcm
    from drake_disamb.trial import run_trial

    reaching = load_scenario("reaching")
    run_trial(dataclasses.replace(reaching, duration=4.0), progress=False)
    pouring = load_scenario("pouring", {"interface": "joystick", "paradigm": "manual", "duration": 4.0})
    pouring = dataclasses.replace(pouring, station=InProcessLcm(lcm_url="memq://"))
    run_trial(build_shared_control_diagram(pouring), progress=False)
    after = signatures()
    new = {n: sorted(map(str, after[n] - before[n])) for n in after if after[n] - before[n]}
    print("NEW", new)
    """
)


def test_a_trial_after_warm_up_compiles_no_kernel() -> None:
    done = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    line = [ln for ln in done.stdout.splitlines() if ln.startswith("NEW")][-1]
    assert line == "NEW {}", f"kernels compiled after warm_up (add them to warm_up): {line}"
