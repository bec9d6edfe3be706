"""``python -m motionrep``: the command line (same as the ``motionrep`` console script)."""

from .cli import main

main()
