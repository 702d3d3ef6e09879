"""``physomni-usd studio``: the set-up page. Objects are picked on the photo in a browser (a box, clicks on
and off the object, a label), pushes drawn as arrows, a force field and a camera move chosen from lists;
"Build" builds the shot and shows its live preview, "Render" writes its video. Everything the page does is
written as command lines (``studio.sh``) and as ``studio.json`` beside the shot, for the CLI to replay.
"""

from .server import Options, Studio, preview_or_set_up
from .session import commands, read_state

__all__ = ["Options", "Studio", "commands", "preview_or_set_up", "read_state"]
