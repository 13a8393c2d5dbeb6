"""The thread that ends the job on a signal always exits, and the main thread that waits
for it is not let go by a further signal.

`begin_stop` takes the stop lock for good: every other stop, and the run's own end
(`RunGuard.__exit__` -> `wait_for_the_stop`), then leaves the job to that thread. So the
thread must exit whatever fails in its writes: before, a closed stderr (BrokenPipeError
from its error line) or an OUT it could not list (clear_files) ended the watchdog thread
with the lock held and no exit; on several ranks the run went on (its steps' summaries
replaced `interrupted`) and its end waited STOP_WAIT_SECONDS and exited with no line.
"""

from __future__ import annotations

import json
import os
import threading
import time

import pytest
from signal_support import cli_with, run_script
from support import CONFIGS, read_summary
from test_stop_race import fake_exit  # noqa: F401 (the fixture)

from app.output import status
from app.output.batch_guard import BatchGuard
from app.output.status import RunGuard
from app.run import write_summary


class _ClosedPipe:
    """A stderr whose reader has gone."""

    def write(self, text: str) -> int:
        raise BrokenPipeError(32, "Broken pipe")

    def flush(self) -> None:
        raise BrokenPipeError(32, "Broken pipe")


def _unlistable(out, pattern=status.STALE, also=None):
    raise FileNotFoundError(2, "No such file or directory", str(out))


def _in_a_thread(fn, *args) -> list[BaseException]:
    """Run fn(*args) in a thread to its end; the exceptions it raised."""
    raised: list[BaseException] = []

    def body():
        try:
            fn(*args)
        except BaseException as exc:  # noqa: BLE001 (reported to the test)
            raised.append(exc)

    t = threading.Thread(target=body)
    t.start()
    t.join(timeout=30)
    return raised


@pytest.mark.parametrize("breaks", ["stderr", "clear_files"])
def test_a_run_stop_whose_writes_fail_still_exits(tmp_path, monkeypatch, fake_exit,  # noqa: F811
                                                   breaks):
    summary = {"config": "c.toml", "steps": [], "status": "running"}
    with RunGuard(tmp_path, summary, write_summary, 2) as guard:
        with monkeypatch.context() as m:
            if breaks == "stderr":
                m.setattr("sys.stderr", _ClosedPipe())
            else:
                m.setattr(status, "clear_files", _unlistable)
            raised = _in_a_thread(guard.stop_now, "SIGTERM")
        assert raised == [] and fake_exit == [143], (raised, fake_exit)  # before: [], raised
        s = read_summary(tmp_path)
        assert s["status"] == "interrupted", s
        status._STOP_LOCK.release()  # (stop_now keeps it: the process would exit)
        summary["status"] = "completed"


def test_a_batch_stop_with_a_closed_stderr_still_exits(monkeypatch, fake_exit):  # noqa: F811
    with monkeypatch.context() as m:
        m.setattr("sys.stderr", _ClosedPipe())
        raised = _in_a_thread(BatchGuard(lambda: "sweep: 0 rows").stop_now, "SIGINT")
    assert raised == [] and fake_exit == [130], (raised, fake_exit)


@pytest.mark.parametrize("printed", [True, False])
def test_a_signal_that_answers_a_peers_failure_records_the_failure(tmp_path, monkeypatch,
                                                                   fake_exit, capsys,  # noqa: F811
                                                                   printed):
    """mpiexec's SIGTERM after rank 1 failed alone and left its note (app/exit_sync.py):
    the run's summary and a study's stop hooks say `failed` with rank 1's line, the exit
    status is rank 1's, and the line is printed once (by rank 0 only if rank 1 did not).
    Before: `interrupted by SIGTERM during step 1/2`, exit 143."""
    from app import exit_sync

    line = "out of memory (x); no step completed (rank 1; the other ranks did not fail)"
    seen: list[tuple[str, str | None]] = []

    def hook():
        seen.append((status.stop_status(), status.stop_reason()))

    monkeypatch.setitem(exit_sync._STATE, "comm", object())  # (as on several ranks)
    monkeypatch.setitem(exit_sync._STATE, "note", None)
    monkeypatch.setattr(status, "_STOP_STATUS", [])  # (module state: this test's only)
    monkeypatch.setattr(status, "_STOP_REASON", [])
    summary = {"config": "c.toml", "steps": [], "status": "running"}
    status.on_stop(hook)
    try:
        with RunGuard(tmp_path, summary, write_summary, 2) as guard:
            rank1 = exit_sync._STATE["note"]
            assert rank1 == tmp_path / exit_sync.NOTE_NAME  # (RunGuard: note_in)
            rank1.write_text(json.dumps({"rank": 1, "code": 2, "error": line,
                                         "printed": printed,
                                         "run": exit_sync._STATE["token"]}))  # (this run's)
            raised = _in_a_thread(guard.stop_now, "SIGTERM")
            assert raised == [] and fake_exit == [2], (raised, fake_exit)
            s = read_summary(tmp_path)
            assert (s["status"], s["error"], s["failed_step"]) == ("failed", line, 1), s
            assert seen == [("failed", line)]
            assert capsys.readouterr().err.count(line) == (0 if printed else 1)
            assert not rank1.exists()
            status._STOP_LOCK.release()
            summary["status"] = "completed"
    finally:
        status.remove_on_stop(hook)


def test_the_wait_for_the_stop_outlasts_a_further_signal(monkeypatch):
    """One rank: Ctrl-C again while the main thread waits raised KeyboardInterrupt out of
    the sleep, and the main thread went on to exit by itself under the stopping thread."""
    exits: list[int] = []

    class _Exited(BaseException):
        pass

    def exit_(code: int) -> None:
        exits.append(code)
        raise _Exited

    real_sleep = time.sleep
    calls: list[float] = []

    def sleep(seconds: float) -> None:
        calls.append(seconds)
        if len(calls) == 1:
            raise KeyboardInterrupt  # the second Ctrl-C, inside the wait
        real_sleep(seconds)

    monkeypatch.setattr(status, "STOP_WAIT_SECONDS", 0.2)
    monkeypatch.setattr(status, "_STOP_CODE", [143])
    monkeypatch.setattr(os, "_exit", exit_)
    monkeypatch.setattr(time, "sleep", sleep)
    with pytest.raises(_Exited):  # before: KeyboardInterrupt
        status.wait_for_the_stop()
    assert exits == [143] and len(calls) >= 2


WRITES_UNDER_THE_LOCK = cli_with("""
    from app.driver import output
    from app.output import status

    def held():
        return bool(status._WATCHDOG) and status._WATCHDOG[-1].writing.locked()

    real_summary, real_writer = output.write_summary, output.ResultWriter

    def write_summary(out, summary):
        if summary.get("status") == "completed":
            print("final summary under the lock:", held(), flush=True)
        return real_summary(out, summary)

    def writer(*args, **kwargs):
        print("mesh.h5 under the lock:", held(), flush=True)
        return real_writer(*args, **kwargs)

    output.write_summary, output.ResultWriter = write_summary, writer
    """)


def test_the_runs_writes_outside_the_steps_hold_the_watchdogs_lock(tmp_path):
    """app/driver/output.py writes mesh.h5 and the completed summary inside `writing()`
    (a watchdog's stop waits for them; tests/test_stop_race.py shows why). Without it this
    test fails: nothing else runs those call sites under a watchdog."""
    res = run_script(WRITES_UNDER_THE_LOCK, ["run", str(CONFIGS / "hertz.toml"), "--quiet",
                                             "--mesh-size", "1.0", "--out", str(tmp_path)])
    assert res.returncode == 0, res.stderr
    assert "mesh.h5 under the lock: True" in res.stdout, res.stdout
    assert "final summary under the lock: True" in res.stdout, res.stdout
    assert "under the lock: False" not in res.stdout, res.stdout


def test_the_wait_for_the_stop_lasts_as_long_as_the_stopping_thread(monkeypatch):
    """The thread that ends the job runs the stop hooks: a study's tables and, on one rank,
    its plots. The main thread exited after a fixed STOP_WAIT_SECONDS, in the middle of
    them; it now waits for that thread (which exits the process), then exits itself."""
    seen: list[bool] = []

    class _Exited(BaseException):
        pass

    def exit_(code: int) -> None:
        seen.append(done.is_set())
        raise _Exited

    done = threading.Event()
    began = threading.Event()

    def stopper() -> None:  # a watchdog's stop whose hooks take longer than the wait
        status.begin_stop("SIGINT")
        began.set()
        time.sleep(0.8)
        done.set()  # (its exit_after_rank0 would end the process here)

    monkeypatch.setattr(status, "STOP_WAIT_SECONDS", 0.2)
    monkeypatch.setattr(os, "_exit", exit_)
    t = threading.Thread(target=stopper)
    t.start()
    try:
        assert began.wait(10)
        with pytest.raises(_Exited):
            status.wait_for_the_stop()
    finally:
        t.join(timeout=10)
        status._STOP_LOCK.release()
        status._STOP_CODE.clear()
        status._STOPPER.clear()
    assert seen == [True]  # before: [False] (exited 0.2 s in, the hooks still writing)


def test_a_hand_off_while_another_thread_stops_disarms_and_waits(monkeypatch,
                                                                  fake_exit):  # noqa: F811
    """app/hard_stop.py arms the C handler, then asks `_hand_off_pending`. With a watchdog
    already ending the job it waited on the stop lock with the C handler armed (a second
    signal then wrote from C over the watchdog's summary); now it disarms and waits for
    the job's end (`wait_for_the_stop`, here raising _Waited)."""
    from test_stop_race import _Waited

    from app import hard_stop

    disarmed: list[bool] = []
    monkeypatch.setattr(hard_stop, "disarm", lambda: disarmed.append(True))
    monkeypatch.setattr(status, "_PENDING", ["SIGINT"])
    stopper = threading.Thread(target=status.begin_stop, args=("SIGTERM",))
    stopper.start()
    stopper.join(timeout=10)
    result = []

    def hand_off() -> None:
        try:
            result.append(status._hand_off_pending())
        except _Waited:
            result.append("waited")

    t = threading.Thread(target=hand_off)
    t.start()
    t.join(timeout=2)
    blocked = t.is_alive()
    if blocked:  # (before: blocked on the stop lock, the C handler armed)
        status._STOP_LOCK.release()
        t.join(timeout=10)
    assert not blocked and result == ["waited"] and disarmed == [True], (blocked, result)


def test_a_hand_off_without_a_stop(monkeypatch, fake_exit):  # noqa: F811
    """No stop under way: None and the lock free with nothing pending; the pending name
    and the lock kept (for the C handler, which exits) with a signal pending."""
    monkeypatch.setattr(status, "_PENDING", [])
    assert status._hand_off_pending() is None and not status._STOP_LOCK.locked()
    monkeypatch.setattr(status, "_PENDING", ["SIGTERM"])
    assert status._hand_off_pending() == "SIGTERM" and status._STOP_LOCK.locked()


def test_a_note_left_by_an_earlier_run_is_not_this_runs_failure(tmp_path, monkeypatch,
                                                                 fake_exit):  # noqa: F811
    """A note in OUT that this run's ranks did not write (a rank of an earlier job in the
    same OUT that outlived it: its `leave_if_alone` writes the note again at its deadline,
    after this run's rank 0 removed the old one) must not turn this run's SIGTERM into
    `failed` with that job's line: the note carries its run's token (`note_in`)."""
    from app import exit_sync

    monkeypatch.setitem(exit_sync._STATE, "comm", object())  # (as on several ranks)
    monkeypatch.setitem(exit_sync._STATE, "note", None)
    monkeypatch.setattr(status, "_STOP_STATUS", [])
    monkeypatch.setattr(status, "_STOP_REASON", [])
    summary = {"config": "c.toml", "steps": [], "status": "running"}
    with RunGuard(tmp_path, summary, write_summary, 2) as guard:
        (tmp_path / exit_sync.NOTE_NAME).write_text(json.dumps(
            {"rank": 1, "code": 2, "error": "an earlier job's line", "printed": False}))
        raised = _in_a_thread(guard.stop_now, "SIGTERM")
        assert raised == [] and fake_exit == [143], (raised, fake_exit)
        s = read_summary(tmp_path)
        assert s["status"] == "interrupted" and "earlier" not in json.dumps(s), s
        status._STOP_LOCK.release()
        summary["status"] = "completed"


def test_a_ranks_note_is_not_written_through_a_planted_link(tmp_path, monkeypatch):
    """A rank that failed alone writes its note through `.failed_rank.json.<rank>.tmp`:
    before, a dangling link planted there made it create the link's target, outside OUT."""
    from app import exit_sync

    monkeypatch.setitem(exit_sync._STATE, "note", tmp_path / exit_sync.NOTE_NAME)
    monkeypatch.setitem(exit_sync._STATE, "token", "t")
    (tmp_path / f"{exit_sync.NOTE_NAME}.1.tmp").symlink_to(tmp_path / "elsewhere")
    assert exit_sync._leave_note(1, 2, "bad", False)
    assert not (tmp_path / "elsewhere").exists()
    note = tmp_path / exit_sync.NOTE_NAME
    assert not note.is_symlink() and json.loads(note.read_text())["error"] == "bad"
