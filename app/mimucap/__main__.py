"""``python -m mimucap`` is the same as the ``mimucap`` command."""

from mimucap.cli import main

raise SystemExit(main())
