"""study_tables.md lists the methods in the order of the study's runs (`--methods`, by
default 1, 2, 3, 4, 8, 16 SD, FEM-Q4): before, it sorted their labels as text, so 16SD
came first, before 1SD, and 8SD after 4SD."""

from app.studies.reference_errors import write_tables


def test_methods_in_the_order_of_the_runs(tmp_path):
    methods = ["1SD", "2SD", "4SD", "8SD", "16SD", "FEM-Q4"]
    rows = [{"level": lv, "method": m, "err_x": 0.1, "n_dofs": 10 * (lv + 1), "t_total": 1.0}
            for lv in range(2) for m in methods]
    text = write_tables(rows, [], tmp_path, "note")
    cells = [[c.strip() for c in line.split("|")[1:3]] for line in text.splitlines()]
    listed = [f"{m}/{lv}" for m, lv in (c for c in cells if len(c) == 2) if m in methods]
    assert listed == [f"{m}/{lv}" for m in methods for lv in range(2)]
