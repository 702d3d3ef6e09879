"""Shared primitives below every stage: the pinhole camera (:mod:`.camera`) and the warp ray caster
(:mod:`.raycast`) that perceive, align and render all use, and the ground a depth map sees (:mod:`.depth`)."""
