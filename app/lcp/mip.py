"""A complementary basis of an LCP by mixed-integer search (HiGHS through scipy.optimize.milp).

Lemke's method ends on a secondary ray only when the LCP has no solution for copositive-plus
matrices; the frictional contact LCP with free floating-mode amplitudes is not one, and its
ray then proves nothing. `complementary_basis` searches the LCP's solutions directly, with
one binary per pair (z_i, w_i) and a bound on the scaled unknowns (big-M), and returns the
basis of the least sum of the scaled z (the least motion) it finds that the caller's check
(`lemke` warm-started from it) accepts. configs/multibody.toml --sd 1 --mesh-size 1.2 (step
1, 98 unknowns, 22 hourglass modes held by friction): Lemke ended on a secondary ray, the
search found a solution that Lemke's check accepts from its basis in 0 pivots.

Free of units: LCP(m, t q) has the solutions t z (t > 0), and a scene in other units (every
E, load and bond strength x s) has the same unit-diagonal m and q x sqrt(s) (the scaled
unknowns carry sqrt(force x length)). The search sees q scaled to max |q| = MIP_SCALE and
bounds the unknowns relative to it, so the verdict and the basis do not depend on the
units. Before, the bound (1e3) applied to the unknowns as they came: multibody.toml --sd 1
--mesh-size 1.2 with its moduli, loads and bond strengths x 1e6 stopped with `no static
equilibrium` (none below 1e3) where its own units (max |q| 1.05 at step 1) complete.
"""

from __future__ import annotations

import io
import os
import pickle
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

MIP_SCALE = 1e3
"""max |q| of the LCP the search sees: HiGHS's tolerances are absolute (feasibility 1e-7 to
1e-6), and at max |q| = 1 they let w_i = -8e-7 through: two_blocks.toml's stiff floating
block (README "Floating bodies") then read a false solution whose basis Lemke's check
refused, at 1e3 the right one (w >= -5e-11;
tests/test_interface_steps.py::test_a_stiff_floating_block_at_1e11_finds_the_equilibrium_lemkes_ray_missed)."""

MIP_BOUNDS = (1e1, 1e2, 1e3)
"""The bounds on the scaled unknowns (z and w, times max |q|) tried in turn, the next only
when the last found none or none that the caller accepts: HiGHS's integrality tolerance
(1e-6) lets z_i reach 1e-6 x its bound where y_i = 0, and with 1e3 that slack found a false
solution of multibody.toml --sd 1 --mesh-size 1.2 at step 3 (sum of z 0.55 x the true one,
both bases refused), which 1e1 and 1e2 do not (tests/test_interface_floating.py, 1.2)."""

MIP_BOUND = MIP_BOUNDS[-1]
"""Largest scaled unknown (relative to max |q|) the search admits."""

MIP_MAX_SIZE = 200
"""LCPs above this size are not searched (binaries: one per unknown)."""

MIP_WORK = 1.2e7
"""Branch-and-bound nodes x n^2 of one bound's search (HiGHS), the search ending when a bound
reaches it: a limit that does not depend on the machine's speed, and bounds the time, a
node of an LCP of size n costing roughly 2e-6 n^2 s or more (7 ms at n = 39, 17-50 ms at
98, 250 ms at 200 on 2 shared cores; README "Floating bodies", cost): 1,250 nodes at n =
98, where multibody.toml --sd 1 --mesh-size 1.2 needs 582, 300 at 200. Per bound, since
HiGHS does not report the nodes of a proof that there is no solution. Before, 5,000 nodes
at any size: a random dense LCP of 200 took 426 s to reach them."""

MIP_SECONDS = 600.0
"""Time limit of one search, a guard against a hang only (the node limit ends it first);
within MIP_STEP_SECONDS and MIP_RUN_SECONDS (`CLOCK`)."""

BASIC_REL = 1e-9
"""z_i above this x its bound is basic in the first basis tried."""


MIP_STEP_SECONDS = 300.0
"""Seconds of searches in one load step (all its LCP solves), each search's time limit the
least of MIP_SECONDS and what is left of this and MIP_RUN_SECONDS (`CLOCK`)."""

MIP_RUN_SECONDS = 600.0
"""Seconds of searches in one run: past it the run searches no more (its line says so)."""


class SearchClock:
    """The searches' seconds spent in this step and this run (the run driver calls
    `new_run` and `new_step`); a process runs one run at a time."""

    def __init__(self) -> None:
        self.step = self.run = 0.0

    def new_run(self) -> None:
        self.step = self.run = 0.0

    def new_step(self) -> None:
        self.step = 0.0

    def left(self) -> float:
        """Seconds a search may take now."""
        return min(MIP_STEP_SECONDS - self.step, MIP_RUN_SECONDS - self.run)

    def spend(self, seconds: float) -> None:
        self.step += seconds
        self.run += seconds

    def spent(self) -> str:
        """Why no search: the budget it reached, in words."""
        if MIP_RUN_SECONDS - self.run <= MIP_STEP_SECONDS - self.step:
            return f"this run's {MIP_RUN_SECONDS:.0f} s of searches are spent"
        return f"this step's {MIP_STEP_SECONDS:.0f} s of searches are spent"


CLOCK = SearchClock()
"""The process's search clock (app/run.py resets it per run and per step)."""

MIP_GRACE = 10.0
"""Seconds past a search's own time limit before its HiGHS process is killed (HiGHS checks
its clock between LPs, not inside one)."""

_CHILD = r"""
import ctypes, io, os, pickle, signal, sys
try:  # end with the run (PR_SET_PDEATHSIG = 1), whatever ends it
    ctypes.CDLL(None).prctl(1, signal.SIGKILL)
except (OSError, AttributeError):
    pass
if os.getppid() != int(sys.argv[1]):
    os._exit(3)
signal.signal(signal.SIGINT, signal.SIG_DFL)
answer = os.fdopen(os.dup(1), "wb")  # stray output from here on (HiGHS's C) to stderr
os.dup2(2, 1)
import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp
d = np.load(io.BytesIO(sys.stdin.buffer.read()))
n = d["c"].size // 2
res = milp(d["c"], constraints=LinearConstraint(d["a"], d["lo"], d["hi"]),
           integrality=np.concatenate([np.zeros(n), np.ones(n)]),
           bounds=Bounds(np.zeros(2 * n), d["ub"]),
           options={"node_limit": int(d["nodes"]), "time_limit": float(d["seconds"]),
                    "mip_rel_gap": 0.0})
answer.write(b"\n--- answer ---\n" + pickle.dumps(
    (res.x, int(res.status), str(res.message), int(getattr(res, "mip_node_count", 0) or 0))))
answer.flush()
os._exit(0)
"""
"""The search's own process: reads the problem (npz on stdin), writes HiGHS's answer (on
stdout, after a mark: a sitecustomize may print before it; later output goes to stderr)."""


STOP_SIGNALS = frozenset({signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGKILL})
"""Signals that end a HiGHS process from outside (a user, a job's end, the kernel's
out-of-memory killer): the search ends there. Any other death (SIGABRT, SIGSEGV, a
non-zero exit) is HiGHS's own crash on that bound's problem, and the next bound is tried."""


class Answer(NamedTuple):
    """HiGHS's answer as scipy.optimize.milp gives it (status 0 optimal, 1 a limit, here
    also a HiGHS process killed MIP_GRACE past its time limit, 2 infeasible, 4 other: here
    also a HiGHS process that crashed or was stopped from outside)."""

    x: np.ndarray | None
    status: int
    message: str
    mip_node_count: int
    crashed: bool = False
    """The HiGHS process died (a signal but STOP_SIGNALS, a non-zero exit) or its answer did
    not read: that bound's search failed, not the search (the next bound is tried)."""


def _search(m: np.ndarray, q: np.ndarray, zb: np.ndarray, bound: float, nodes: int,
            seconds: float) -> Answer:
    """HiGHS's answer to: z, w = m z + q >= 0, z_i <= zb_i y_i, w_i <= bound (1 - y_i), y
    binary, least sum(z) (m (n, n), q (n,), zb (n,)). In a process of its own: HiGHS holds
    the GIL through the whole search (minutes), where no signal handler and no watchdog
    thread can run; here the run waits in Python, so SIGINT / SIGTERM stop it at once on
    any number of ranks (the HiGHS process is killed with it: in a session of its own, so
    mpiexec's SIGTERM to a rank's group or Ctrl-C's SIGINT reaches the rank, not HiGHS; the
    parent-death signal ends it if the rank dies), the time limit holds even
    inside one LP (killed MIP_GRACE s past it), and a HiGHS crash (scipy 1.10's HiGHS aborts
    in free() on two_blocks.toml's LCP of 39 at E = 1e13, README "Floating bodies") ends
    this bound's search (`Answer.crashed`), not the run."""
    n = q.size
    eye, zero = np.eye(n), np.zeros((n, n))
    inf = np.full(n, np.inf)
    data = io.BytesIO()
    np.savez(data, c=np.concatenate([np.ones(n), np.zeros(n)]),
             a=np.block([[m, zero], [eye, -np.diag(zb)], [m, bound * eye]]),
             lo=np.concatenate([-q, -inf, -inf]),
             hi=np.concatenate([inf, np.zeros(n), bound - q]),
             ub=np.concatenate([inf, np.ones(n)]), nodes=nodes, seconds=seconds)
    proc = subprocess.Popen([sys.executable, "-c", _CHILD, str(os.getpid())],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, start_new_session=True)
    try:
        out, err = proc.communicate(data.getvalue(), timeout=seconds + MIP_GRACE)
    except subprocess.TimeoutExpired:
        return Answer(None, 1, f"HiGHS passed its time limit ({seconds:.0f} s) by "
                      f"{MIP_GRACE:.0f} s and was stopped", 0)
    finally:  # (also on a signal's exception: the search ends with the run)
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    if proc.returncode != 0 or not out:
        last = (err.decode(errors="replace").strip().splitlines() or [""])[-1][:120]
        code = f"exit {proc.returncode}" + (f": {last}" if last else "")
        if -proc.returncode in STOP_SIGNALS:
            name = signal.Signals(-proc.returncode).name
            return Answer(None, 4, f"HiGHS was stopped by {name} from outside ({code})", 0)
        return Answer(None, 4, f"HiGHS crashed ({code})", 0, True)
    try:  # (what a sitecustomize printed at start-up comes before the mark)
        x, status, message, count = pickle.loads(out.partition(b"\n--- answer ---\n")[2])
    except Exception as exc:  # (any bytes: pickle raises many kinds) not the run's end
        return Answer(None, 4, f"HiGHS's answer unreadable ({type(exc).__name__})", 0, True)
    return Answer(x, status, message, count)


def complementary_basis(m: np.ndarray, q: np.ndarray,
                        accept: Callable[[np.ndarray], bool] = lambda basis: True, *,
                        widen: np.ndarray | None = None, bounds: tuple[float, ...] = MIP_BOUNDS,
                        work: float = MIP_WORK, seconds: float = MIP_SECONDS
                        ) -> tuple[np.ndarray | None, str]:
    """`_basis` (below) within `CLOCK`: its time limit the least of `seconds` and the
    step's and the run's time left (MIP_STEP_SECONDS, MIP_RUN_SECONDS), none past them."""
    left = CLOCK.left()
    if 0 < q.size <= MIP_MAX_SIZE and left < 1.0:
        return None, f"no mixed-integer search ({CLOCK.spent()})"
    start = time.monotonic()
    try:
        basis, found = _basis(m, q, accept, widen=widen, bounds=bounds, work=work,
                              seconds=min(seconds, left))
    finally:
        CLOCK.spend(time.monotonic() - start)
    if basis is None and seconds > left and ("time limit" in found.lower()
                                             or found.endswith("no time left")):
        found += f" ({CLOCK.spent()})"
    return basis, found


def _add_crash(notes: list[str], b: float, message: str) -> None:
    """Bound b's HiGHS crash (`message`) added to `notes`, one note with the bound before's
    when that crashed alike: `none below 1e+01, 1e+02 or 1e+03 (HiGHS crashed (exit -6))`,
    not the crash's words once per bound."""
    tail = f" ({message})"
    if notes and notes[-1].startswith("none below ") and notes[-1].endswith(tail):
        notes[-1] = f"{notes[-1][:-len(tail)].replace(' or ', ', ')} or {b:.0e}{tail}"
    else:
        notes.append(f"none below {b:.0e}{tail}")


def _none_below_largest(notes: list[str], b: float, widen: np.ndarray | None) -> list[str]:
    """`notes` when the largest bound b has no solution: the smaller bounds' `no solution`
    left out (none below b, none below them either), and the widened unknowns named."""
    wider = "" if widen is None or not (widen > 1.0).any() else \
        f" ({int((widen > 1.0).sum())} of them up to {b * widen.max():.1e})"
    return [note for note in notes if not note.startswith("no solution below")] + [
        f"no solution with the scaled unknowns below {b:.0e} x the largest constant term"
        f"{wider}"]


def _basis(m: np.ndarray, q: np.ndarray, accept: Callable[[np.ndarray], bool], *,
           widen: np.ndarray | None, bounds: tuple[float, ...], work: float, seconds: float
           ) -> tuple[np.ndarray | None, str]:
    """(basis (n,) bool or None, what the search found, in words) for LCP(m, q), m (n, n)
    and q (n,) scaled to a unit diagonal. With q' = MIP_SCALE q / max |q|, for each bound b
    in turn: z, w = m z + q' >= 0, z_i <= b MIP_SCALE widen_i y_i, w_i <= b MIP_SCALE (1 -
    y_i), y binary, least sum(z); its bases z > BASIC_REL x the bound and y, each given to
    `accept` (e.g. Lemke's check), the first accepted returned. widen (n,) >= 1 (default 1):
    a caller's factor on the bound of the unknowns whose unit diagonal understates them (see
    `app.interface.coulomb.ContactLCP._searched`). None when no bound has an accepted
    solution, the LCP is above MIP_MAX_SIZE or the search ran out of nodes (MIP_WORK / n^2
    over all bounds) or time. A node limit that ends a bound with a solution keeps it (not
    the least sum(z), but a solution). A bound whose HiGHS process crashed (scipy 1.10's
    HiGHS aborts on some LCPs at one bound and not at another) goes on to the next within
    the nodes and time left; a time or node limit, or a HiGHS process stopped from outside
    (STOP_SIGNALS), ends the search. The words say what each bound found (`_add_crash`,
    `_none_below_largest`)."""
    n = q.size
    if n == 0 or n > MIP_MAX_SIZE:
        return None, f"no mixed-integer search (size {n} > {MIP_MAX_SIZE})"
    top = float(np.abs(q).max())
    qs = q * (MIP_SCALE / top) if top > 0 else q
    factor = np.ones(n) if widen is None else np.maximum(widen, 1.0)
    nodes, end = max(int(work / n ** 2), 1), time.monotonic() + seconds
    notes: list[str] = []
    for b in bounds:
        bound = b * MIP_SCALE
        zb = bound * factor
        res = _search(m, qs, zb, bound, nodes, max(end - time.monotonic(), 1.0))
        nodes -= res.mip_node_count
        if res.x is not None:
            z, y = res.x[:n] > BASIC_REL * zb, res.x[n:] > 0.5
            # both: within HiGHS's integrality tolerance a y_i of 1e-6 lets z_i reach 1e-6
            # x its bound with w_i > 0 (z's basis then singular), and y_i = 1 where z_i =
            # w_i = 0 can make y's singular
            for basis in ([z] if np.array_equal(z, y) else [z, y]):
                if accept(basis):
                    return basis, ("a mixed-integer search found a basis (the scaled "
                                   f"unknowns below {b:.0e} x the largest constant term)"
                                   + (f", after {', then '.join(notes)}" if notes else ""))
            notes.append(f"one below {b:.0e} that Lemke's check did not accept")
        elif res.crashed:  # that bound's HiGHS died: the next one may not
            _add_crash(notes, b, res.message)
        elif res.status != 2:  # a limit, HiGHS's other failures, a stop from outside
            notes.append(f"none {'before its limit' if res.status == 1 else f'below {b:.0e}'}"
                         f" ({res.message})")
            break
        elif b != bounds[-1]:
            notes.append(f"no solution below {b:.0e}")
        else:
            notes = _none_below_largest(notes, b, widen)
        if b == bounds[-1]:
            break
        if nodes <= 0:
            notes.append("no nodes left")
            break
        if end - time.monotonic() < 1.0:
            notes.append("no time left")
            break
    return None, "a mixed-integer search found " + ", then ".join(notes)
