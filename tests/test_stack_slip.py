"""configs/hard/stack_slip.toml: which interface of a stack slips first follows the hand
calculation T / (mu N) per interface (README "Hard cases"), and a sixth step past the
first limit has no static equilibrium, the earlier steps kept; as shipped it completes."""

from __future__ import annotations

import pytest

from tests.support import CONFIGS, read_summary, run_cli

SCENE = CONFIGS / "hard" / "stack_slip.toml"
P, Q1 = 16.0, 3.2


def _run(tmp_path, name: str, *args: str) -> dict:
    out = tmp_path / name
    res = run_cli(["run", str(SCENE), "--out", str(out), "--quiet",
                   "--set", "analysis.steps=6", *args])
    assert res.returncode == 2 and "no static equilibrium" in res.stderr
    s = read_summary(out)
    assert sorted(p.name for p in out.glob("step_*.h5")) == [
        f"step_{k:04d}.h5" for k in range(1, s["failed_step"])]
    return s


def _ratios(step: dict, mu: dict) -> dict:
    return {n: abs(v["tangential_force"]) / (mu[n] * abs(v["normal_force"]))
            for n, v in step["interfaces"].items()}


@pytest.mark.parametrize(("args", "mu", "first", "failed"), [
    (("--set", "load.2.history=[0.0,0.05,0.1,0.15,0.19,0.21]"),
     {"bot": 0.4, "mid": 0.25, "top": 0.3}, "bot", 6),
    (("--set", "interface.bot.mu=0.6", "--set", "load.2.history=[0.0,0.1,0.2,0.215,0.24,0.26]"),
     {"bot": 0.6, "mid": 0.25, "top": 0.3}, "mid", 6),
    (("--set", "interface.bot.mu=0.6", "--set", "interface.top.mu=0.22",
      "--set", "load.2.history=[0.0,0.1,0.2,0.215,0.24,0.26]"),
     {"bot": 0.6, "mid": 0.25, "top": 0.22}, "top", 5),
])
def test_the_interface_nearest_its_limit_is_the_hand_calculations(tmp_path, args, mu, first,
                                                                   failed):
    s = _run(tmp_path, first, *args)
    assert s["failed_step"] == failed
    history = s["provenance"]["config_resolved"]["load"][2]["history"]
    for step in s["steps"]:
        q3 = P * history[step["step"] - 1]
        hand = {"bot": (q3 + Q1) / (mu["bot"] * P), "mid": q3 / (mu["mid"] * P),
                "top": q3 / (mu["top"] * P)}
        got = _ratios(step, mu)
        assert got == pytest.approx(hand, abs=1e-9)
        assert step["balance"]["max_relative_residual"] < 1e-12
    last = _ratios(s["steps"][-1], mu)
    assert max(last, key=last.get) == first
    q3 = P * history[failed - 1]
    beyond = {"bot": (q3 + Q1) / (mu["bot"] * P), "mid": q3 / (mu["mid"] * P),
              "top": q3 / (mu["top"] * P)}
    assert max(beyond, key=beyond.get) == first and beyond[first] > 1.0


def test_as_shipped_it_completes_just_below_the_first_limit(tmp_path):
    out = tmp_path / "shipped"
    res = run_cli(["run", str(SCENE), "--out", str(out), "--quiet"])
    assert res.returncode == 0, res.stderr
    last = _ratios(read_summary(out)["steps"][-1], {"bot": 0.4, "mid": 0.25, "top": 0.3})
    assert last == pytest.approx({"bot": 0.975, "mid": 0.76, "top": 0.19 / 0.3}, abs=1e-9)
