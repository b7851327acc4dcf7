"""Worked examples of extending the testbed."""
