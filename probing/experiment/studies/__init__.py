"""The studies: Fig. 4, the excitations, NASA's Example 6, the mode table, several
surfaces at once and manoeuvres (runners and their light set-ups).
"""
