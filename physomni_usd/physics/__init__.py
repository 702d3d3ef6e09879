"""Simulate: the composed stage → a Newton model → time samples in ``sim.usdc``.

Only what the scene needs is built: a rigid-only scene loads Newton's rigid
solver and its contact kernels, nothing else (no MPM grid, no cloth, no torch).
"""
