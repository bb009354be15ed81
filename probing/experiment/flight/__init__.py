"""The flight computer and its worlds: the flight computer, the reference it computes,
the in-process, live and replayed flights and the monitor.
"""
