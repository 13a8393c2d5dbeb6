"""Session set-up shared by every test module.

A suite started in the background by a shell without job control (`bash scripts/test.sh &`
in a script, `nohup`) inherits SIGINT ignored, and so would every run the tests start:
the tests of Ctrl-C (a run's `interrupted` summary, the hard stop's hand-back to Python)
then failed, the signal never arriving (3 of them on a fresh clone run that way). The
tests send SIGINT on purpose, so the suite restores Python's own handler; the processes
it starts then get the default disposition (a caught signal is reset on exec)."""

import signal

if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
