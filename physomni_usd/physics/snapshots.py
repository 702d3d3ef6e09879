"""Copies of Newton states, so that a frame the guard rejects can be rolled back."""

from __future__ import annotations


def snapshot(state) -> dict:
    """Copies of every warp array a Newton state holds, namespaced ones (``state.mpm.*``) included."""
    import warp as wp

    out = {}
    for name, value in vars(state).items():
        if isinstance(value, wp.array):
            out[name] = wp.clone(value)
        elif hasattr(value, "__dict__") and not callable(value):
            for sub, arr in vars(value).items():
                if isinstance(arr, wp.array):
                    out[f"{name}.{sub}"] = wp.clone(arr)
    return out


def restore(state, saved: dict) -> None:
    """Put a :func:`snapshot` back into ``state``'s own arrays."""
    for key, arr in saved.items():
        owner = state
        *ns, name = key.split(".")
        for part in ns:
            owner = getattr(owner, part)
        getattr(owner, name).assign(arr)
