"""Benchmarks, the soak run, the ragdoll baseline and the shoe-model fit: ``jostle bench NAME``.

The table of benches is :mod:`jostle.bench.table`. Benches may import every layer; nothing in
sensors/, interaction/, sim/ or render/ imports them. Nothing is imported here.
"""
