"""What a flight writes: atomic Parquet files with provenance, their layouts, the
estimates' files, output paths and progress.
"""
