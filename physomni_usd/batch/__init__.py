"""``batch``: many ``run`` shots from a list, as Ray tasks, resumable, each failure kept to its shot.

:mod:`.shots` reads the list and decides what is finished (no Ray needed);
:mod:`.runner` runs the rest on Ray; :mod:`.progress` shows it.
"""
