"""The live pages' numbers, with their options, defaults and ranges (:class:`~physomni_usd.limits.Limits`):
the preview's (:class:`~.app.Options`) and the set-up page's, ``studio``'s, whose preview takes the port after
its own. The pages check their options against these, and the commands read their options from them."""

from __future__ import annotations

from ..limits import Limit, Limits

_DURATION = Limit("--duration", "Quit after this many seconds (for scripts)", 0, 86400, None, lo_open=True,
                  default_text="run until Ctrl-C")
PREVIEW = Limits(
    port=Limit("--port", "Port of the page.", 1, 65535, 8080, whole=True),
    duration=_DURATION,
)
STUDIO = Limits(
    port=Limit("--port", "Port of the page; the live preview takes the next one.", 1, 65534, 8070, whole=True),
    duration=_DURATION,
)
