"""Probe design: what is asked, what the design measures by flying, the noise model it
predicts with, and the designed probe's export.
"""
