"""app/hard_stop.py and app/_hard_stop.c: the status on a signal during a long C call that
holds the GIL (a MUMPS factorization), where neither Python's handlers nor the run's
watchdog thread can act before mpiexec's SIGKILL."""

from __future__ import annotations

import json
import signal
import subprocess
import sys

import pytest
from signal_support import sleep_in_a_solve
from support import CONFIGS, ROOT, read_summary, signal_when_ready

from app import hard_stop

pytestmark = pytest.mark.skipif(not hard_stop.available(),
                                reason="app/_hard_stop.c not built (no C compiler)")

HOLDS_THE_GIL = """
import ctypes, sys
from pathlib import Path
from app import hard_stop
out = Path(sys.argv[1])
hard_stop.set_provider(lambda name: (out / "summary.json", -1,
                                     ('{"status": "interrupted", "by": "%s"}' % name).encode(),
                                     f"error: interrupted by {name}\\n"))
with hard_stop.armed():
    print("ready", flush=True)
    ctypes.PyDLL(None).sleep(60)  # a C call that keeps the GIL, as PETSc's do
print("not stopped", flush=True)
"""


def _signal_when_ready(cmd: list[str], sig: int, env=None,
                       readies: int = 1) -> subprocess.CompletedProcess:
    """Send sig once `readies` processes have printed "ready" and nothing else; the run
    must stop at once (within 10 s)."""
    res, seen, seconds = signal_when_ready(cmd, sig, readies, env, settle=0.2, timeout=30)
    assert seen.replace("ready", "").strip() == "", seen
    assert seconds < 10, "did not stop at once"
    return res


@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_inside_a_gil_holding_call_writes_the_prepared_summary(tmp_path, sig, code):
    res = _signal_when_ready([sys.executable, "-c", HOLDS_THE_GIL, str(tmp_path)], sig)
    name = signal.Signals(sig).name
    assert res.returncode == code, res.stderr
    assert res.stderr == f"error: interrupted by {name}\n"
    assert "not stopped" not in res.stdout
    assert json.loads((tmp_path / "summary.json").read_text()) == {
        "status": "interrupted", "by": name}
    assert not list(tmp_path.glob("*.tmp"))


def test_pythons_handlers_are_back_after_the_call(tmp_path):
    script = HOLDS_THE_GIL.replace("ctypes.PyDLL(None).sleep(60)", "pass") + """
import signal
try:
    signal.raise_signal(signal.SIGINT)
except KeyboardInterrupt:
    print("python handled it", flush=True)
"""
    res = subprocess.run([sys.executable, "-c", script, str(tmp_path)], cwd=ROOT,
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    assert "python handled it" in res.stdout
    assert not (tmp_path / "summary.json").exists()


def test_without_a_run_armed_does_nothing():
    hard_stop.set_provider(None)
    with pytest.raises(KeyboardInterrupt), hard_stop.armed():
        signal.raise_signal(signal.SIGINT)  # Python's own handler: not the C one


ANNOUNCE_FACTORIZATION = """
import sys
from app.assembly import solve
real = solve.LinearSolver.factor

def factor(self):
    print("ready", flush=True)
    real(self)

solve.LinearSolver.factor = factor
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_sigterm_to_mpiexec_inside_the_factorization_records_interrupted(tmp_path):
    """On 2 ranks a signal during the MUMPS factorization (seconds at 600k DOFs, one C
    call that holds the GIL) left summary.json at `running`, with no line: the watchdog
    thread waited for the GIL until mpiexec's SIGKILL."""
    import shutil

    out = tmp_path / "o"
    cmd = [shutil.which("mpiexec"), "-n", "2", sys.executable, "-c", ANNOUNCE_FACTORIZATION,
           "run", str(CONFIGS / "hertz.toml"), "--refine", "4", "--out", str(out),
           "--quiet"]
    res = _signal_when_ready(cmd, signal.SIGTERM, readies=2)
    assert "Traceback" not in res.stderr, res.stderr
    s = read_summary(out)
    assert s["status"] == "interrupted", res.stderr
    assert s["error"] == "interrupted by SIGTERM during step 1/1; no step completed"
    assert f"error: {s['error']}" in res.stderr


# step 4's recovery (its solve: a long call) once step 3 is written
STOP_IN_STEP_FOUR = sleep_in_a_solve('(out / "step_0003.h5").exists()')


def test_a_signal_in_a_later_steps_solve_keeps_the_written_steps(tmp_path):
    """After steps, the handler rewrites only the summary's tail in place (the whole text
    grows with the steps: arming with it made 400 steps 8x slower); the file stays valid
    JSON with every completed step."""
    import shutil

    out = tmp_path / "o"
    cmd = [shutil.which("mpiexec"), "-n", "2", sys.executable, "-c", STOP_IN_STEP_FOUR,
           "run", str(CONFIGS / "cattaneo.toml"), "--out", str(out), "--quiet"]
    res = _signal_when_ready(cmd, signal.SIGINT, readies=2)
    s = read_summary(out)
    assert s["status"] == "interrupted", res.stderr
    assert [st["step"] for st in s["steps"]] == [1, 2, 3]
    assert s["error"].startswith("interrupted by SIGTERM during step 4/15; steps 1..3 are "
                                 "written in"), s["error"]
    assert f"error: {s['error']}" in res.stderr
    assert "timings" in s and "strain_energy" in s


def test_the_tail_patch_turns_the_file_into_the_new_summary(tmp_path):
    import os

    from app.output.summary import tail_patch, write_summary

    path = tmp_path / "summary.json"
    summary = {"config": "x", "steps": [], "status": "running"}
    write_summary(path, summary)
    for k in range(3):
        summary["steps"].append({"step": k + 1, "energy": 0.5 * k})
        summary["timings"] = {"total": 1.0 + k}
        write_summary(path, summary)
    stopped = {**summary, "status": "interrupted", "error": "interrupted by SIGINT"}
    offset, data = tail_patch(path, stopped, ("error",))
    fd = os.open(path, os.O_WRONLY)
    os.pwrite(fd, data, offset)
    os.close(fd)
    assert json.loads(path.read_text()) == stopped
    summary["n_dofs"] = 10  # a head key the file does not have: write it whole
    assert tail_patch(path, {**summary, "error": "e"}, ("error",)) is None


def test_a_signal_recorded_just_before_arming_is_handed_to_the_c_handler(tmp_path):
    """A signal that Python recorded just before the call (its watchdog thread then waits
    for the GIL through the call) stopped nothing until mpiexec's SIGKILL."""
    script = HOLDS_THE_GIL.replace('n"))\n', 'n"), lambda: "SIGTERM")\n', 1).replace(
        'print("ready", flush=True)', 'pass')
    assert 'lambda: "SIGTERM"' in script
    res = subprocess.run([sys.executable, "-c", script, str(tmp_path)], cwd=ROOT,
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 143, res.stderr
    assert res.stderr == "error: interrupted by SIGTERM\n"
    assert json.loads((tmp_path / "summary.json").read_text())["by"] == "SIGTERM"


def test_an_extra_that_fails_is_left_out_and_the_others_written():
    """A further file's texts that cannot be made (a bug, a full disk in a sweep's stat)
    must not fail the run's long call: that file is left out, the others are armed."""
    def bad(name: str, line: str):
        raise OSError(28, "No space left on device")

    def good(name: str, line: str):
        return None, b"", f"good {name}\n"

    assert hard_stop._texts(bad, "a\n", "b\n") is None
    assert hard_stop._texts(good, "a\n", "b\n") == ((None, b"", "good SIGINT\n"),
                                                    (None, b"", "good SIGTERM\n"))


DISARM_RACE = """
import ctypes, importlib.util, sys, threading
# the library alone (PETSc not loaded: its allocator hooks hid the double free)
lib = ctypes.CDLL(importlib.util.find_spec("app._hard_stop").origin)
lib.hard_stop_arm.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_longlong,
                              ctypes.c_char_p, ctypes.c_size_t, ctypes.c_char_p,
                              ctypes.c_size_t, ctypes.c_char_p, ctypes.c_char_p]
out = sys.argv[1].encode()
text = b"x" * 100000
for _ in range(10000):
    assert lib.hard_stop_arm(out + b"/s.tmp", out + b"/s.json", -1, text, len(text), text,
                             len(text), b"a\\n", b"b\\n") == 0
    bar = threading.Barrier(2)
    def end():
        bar.wait()
        lib.hard_stop_disarm()  # (ctypes drops the GIL: both threads are in C at once)
    threads = [threading.Thread(target=end) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
print("survived", flush=True)
"""


def test_two_threads_disarming_at_once_free_the_texts_once(tmp_path):
    """The thread that ends the job disarms (`hard_stop.disarm`) while `armed` disarms at
    the end of its call: both passed `if (!g_armed)` and freed the texts twice, and the
    process died with "double free or corruption" (5 of 5 trials, within 10000 rounds)."""
    res = subprocess.run([sys.executable, "-c", DISARM_RACE, str(tmp_path)], cwd=ROOT,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0 and "survived" in res.stdout, res.stderr[-500:]
