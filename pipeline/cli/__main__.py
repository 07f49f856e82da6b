"""``python -m shellvox.cli``: the ``shellvox`` command without the installed script.

SIGINT and SIGTERM are blocked from the first line, before any import: a signal that
comes before :func:`shellvox.cli.main` has its handlers in place is held back, then stops
the run with its one line (instead of a silent death by SIGTERM or a KeyboardInterrupt
traceback). Only the interpreter's own start-up, before this line, is left to the
signals' default actions.
"""

import signal

signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})

import sys  # noqa: E402

from shellvox.cli import main  # noqa: E402

sys.exit(main())
