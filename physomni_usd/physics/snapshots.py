"""Copies of Newton states, so that a frame the guard rejects can be rolled back."""

from __future__ import annotations


def snapshot(state, into: dict | None = None) -> dict:
    """Copies of every warp array a Newton state holds, namespaced ones (``state.mpm.*``) included; ``into``,
    an earlier snapshot of the same state no longer needed, has its arrays written over instead of new ones
    allocated (the guard checkpoints every few frames)."""
    import warp as wp

    out = {}
    for key, value in _arrays(state):
        held = into.get(key) if into else None
        if held is not None and held.shape == value.shape and held.dtype == value.dtype:
            wp.copy(held, value)
            out[key] = held
        else:
            out[key] = wp.clone(value)
    return out


def _arrays(state):
    import warp as wp

    for name, value in vars(state).items():
        if isinstance(value, wp.array):
            yield name, value
        elif hasattr(value, "__dict__") and not callable(value):
            for sub, arr in vars(value).items():
                if isinstance(arr, wp.array):
                    yield f"{name}.{sub}", arr


def restore(state, saved: dict) -> None:
    """Put a :func:`snapshot` back into ``state``'s own arrays."""
    for key, arr in saved.items():
        owner = state
        *ns, name = key.split(".")
        for part in ns:
            owner = getattr(owner, part)
        getattr(owner, name).assign(arr)
