"""`vtol campaign FILE`: many real flights over a grid or seeded samples of scenario parameters, on Dask, into
a DuckDB store, with envelope reports (docs/campaigns.md)."""
