"""numba settings of the fusion kernels, and a guard against stale compiled caches.

The kernels read the packed-settings and state layouts (``PI_*`` in :mod:`.params`, ``AX_*``
and ``FLAG_*`` in :mod:`.state`) as compile-time constants. numba's on-disk cache is keyed on
the source file of each kernel only, so after an edit of those layouts a cached kernel would
silently index the wrong entries. Each kernel module therefore compiles a function returning
:data:`LAYOUT_FINGERPRINT` and calls :func:`refresh_if_stale` at import: on a mismatch its
caches are emptied and the kernels compile afresh. (The module compiled ahead of time carries
the same fingerprint in its name: :mod:`.aot`.)
"""

from __future__ import annotations

from numba.core.registry import CPUDispatcher

from mimucap.core.fusion.aot import LAYOUT_FINGERPRINT

#: numba options of every fusion kernel: compiled once and cached on disk; IEEE NaN/inf
#: semantics are kept (no "nnan"/"ninf" fast-math), division follows numpy (no exceptions).
JIT_OPTIONS = dict(cache=True, error_model="numpy", fastmath={"contract", "arcp", "reassoc", "nsz"})


def refresh_if_stale(namespace: dict, compiled_fingerprint: int) -> bool:
    """Empty the on-disk caches of the kernels defined in ``namespace`` (a module's globals)
    when they were compiled against another layout; returns ``True`` if they were stale."""
    if compiled_fingerprint == LAYOUT_FINGERPRINT:
        return False
    for obj in list(namespace.values()):
        if (isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == namespace["__name__"]
                and getattr(obj, "_cache", None) is not None):
            obj._cache.flush()
    return True
