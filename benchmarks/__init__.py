"""Side-by-side speed benchmarks of openimp against pylinkage, Exudyn, MuJoCo and Pinocchio.

Run ``python -m benchmarks`` from the repository root; see benchmarks/README.md.
"""
