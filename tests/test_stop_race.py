"""A watchdog that ends the job while the main thread writes a file of the run.

On several ranks rank 0's watchdog stops the job at once (`RunGuard.stop_now`): it removes
the run's temporary files, writes `interrupted`, prints its line and exits, while the main
thread goes on. When the main thread was writing mesh.h5 or the final summary.json, its
rename failed (`No such file or directory`: the watchdog had removed the .tmp), and its
`failed` summary and error replaced the watchdog's before the process exited (2 of about
400 `check_interrupts.py --sweep` trials on 2 ranks). Forced here in one process: the
watchdog's `stop_now` runs inside the main thread's fsync of the file.
"""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest
from support import read_summary

from app.output import startup_signals, status
from app.output.status import RunGuard
from app.output.xdmf import ResultWriter
from app.run import write_summary


class _Waited(BaseException):
    """Raised by the stand-in for `status.wait_for_the_stop` (the main thread yielded)."""


@pytest.fixture
def fake_exit(monkeypatch):
    """The watchdog's exit ends its thread only; the main thread's wait raises _Waited.
    Yields the exit codes; releases the stop lock after the test."""
    codes: list[int] = []

    def exit_thread(code: int) -> None:
        codes.append(code)  # and return: stop_now's thread ends

    def waited() -> None:
        raise _Waited

    monkeypatch.setattr(startup_signals, "exit_after_rank0", exit_thread)
    monkeypatch.setattr(status, "wait_for_the_stop", waited)
    yield codes
    if status._STOP_LOCK.locked():
        status._STOP_LOCK.release()
    status._STOP_CODE.clear()
    status._STOPPER.clear()


def _stop_inside_fsync(monkeypatch, guard_box: list, suffix: str) -> None:
    """os.fsync of the main thread's `*suffix` file: first the watchdog's stop_now (in
    another thread, to its end), then the fsync returns and the main thread renames."""
    real_fsync = os.fsync
    fired = []

    def fsync(fd: int) -> None:
        real_fsync(fd)
        if (guard_box and not fired and threading.current_thread() is threading.main_thread()
                and os.readlink(f"/proc/self/fd/{fd}").endswith(suffix)):
            fired.append(fd)
            t = threading.Thread(target=guard_box[0].stop_now, args=("SIGTERM",))
            t.start()
            t.join(timeout=30)

    monkeypatch.setattr(os, "fsync", fsync)


def _write_mesh(out, summary) -> None:
    ResultWriter(out, np.zeros((4, 2)), np.array([[0, 1, 2, 3]]), np.zeros(1, dtype=int))


def _write_final_summary(out, summary) -> None:
    summary["status"] = "completed"
    summary["point_values"] = {"x": 1.0}  # a new head key: written whole (a rename)
    write_summary(out, summary)


@pytest.mark.parametrize("write,suffix,where", [
    (_write_mesh, "mesh.h5.tmp", "during step 1/1"),
    (_write_final_summary, "summary.json.tmp", "after the last step (1/1)"),
])
def test_a_watchdog_stop_during_a_write_stays_interrupted(tmp_path, monkeypatch, fake_exit,
                                                          write, suffix, where):
    summary = {"config": "c.toml", "steps": [], "status": "running"}
    if where.startswith("after"):
        summary["steps"].append({"step": 1})
    guard_box: list = []
    _stop_inside_fsync(monkeypatch, guard_box, suffix)
    with pytest.raises(_Waited):  # before: InputError, the run `failed`
        with RunGuard(tmp_path, summary, write_summary, 1) as guard:
            guard_box.append(guard)
            write(tmp_path, summary)
    assert fake_exit == [143]
    s = read_summary(tmp_path)
    assert s["status"] == "interrupted", s
    assert s["error"].startswith(f"interrupted by SIGTERM {where}"), s["error"]
    assert not list(tmp_path.glob("*.tmp"))


def test_a_stop_waits_for_the_main_threads_end_of_run(tmp_path, monkeypatch, fake_exit):
    """The other order: the watchdog's stop begins while the main thread records the run's
    end; it waits for that, then records `interrupted` over it."""
    summary = {"config": "c.toml", "steps": [], "status": "running"}
    started = []
    real_finish = RunGuard._finish

    def finish(self, exc):
        t = threading.Thread(target=self.stop_now, args=("SIGINT",))
        t.start()
        t.join(timeout=0.5)
        started.append(t.is_alive())  # blocked on the stop lock while this runs
        try:
            return real_finish(self, exc)
        finally:
            started.append(t)

    monkeypatch.setattr(RunGuard, "_finish", finish)
    with pytest.raises(status.InputError):
        with RunGuard(tmp_path, summary, write_summary, 1):
            raise OSError(28, "No space left on device")
    assert started[0] is True
    started[1].join(timeout=30)
    assert fake_exit == [130]
    s = read_summary(tmp_path)
    assert s["status"] == "interrupted" and s["error"].startswith("interrupted by SIGINT"), s


def test_a_studys_stop_between_the_runs_is_the_only_one(tmp_path, fake_exit):
    """A sweep's watchdog that ends the job as a run starts (the run's guard already in
    place): the run's main thread, failing or ending meanwhile, leaves the run's summary
    to it (before: `failed` over the `interrupted` of the study's stop hook; and the
    C handler's hand-off took the stop lock too, a second line)."""
    from app.output.batch_guard import BatchGuard

    summary = {"config": "c.toml", "steps": [], "status": "running"}
    with pytest.raises(_Waited):
        with RunGuard(tmp_path, summary, write_summary, 1):
            BatchGuard(lambda: "sweep: 0 rows").stop_now("SIGTERM")
            assert status._STOP_LOCK.locked()
            raise FileNotFoundError(2, "No such file or directory")
    assert fake_exit == [143]
    s = read_summary(tmp_path)
    assert s["status"] == "interrupted" and s["error"].startswith("interrupted by SIGTERM"), s


def test_a_studys_stop_as_a_run_takes_its_folder_leaves_no_running_summary(tmp_path,
                                                                             monkeypatch,
                                                                             fake_exit):
    """A sweep's watchdog that ends the job after the run's guard took OUT and before it
    wrote `running` and added its stop hook: the study's hooks ran without the run's, and
    the run's summary.json stayed `running` (1 of 18 real trials on 2 ranks). Now the run
    writes neither once a stop is under way (it waits for the job's end): no summary.json,
    the run did not start."""
    from app.output.batch_guard import BatchGuard

    real_clear = status.clear_files

    def clear_then_stop(out, pattern=status.STALE, also=None):  # (in the guard's `start`)
        removed = real_clear(out, pattern, also)
        threading.Thread(target=BatchGuard(lambda: "sweep: 0 rows").stop_now,
                         args=("SIGTERM",)).start()
        while not fake_exit:  # the study's stop has run its hooks
            pass
        return removed

    monkeypatch.setattr(status, "clear_files", clear_then_stop)
    summary = {"config": "c.toml", "steps": [], "status": "running"}
    with pytest.raises(_Waited):  # before: the run went on
        with RunGuard(tmp_path, summary, write_summary, 1):
            pass
    assert fake_exit == [143] and not (tmp_path / "summary.json").exists()


def test_the_stops_summary_is_interrupted_whatever_the_main_thread_sets(tmp_path, fake_exit,
                                                                        monkeypatch):
    """The main thread's `status = completed` (the run's end) between the stop's own
    status and its JSON left summary.json `completed` with the interrupt's error."""
    summary = {"config": "c.toml", "steps": [{"step": 1}], "status": "running"}
    real_clear = status.clear_files

    def clear_then_complete(out, pattern=status.STALE, also=None):
        summary["status"] = "completed"  # the main thread, at that moment
        return real_clear(out, pattern, also)

    with RunGuard(tmp_path, summary, write_summary, 1) as guard:
        monkeypatch.setattr(status, "clear_files", clear_then_complete)
        guard.stop_now("SIGTERM")
        monkeypatch.setattr(status, "clear_files", real_clear)
        s = read_summary(tmp_path)
        assert s["status"] == "interrupted", s
        assert s["error"].startswith("interrupted by SIGTERM after the last step (1/1)")
        status._STOP_LOCK.release()  # (stop_now keeps it: the process would exit)
        summary["status"] = "completed"


def test_a_watchdog_stop_waits_for_a_write_outside_the_steps(tmp_path, fake_exit,
                                                              monkeypatch):
    """`writing()` (mesh.h5, the final summary): the watchdog's stop (which holds the
    writing lock, as StopWatchdog._watch does) waits for it, then records `interrupted`."""
    summary = {"config": "c.toml", "steps": [{"step": 1}], "status": "running"}
    threads = []
    real_fsync = os.fsync

    def fsync(fd: int) -> None:
        real_fsync(fd)
        if not threads and threading.current_thread() is threading.main_thread():
            def watch():
                with status._WATCHDOG[-1].writing:
                    guard.stop_now("SIGINT")
            threads.append(threading.Thread(target=watch))
            threads[0].start()
            threads[0].join(timeout=0.5)
            assert threads[0].is_alive()  # waiting for the write

    with RunGuard(tmp_path, summary, write_summary, 1) as guard:
        monkeypatch.setattr(os, "fsync", fsync)
        with status.writing():
            _write_final_summary(tmp_path, summary)
        threads[0].join(timeout=30)
        monkeypatch.setattr(os, "fsync", real_fsync)
        assert fake_exit == [130]
        s = read_summary(tmp_path)
        assert s["status"] == "interrupted" and "after the last step" in s["error"], s
        assert not list(tmp_path.glob("*.tmp"))
        status._STOP_LOCK.release()
        summary["status"] = "completed"
