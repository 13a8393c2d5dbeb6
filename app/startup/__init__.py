"""A command's start: PETSc's start with the command line's options (petsc.py) and the
`failed` summary.json of input refused before a run or study starts (early_failure.py:
before PETSc starts; input_failure.py: after). Above app/run.py; below app/studies/ and
app/cli.py.
"""
