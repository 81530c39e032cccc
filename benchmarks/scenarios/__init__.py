"""Scenarios the benchmarks (and their tests) share, kept out of the armlab package: they measure the kit, they are
not part of it. Importable with benchmarks/ on sys.path (a benchmark run as a script has it there)."""
