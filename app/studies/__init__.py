"""Studies: many runs of one config (app/run.py) and their figures.

A convergence study over levels and methods (convergence.py, with the level's mesh
level_mesh.py, the errors against a reference of the same model reference_errors.py, its
Richardson reference richardson_reference.py over the numpy kernel richardson.py, and the
runs an interrupt left out missing_runs.py), a parameter sweep (sweep.py), a study's or
sweep's own summary.json (batch_status.py), the energy bracket of `run --energy-bracket`
(energy_bracket.py) and the numpy breakdowns of field errors used by scripts
(l2_breakdown.py, field_breakdown.py). Above app/run.py and app/startup/; below app/cli.py.
"""
