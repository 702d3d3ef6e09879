"""Estimate: the physical material of each object (built in: a keyword table)."""
