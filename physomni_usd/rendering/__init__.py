"""Render: the composed stage, frame by frame, over the background plate, into a video.

A warp ray caster (the same kernels on the CPU and on CUDA) finds, for each
pixel, the object surface it sees; the photo projected onto that surface at
build time gives its colour, and the mask in the texture's alpha cuts the
object out exactly. Ground pixels under an object are darkened by a soft
contact shadow. Frame 0 therefore reproduces the photo.
"""
