import sys

from app.blas_threads import choose

choose()  # BLAS threads: before numpy loads (several ranks on a node: cores // ranks)
from app.output import startup_signals  # noqa: E402
from app.output.closed_pipes import drop_closed_pipes  # noqa: E402

drop_closed_pipes()  # a closed stdout / stderr pipe does not end the run
startup_signals.arm(None, "", act=False)  # a signal while the modules load is recorded
from app.cli import main  # noqa: E402
from app.exit_sync import end_process  # noqa: E402

code = main()
end_process(code)  # 0: PetscFinalize, then os._exit, past the interpreter's teardown
sys.exit(code)
