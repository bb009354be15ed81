"""Analysis of probing results: reads Parquet only, draws figures and tables."""
