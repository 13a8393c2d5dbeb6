"""The run driver as named phases (app/run.py strings them together): build the model,
assemble and factor, unit solutions, condense, the load steps, finish. Each phase is a
function of the run context and the typed results of the phases before it."""
