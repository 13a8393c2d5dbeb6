import sys

from app.output import startup_signals

startup_signals.arm(None, "", act=False)  # a signal while the modules load is recorded
from app.cli import main  # noqa: E402

sys.exit(main())
