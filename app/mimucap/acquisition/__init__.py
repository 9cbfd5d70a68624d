"""Wire protocols (pure parsers), device drivers, worker processes, supervisor and time sync.

May import ``core`` only (never ``io``, ``session`` or ``gui``).
"""
