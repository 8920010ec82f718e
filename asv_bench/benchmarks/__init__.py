"""odms-data's speed benchmarks for airspeed velocity (asv); see docs/DEVELOPING.md, Benchmarks."""
