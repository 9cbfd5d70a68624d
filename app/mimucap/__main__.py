"""``python -m mimucap`` is the same as the ``mimucap`` command; also the desktop bundle's entry.

In the PyInstaller bundle the acquisition worker processes (started with ``spawn``) run this
same executable: ``freeze_support`` turns such a start into the worker instead of a second
application. Outside a bundle it would do nothing, so :mod:`multiprocessing` (tens of
milliseconds of imports) is not loaded there.
"""

import sys

from mimucap.cli import main

if __name__ == "__main__":
    if getattr(sys, "frozen", False):
        import multiprocessing

        multiprocessing.freeze_support()
    raise SystemExit(main())
