"""``make bench``: performance figures, each measured in the same run as its comparison."""
