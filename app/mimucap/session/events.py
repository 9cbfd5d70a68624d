"""Plain-Python events: how session models tell the GUI (or a test) that something changed.

Models in ``mimucap.session`` know nothing of Qt (napari style): each model owns
:class:`EventEmitter` objects, and a widget subscribes with :meth:`EventEmitter.connect`
in its constructor and unsubscribes with :meth:`EventEmitter.disconnect` when it closes.
Callbacks run synchronously, in the thread that calls :meth:`EventEmitter.emit`; the live
pipeline and the review player emit from the thread that drives them (the GUI's timers).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

log = logging.getLogger(__name__)

Callback = Callable[..., Any]


class EventEmitter:
    """A named event with a list of subscribers.

    ``emit(*args, **kwargs)`` calls every connected callback with the same arguments, in
    the order they were connected. A callback that raises is logged and its exception
    propagates to the caller of ``emit``, so that a broken subscriber is seen, not hidden.
    """

    def __init__(self, name: str) -> None:
        self.name = name
        self._callbacks: list[Callback] = []
        self._blocked = 0

    def connect(self, callback: Callback) -> Callback:
        """Subscribe ``callback``; connecting it twice has no extra effect. Returns it."""
        if not callable(callback):
            raise ValueError(f"event {self.name!r}: {callback!r} is not callable")
        if callback not in self._callbacks:
            self._callbacks.append(callback)
        return callback

    def disconnect(self, callback: Callback | None = None) -> None:
        """Unsubscribe ``callback`` (every callback when ``None``); unknown ones are ignored."""
        if callback is None:
            self._callbacks.clear()
        elif callback in self._callbacks:
            self._callbacks.remove(callback)

    @property
    def callbacks(self) -> tuple[Callback, ...]:
        """The connected callbacks, in call order."""
        return tuple(self._callbacks)

    def emit(self, *args: Any, **kwargs: Any) -> None:
        """Call every subscriber with ``args``/``kwargs`` (nothing while blocked)."""
        if self._blocked:
            return
        for callback in tuple(self._callbacks):
            try:
                callback(*args, **kwargs)
            except Exception:
                log.exception("subscriber %r of event %r failed", callback, self.name)
                raise

    def blocked(self) -> "_Blocker":
        """Context manager that suppresses emission while active."""
        return _Blocker(self)


class _Blocker:
    def __init__(self, emitter: EventEmitter) -> None:
        self._emitter = emitter

    def __enter__(self) -> EventEmitter:
        self._emitter._blocked += 1
        return self._emitter

    def __exit__(self, *exc: object) -> None:
        self._emitter._blocked -= 1


class EmitterGroup:
    """A set of named :class:`EventEmitter` objects, reachable as attributes.

    ``events = EmitterGroup("frame", "status")`` gives ``events.frame`` and ``events.status``;
    a typo in a name raises ``AttributeError`` instead of silently creating an event.

    A model composed of parts offers its parts' events under its own names:
    ``EmitterGroup("frame", data=history.events.data)`` gives a new ``frame`` and, as ``data``,
    the very emitter of the part (one list of subscribers: a part that builds something only
    while someone listens sees the subscribers of the whole).
    """

    def __init__(self, *names: str, **shared: EventEmitter) -> None:
        if len(set(names)) != len(names) or set(names) & set(shared):
            raise ValueError(f"duplicate event names in {names} and {tuple(shared)}")
        for name, emitter in shared.items():
            if not isinstance(emitter, EventEmitter):
                raise ValueError(f"event {name!r}: {emitter!r} is not an EventEmitter")
        self._emitters = {name: EventEmitter(name) for name in names}
        self._emitters.update(shared)

    def __getattr__(self, name: str) -> EventEmitter:
        emitters = self.__dict__.get("_emitters", {})
        if name in emitters:
            return emitters[name]
        raise AttributeError(f"no event named {name!r} (known: {', '.join(emitters)})")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self._emitters)

    def disconnect_all(self, callback: Callback | None = None) -> None:
        """Remove ``callback`` (or every callback) from every event of the group."""
        for emitter in self._emitters.values():
            emitter.disconnect(callback)
