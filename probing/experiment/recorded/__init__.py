"""A user's own recorded data: its columns and time base, the estimates of
``probing analyze`` and foreign logs replayed by the monitor.
"""
