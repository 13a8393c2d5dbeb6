"""scripts/plot_results.py names each interface's plot after the interface, also where
the config has a closed form: before, the first interface's plot of hertz.toml was
written as contact_Hertz.png and titled "interface 'Hertz'" (the overlay's label took
the interface name's variable)."""

import subprocess
import sys

from support import CONFIGS, ROOT, mpi_env, run_cli


def test_plot_named_after_the_interface_with_a_reference(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(out), "--quiet"])
    assert res.returncode == 0, res.stderr
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "plot_results.py"), str(out)],
                         cwd=ROOT, env=mpi_env(), capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in out.glob("contact_*.png")) == ["contact_contact.png"]
