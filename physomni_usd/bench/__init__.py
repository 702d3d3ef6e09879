"""Benchmarks behind ``physomni-usd bench``: they print a table and write the same numbers as JSON."""
