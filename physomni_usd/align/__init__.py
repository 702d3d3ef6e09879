"""Align: the camera that reproduces the photo, and where each object stands on the ground."""
